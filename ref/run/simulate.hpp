#pragma once
// One steady-state run at a fixed speed: settle, then record whole revolutions on a uniform
// grid. The front door for the CLI's `simulate` and for tests that need an orbit of any variant.

#include <string>
#include <vector>

#include "ref/integrate/hybrid_integrator.hpp"
#include "ref/model/parameters.hpp"

namespace rubref {

struct run_request {
  std::string variant = "identified";
  parameters params;
  // Defaults, units and ranges: the settings registry (ref/model/settings.hpp).
  double rpm = default_of("run", "rpm");                          // rev/min, constant speed
  int settle_revs = default_count_of("run", "settle_revs");       // revolutions discarded before recording
  int record_revs = default_count_of("run", "record_revs");       // revolutions recorded
  int samples_per_rev = default_count_of("run", "samples_per_rev");  // output samples per revolution
  integration_options integration;
  state_type initial_state{};      // at t = 0; default: the rotor at rest at the origin
};

struct orbit_sample {
  double t;      // s, absolute: the unbalance force is m e w^2 (cos wt, sin wt) at this t
  state_type s;  // m, m, m/s, m/s
  double fn;     // N, normal contact force (stator reaction while stuck)
};

struct orbit {
  run_request request;
  std::vector<orbit_sample> samples;  // record_revs * samples_per_rev, from t = settle_revs T
  std::vector<contact_event> events;  // located events within the recorded window
  hybrid_state end;                   // where the run stopped, for continuation
  integration_counts counts;          // whole run, settle included
};

// Largest product of the model's fastest rate (sqrt(k/m), c/m, sqrt(k1/m)) and a run's duration:
// ~1e9 explicit steps at rate * dt = 1. The paper's rotor over 208 revolutions at 1600 rpm: 1.2e4.
inline constexpr double kMaxRateTimesDuration = 1e9;

// Largest speed accepted; far above any rotor kit, it only keeps the period well resolved in t.
inline constexpr double kMaxSpeedRpm = setting_named("run", "rpm").range.hi;

// RK4 is stable for a mode with rate * dt up to 2.785 on the negative real axis and 2.828 on the
// imaginary one; a fixed step beyond the smaller for the rotor's fastest mode (free, or on the
// stator's spring for a compliant law) diverges, so it is refused before integrating.
inline constexpr double kRk4StableRateDt = 2.78;

// Throws input_error if the model's fastest rate times `duration_s` exceeds kMaxRateTimesDuration
// (after validate(parameters): finite, positive values).
void require_safe_rates(const parameters& p, bool compliant, double duration_s);

// Throws input_error naming the first bad parameter or setting.
void validate(const run_request& req);

// Validates, then integrates. Throws input_error or numerical_error, never returns a partial orbit.
orbit simulate(const run_request& req);

// A fixed-step run that crossed contacts too coarsely (integration_counts::coarse_contact_steps):
// a one-line warning with the count, the first time and the largest rate * dt; "" otherwise.
std::string coarse_contact_warning(const integration_counts& c);
// Adds another run's counts (steps, events, coarse contact steps) to `total`.
void accumulate(integration_counts& total, const integration_counts& c);

}  // namespace rubref
