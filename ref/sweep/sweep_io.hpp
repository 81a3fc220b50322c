#pragma once
// Sweep results as tables and JSON (docs/sweeps.md lists every column).

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ref/format/record.hpp"
#include "ref/format/table.hpp"
#include "ref/sweep/sweep.hpp"

namespace rubref {

// Orders reported per speed: integer orders -5..+5 and the subharmonic families of partial rub.
struct order_column {
  double order;      // negative: backward whirl
  std::string name;  // e.g. amp_f1x_m (forward 1X), amp_b1_2x_m (backward 1/2 X), amp_0x_m
};
const std::vector<order_column>& reported_orders();

// One row per speed and direction: the summary, the regime, the whirl, the order amplitudes.
table sweep_table(const sweep_settings& s, const std::vector<sweep_branch>& branches);

// Waterfall (cascade) data of one branch: speed_rpm, order, amplitude_m for |order| <= max_order.
table waterfall_table(const sweep_settings& s, const sweep_branch& b, double max_order = 5.0);

// Where a branch whirls backward (backward 1X above forward 1X), and where it touches the stator.
speed_ranges backward_whirl_ranges(const sweep_branch& b);
speed_ranges rub_ranges(const sweep_branch& b);

// Settings, per-branch counts and backward-whirl ranges, and the jump report when both
// directions ran.
nlohmann::ordered_json sweep_summary_json(const sweep_settings& s, const std::vector<sweep_branch>& branches);

// The recorded orbit of one sweep point as a record (needs keep_orbits).
record orbit_record(const sweep_settings& s, const sweep_point& p);

// A branch as one measurement record of constant-speed dwells (needs keep_orbits), in the order
// visited. Each dwell's times are shifted by a whole number of its own periods to follow the
// previous dwell, so t_s keeps meaning the unbalance phase w t at every sample.
record dwell_record(const sweep_settings& s, const sweep_branch& b);

// The settings as JSON: the provenance lines below, numbers as numbers.
nlohmann::ordered_json sweep_settings_json(const sweep_settings& s);

// Provenance lines for any sweep output.
std::vector<std::pair<std::string, std::string>> sweep_metadata(const sweep_settings& s);

}  // namespace rubref
