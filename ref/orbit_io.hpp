#pragma once
// A simulated orbit as a record (docs/data-format.md) and its summary as JSON.

#include <nlohmann/json.hpp>

#include "ref/orbit_summary.hpp"
#include "ref/record.hpp"

namespace rubref {

// Columns t_s,x_m,y_m,speed_rpm,vx_m_s,vy_m_s,fn_N; metadata: provenance, every parameter, the
// speed, sampling, variant, stepper and tolerances. No wall-clock date: same inputs, same bytes.
record to_record(const orbit& o);

nlohmann::ordered_json to_json(const orbit_summary& s, const orbit& o);

}  // namespace rubref
