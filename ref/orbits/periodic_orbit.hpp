#pragma once
// A steady orbit as a fixed point of the n-revolution map (docs/orbits.md): shooting from the
// contact-free response, then from a short transient, and only then a long transient, which the
// result says it is. The front door of `rubref orbit`.

#include <complex>
#include <optional>
#include <string>
#include <vector>

#include "ref/run/simulate.hpp"

namespace rubref {

struct periodic_orbit_request {
  run_request run;      // variant, parameters, speed, samples per revolution, integration of the recorded period
  // Defaults, units and ranges: the settings registry (ref/model/settings.hpp).
  int periods = default_count_of("shooting", "periods");  // revolutions per period (n > 1 for subharmonic orbits)
  int transient_revs = default_count_of("shooting", "transient_revs");  // the second start: this many revolutions from the first
  int fallback_settle_revs = default_count_of("shooting", "fallback_settle_revs");  // the fallback: a transient this long
  double tolerance = kShootingTolerance;  // m, |P(s) - s| at convergence (velocities / |w|)
  // The first start, a state at t = 0 (e.g. a branch point of `rubref continuation`, to pick one
  // of coexisting orbits); default: the contact-free response.
  std::optional<state_type> initial_guess;
};

struct periodic_orbit_result {
  orbit samples;  // one period from t = 0 (samples, events, counts); request.initial_state is the orbit's state
  std::string method;  // "shooting" or "transient" (Newton failed at both starts)
  std::string start;   // "contact-free response" or "<k>-revolution transient"
  std::string failure; // why shooting failed (empty when it converged)
  bool converged = false;
  int iterations = 0;        // Newton iterations, both starts
  double residual = 0.0;     // m
  std::vector<std::complex<double>> multipliers;  // Floquet multipliers, largest modulus first
  double max_multiplier_modulus = 0.0;
  bool stable = false;
  std::size_t events_per_period = 0;
};

// `periods` revolutions of the model of `run` from `on_orbit` at t0 (s), sampled at
// run.samples_per_rev on the grid t0 + k T / samples_per_rev (run.integration): with t0 = s T,
// the grid of `simulate` after s settling revolutions (the result's request says s; its
// initial_state is `on_orbit`, the state at t0).
orbit record_periods(const run_request& run, const state_type& on_orbit, int periods, double t0 = 0.0);

// How `shoot_from` shoots: its tolerance, the map's start time, and its stepper.
struct shot_options {
  double tolerance = kShootingTolerance;  // m, |P(s) - s| at convergence (velocities / |w|)
  double t0 = 0.0;           // s: the map from t0 to t0 + periods T
  std::optional<stepper_settings> stepper;  // default: the shooting's own (ref/integrate/shooting.hpp)
};

// Newton alone from `guess` at t0, with no second start and no fallback (a sweep's start from
// its neighbour's orbit, a golden case's settled state): `samples` stays empty; `converged` says
// whether it found one. Events are located as run.integration.events says.
periodic_orbit_result shoot_from(const run_request& run, const state_type& guess, int periods, const shot_options& opt = {});

// Validates (input_error), then finds the orbit. A numerical failure of the fallback is a
// numerical_error; a failed Newton is reported in the result, never hidden.
periodic_orbit_result find_periodic_orbit(const periodic_orbit_request& req);

}  // namespace rubref
