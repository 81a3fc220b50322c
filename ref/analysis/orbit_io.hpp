#pragma once
// A simulated orbit as a record (docs/data-format.md) and its summary as JSON.

#include <nlohmann/json.hpp>
#include <span>
#include <vector>

#include "ref/analysis/orbit_summary.hpp"
#include "ref/format/record.hpp"

namespace rubref {

// Orbit samples gathered as the record columns t_s,x_m,y_m,speed_rpm,vx_m_s,vy_m_s,fn_N.
struct orbit_columns {
  std::vector<double> t, x, y, rpm, vx, vy, fn;
  void append(std::span<const orbit_sample> samples, double speed_rpm, double time_shift = 0.0);
  void move_into(record& r);
};

// Columns t_s,x_m,y_m,speed_rpm,vx_m_s,vy_m_s,fn_N; metadata: provenance, every parameter, the
// speed, sampling, variant, stepper and tolerances. No wall-clock date: same inputs, same bytes.
record to_record(const orbit& o);

nlohmann::ordered_json to_json(const orbit_summary& s, const orbit& o);

}  // namespace rubref
