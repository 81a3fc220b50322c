#pragma once
// Order tracking of a waveform record (docs/real-data.md): each constant-speed dwell of a record
// (docs/data-format.md) timed by its keyphasor becomes one row of an order-tracked table, its
// x and y probes' 1X and 2X vectors fitted by least squares to the dwell's samples (a mean and
// each order's cosine and sine up to the 8th: exact for any sampling, whole revolutions or not). What a rig's
// monitoring system exports, made from rubref's own records: the tests' tables with a known truth.

#include <string>

#include "ref/format/order_table.hpp"
#include "ref/format/record.hpp"

namespace rubref {

// Probes "x" (0 deg) and "y" (90 deg), orders 1 and 2; `notes` as the keyphasor alignment says.
order_table track_orders(const record& r, const std::string& source);

}  // namespace rubref
