#include "ref/orbits/periodic_orbit.hpp"

#include <cmath>

#include "ref/base/errors.hpp"
#include "ref/format/record.hpp"
#include "ref/integrate/shooting.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

namespace {

struct recorder {
  std::vector<orbit_sample>* samples;
  std::vector<contact_event>* events;
  template <class System>
  void on_sample(double t, const state_type& s, const System& sys) {
    samples->push_back({t, s, sys.normal_force(s, t)});
  }
  void on_event(const contact_event& e) { events->push_back(e); }
};

template <int N>
void take_shot(periodic_orbit_result& out, const periodic_orbit<N>& shot) {
  out.converged = shot.converged;
  if (!shot.converged) {
    out.failure = shot.failure;
    return;
  }
  out.method = "shooting";
  out.residual = shot.residual;
  out.multipliers = shot.multipliers;
  out.max_multiplier_modulus = shot.max_multiplier_modulus();
  out.stable = shot.stable();
  out.events_per_period = shot.events_per_period;
}

}  // namespace

periodic_orbit_result shoot_from(const run_request& run, const state_type& guess, int periods, const shot_options& opt) {
  return visit_variant(run.variant, [&]<class Law>() {
    const rotor_system<Law> model(run.params, rpm_to_rad_s(run.rpm));
    shooting_settings set;
    set.tolerance = opt.tolerance;
    if (opt.stepper) set.integration.stepper = *opt.stepper;
    set.integration.events = run.integration.events;
    periodic_orbit_result out;
    out.start = "given state";
    const auto shot = shoot_periodic_orbit(model, guess, opt.t0, periods, set);
    out.iterations = shot.iterations;
    take_shot(out, shot);
    out.samples.request = run;
    out.samples.request.initial_state = shot.state;
    return out;
  });
}

periodic_orbit_result find_periodic_orbit(const periodic_orbit_request& req) {
  check({"shooting", "periods"}, req.periods);
  check({"shooting", "transient_revs"}, req.transient_revs);
  check({"shooting", "fallback_settle_revs"}, req.fallback_settle_revs);
  check({"shooting", "tolerance"}, req.tolerance);
  if (req.initial_guess)
    for (const double v : *req.initial_guess) require(std::isfinite(v), "the initial state must be finite");
  run_request run = req.run;
  run.settle_revs = 0;
  run.record_revs = req.periods;
  validate(run);

  return visit_variant(run.variant, [&]<class Law>() {
    const double omega = rpm_to_rad_s(run.rpm);
    const rotor_system<Law> model(run.params, omega);
    const double period = model.period();
    shooting_settings set;
    set.tolerance = req.tolerance;
    set.integration.events = run.integration.events;
    periodic_orbit_result out;

    // Start 1: the given state, or the contact-free steady response at t = 0 (closed form).
    state_type guess;
    if (req.initial_guess) {
      guess = *req.initial_guess;
      out.start = "given state";
    } else {
      parameters free = run.params;
      free.clearance = std::numeric_limits<double>::max();
      guess = free_flight<4>(*rotor_system<Law>(free, omega).free_dynamics()).particular(0.0);
      out.start = "contact-free response";
    }
    if constexpr (!compliant_law<Law>) {
      if (model.penetration(guess) > 0.0) guess[idx::y] = run.params.clearance;  // an impact law starts outside
    }
    // A contact-free response or a short transient is far from a rubbing orbit: coarse
    // evaluations until Newton is close (inexact Newton, ref/integrate/shooting.hpp).
    set.coarse_while_far = !req.initial_guess;
    auto shot = shoot_periodic_orbit(model, guess, 0.0, req.periods, set);
    out.iterations = shot.iterations;
    if (!shot.converged && req.transient_revs > 0) {
      // Start 2: a short transient from there (the system is T-periodic: its state after k T is a
      // state at t = 0).
      null_observer none;
      const auto settled = integrate_hybrid(model, start_state(model, guess, 0.0), req.transient_revs * period, set.integration,
                                            sample_grid{}, none);
      out.start = std::to_string(req.transient_revs) + "-revolution transient";
      set.coarse_while_far = true;
      shot = shoot_periodic_orbit(model, settled.s, 0.0, req.periods, set);
      out.iterations += shot.iterations;
    }
    state_type on_orbit = shot.state;
    take_shot(out, shot);
    if (!shot.converged) {
      // The fallback: a long transient, as `simulate` does; said so in the result.
      out.method = "transient";
      null_observer none;
      on_orbit = integrate_hybrid(model, start_state(model, req.initial_guess.value_or(state_type{}), 0.0), req.fallback_settle_revs * period, run.integration,
                                  sample_grid{}, none).s;
      out.residual = std::numeric_limits<double>::quiet_NaN();
    }

    out.samples = record_periods(run, on_orbit, req.periods);
    return out;
  });
}

orbit record_periods(const run_request& run, const state_type& on_orbit, int periods, double t0) {
  return visit_variant(run.variant, [&]<class Law>() {
    const rotor_system<Law> model(run.params, rpm_to_rad_s(run.rpm));
    orbit out;
    out.request = run;
    out.request.initial_state = on_orbit;
    out.request.settle_revs = static_cast<int>(std::lround(t0 / model.period()));
    out.request.record_revs = periods;
    const sample_grid grid{t0, model.period() / run.samples_per_rev,
                           static_cast<std::size_t>(periods) * static_cast<std::size_t>(run.samples_per_rev)};
    recorder obs{&out.samples, &out.events};
    out.end = integrate_hybrid(model, start_state(model, on_orbit, t0), t0 + periods * model.period(), run.integration, grid,
                               obs, &out.counts);
    return out;
  });
}

}  // namespace rubref
