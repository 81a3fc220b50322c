#pragma once
// Branches of periodic orbits by pseudo-arclength continuation (docs/orbits.md): the orbits of the
// n-revolution map followed in speed, clearance, unbalance or mu, through folds, with their
// Floquet multipliers, and the points where the branch folds (the jumps), grazes the stator,
// doubles its period or loses stability to a torus. The front door of `rubref continuation`.

#include <complex>
#include <string>
#include <string_view>
#include <vector>

#include "ref/analysis/orbit_summary.hpp"
#include "ref/run/simulate.hpp"

namespace rubref {

enum class continuation_parameter { speed, clearance, unbalance, mu };
std::string_view to_string(continuation_parameter p);
continuation_parameter parse_continuation_parameter(const std::string& name);  // input_error if unknown
// The branch table's column of the parameter, with its unit: speed_rpm, clearance_m, e_m, mu.
std::string_view column_name(continuation_parameter p);

struct continuation_request {
  std::string variant = "identified";
  parameters params;
  continuation_parameter parameter = continuation_parameter::speed;
  // Defaults, units and ranges: the settings registry (ref/model/settings.hpp).
  double from = default_of("continuation", "from");  // the parameter's unit: rpm, m, m, 1; from < to
  double to = default_of("continuation", "to");
  bool downward = false;  // trace from `to` down to `from` (another branch where several coexist)
  double rpm = default_of("continuation", "rpm");  // the speed when the parameter is not the speed
  int periods = default_count_of("continuation", "periods");  // revolutions per period of the orbits followed
  int samples_per_rev = default_count_of("continuation", "samples_per_rev");  // of each point's recorded period (its summary)
  // Arclength in the scaled unknowns: states over the clearance (velocities also over |w|), the
  // parameter over |to - from|; one unit spans the range.
  // The step follows the branch's turning (ref/orbits/continuation.cpp, next_step); max_step
  // only caps it on nearly straight stretches.
  double initial_step = default_of("continuation", "initial_step");
  double max_step = default_of("continuation", "max_step");
  double min_step = default_of("continuation", "min_step");
  int max_points = default_count_of("continuation", "max_points");
  double tolerance = kShootingTolerance;  // m, |P(s) - s| at each point (velocities / |w|)
  integration_options integration;
};

struct branch_point {
  double parameter = 0.0;  // its unit
  double rpm = 0.0;
  state_type state{};      // on the orbit at t = 0
  bool stable = false;
  double max_floquet_modulus = 0.0;
  std::vector<std::complex<double>> multipliers;  // largest modulus first
  orbit_summary summary;   // of one recorded period
  double max_z = 0.0;      // m, the largest penetration over the period; < 0: clear of the stator by -max_z
  int newton_iterations = 0;
  double tangent_parameter = 0.0;  // the parameter's share of the unit tangent (its sign flips at a fold)
};

enum class special_kind { fold, grazing, period_doubling, neimark_sacker };
std::string_view to_string(special_kind k);

struct special_point {
  special_kind kind;
  double parameter = 0.0;
  double rpm = 0.0;
  state_type state{};
  bool located = false;      // false: only bracketed, the values are the bracket's nearer end
  // Between points[after_point] and points[after_point + 1]; a grazing that ends the branch is
  // at points[after_point], the last.
  std::size_t after_point = 0;
};

struct continuation_result {
  std::vector<branch_point> points;  // in the order traced
  std::vector<special_point> special;
  std::string start;    // how the first orbit was found
  std::string stopped;  // why the branch ends ("reached the end of the range", ...)
  bool reached_end = false;
};

// Throws input_error naming the first bad setting (parameters checked at both ends of the range).
void validate(const continuation_request& req);

// Traces the branch from `from` towards `to` (downward: the other way). A failure to find the first orbit is a
// numerical_error; a branch that cannot go on says why in `stopped` (reached_end false).
continuation_result continue_branch(const continuation_request& req);

// The run a branch point's parameter value stands for (variant, parameters, speed, sampling).
run_request request_at(const continuation_request& req, double parameter);

}  // namespace rubref
