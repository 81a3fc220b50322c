#pragma once
// Periodic orbits as the fits compare them with data: the loop's predictor, the tables' rub fit,
// identification's orbit and output-error fits and validate's diagnosis shoot with these options
// and sample with this integration, from the settings registry (scope "fit_orbits"); none makes
// its own. The shooting is the one routine (ref/integrate/shooting.hpp: Newton on the
// n-revolution map with its exact monodromy).

#include "ref/integrate/shooting.hpp"

namespace rubref {

struct fit_orbit_options {
  // Newton's iterations: from a neighbouring point's orbit shooting converges in a few; a trial
  // model that needs more is far off the data and is a failed point.
  int max_iterations = default_count_of("fit_orbits", "max_iterations");
  // Steps per revolution beyond which a trial model is a failed point rather than integrated (a
  // revolution of the paper's model takes ~10^3).
  int max_steps_per_revolution = default_count_of("fit_orbits", "max_steps_per_revolution");
  double tolerance = kShootingTolerance;  // m, |P(s) - s|
  // The shooting's tolerance and both steppers' rtol and atol times this (the stability check).
  double tolerance_scale = default_of("fit_orbits", "tolerance_scale");
  // The largest error of a shot and sampled orbit's state, m: the shooting's tolerance, scaled
  // (the sampling's, ~1e-13 m on a 0.3 mm orbit, lies below it).
  double orbit_error() const { return tolerance * tolerance_scale; }
  void validate() const;                  // input_error naming the setting
};

// The shooting's settings for a fit's orbit of `periods` revolutions (its stepper the shooting's
// own: rkf78 at 1e-12 / 1e-16).
shooting_settings fit_shooting(int periods = 1, const fit_orbit_options& o = {});

// The integration that samples a shot orbit on the data's grid, or settles a transient of
// `revolutions`: the registry's integration tolerances (rtol 1e-10, atol 1e-14: ~1e-13 m on a
// 0.3 mm orbit, below every difference a fit takes), the step budget as the shooting's per revolution.
integration_options fit_sampling(int revolutions = 1, const fit_orbit_options& o = {});

// The integration that settles a transient of `revolutions` whose end is not read as samples: the
// state a shooting starts again from, or that one revolution is read from (by fit_sampling) where
// no shooting converges. Newton's basin is far wider, and a table's noise (>= 1e-8 m) far above,
// than this end's error: fit_sampling's tolerances times kSettleLoosening (rtol 1e-7, atol 1e-11 m).
inline constexpr double kSettleLoosening = 1e3;
integration_options fit_settling(int revolutions, const fit_orbit_options& o = {});

// The model's periodic orbit of `periods` revolutions near `guess` at t0.
template <class System>
auto shoot_fit_orbit(const System& sys, const state_of<System>& guess, double t0, int periods = 1, const fit_orbit_options& o = {}) {
  return shoot_periodic_orbit(sys, guess, t0, periods, fit_shooting(periods, o));
}

}  // namespace rubref
