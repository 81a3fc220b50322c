#include "ref/run/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "ref/base/errors.hpp"
#include "ref/format/record.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

namespace {


struct recorder {
  double t_record;
  std::vector<orbit_sample>* samples;
  std::vector<contact_event>* events;

  template <class System>
  void on_sample(double t, const state_type& s, const System& sys) {
    samples->push_back({t, s, sys.normal_force(s, t)});
  }
  void on_event(const contact_event& e) {
    if (e.t >= t_record) events->push_back(e);
  }
};

}  // namespace

namespace {
struct rate {
  double value;
  std::string what;
};
// The fastest rate of Eq. 1: free, or on the stator's spring for a compliant law.
rate fastest_rate(const parameters& p, bool compliant) {
  std::vector<rate> rates{{std::sqrt(p.k_x / p.m), "sqrt(k_x/m)"}, {std::sqrt(p.k_y / p.m), "sqrt(k_y/m)"},
                          {p.c_x / p.m, "c_x/m"}, {p.c_y / p.m, "c_y/m"}};
  if (compliant) rates.push_back({std::sqrt(p.k1 / p.m), "sqrt(k1/m)"});
  return *std::max_element(rates.begin(), rates.end(), [](const rate& a, const rate& b) { return a.value < b.value; });
}
}  // namespace

void require_safe_rates(const parameters& p, bool compliant, double duration) {
  // The fastest rate times the run's duration. Every explicit stepper needs rate * dt below ~1 to
  // stay stable, so beyond kMaxRateTimesDuration the run could not finish (or finish right) in any
  // reasonable time.
  const rate fastest = fastest_rate(p, compliant);
  require(fastest.value * duration <= kMaxRateTimesDuration,
          "numerically dangerous parameters: " + fastest.what + " = " + format_number(fastest.value) + " 1/s over the run's " + format_number(duration) +
              " s needs more than " + format_number(kMaxRateTimesDuration) + " stable steps (m_kg = " + format_number(p.m) + ")");
}

void validate(const run_request& req) {
  validate(req.params);
  visit_variant(req.variant, []<class V>() {});  // unknown variant -> input_error
  // Each setting against its range in the registry (ref/model/settings.hpp).
  check({"run", "rpm"}, req.rpm);
  check({"run", "settle_revs"}, req.settle_revs);
  check({"run", "record_revs"}, req.record_revs);
  check({"run", "samples_per_rev"}, req.samples_per_rev);
  const auto& st = req.integration.stepper;
  check({"integration", "rtol"}, st.rtol);
  check({"integration", "atol"}, st.atol);
  check({"integration", "dt"}, st.dt);
  check({"integration", "max_dt"}, st.max_dt);
  const auto& ev = req.integration.events;
  check({"integration", "event_tol"}, ev.time_tolerance);
  check({"integration", "stick_time"}, ev.stick_time);
  check({"integration", "max_events_per_rev"}, ev.max_events_per_rev);
  check({"integration", "runaway_displacement"}, req.integration.runaway_displacement);
  require(is_finite(req.initial_state), "initial state must be finite");
  const double revs = double(req.settle_revs) + double(req.record_revs);
  require(revs * req.samples_per_rev <= 1e8, "(" + setting("settle_revs") + " + " + setting("record_revs") + ") times " + setting("samples_per_rev") + " is over 1e8 samples");

  const bool compliant = visit_variant(req.variant, []<class Law>() { return compliant_law<Law>; });
  require_safe_rates(req.params, compliant, revs * 60.0 / req.rpm);
  if (st.kind == stepper_kind::rk4 && st.dt > 0.0) {
    const rate fastest = fastest_rate(req.params, compliant);
    require(fastest.value * st.dt <= kRk4StableRateDt,
            "dt = " + format_number(st.dt) + " s is beyond rk4's stability for this rotor: " + fastest.what + " * dt = " + format_number(fastest.value * st.dt) +
                " > " + format_number(kRk4StableRateDt) + "; use dt <= " + format_number(kRk4StableRateDt / fastest.value) + " s or an adaptive stepper");
  }
}

orbit simulate(const run_request& req) {
  validate(req);
  return visit_variant(req.variant, [&]<class Law>() {
    const double omega = rpm_to_rad_s(req.rpm);
    const double period = 2.0 * std::numbers::pi / omega;
    const rotor_system<Law> model(req.params, omega);

    orbit out;
    out.request = req;
    const double t_record = req.settle_revs * period;
    const double t_end = (req.settle_revs + req.record_revs) * period;
    const sample_grid grid{t_record, period / req.samples_per_rev,
                           static_cast<std::size_t>(req.record_revs) * static_cast<std::size_t>(req.samples_per_rev)};
    out.samples.reserve(grid.count);
    recorder obs{t_record, &out.samples, &out.events};
    out.end = integrate_hybrid(model, start_state(model, req.initial_state, 0.0), t_end, req.integration, grid, obs, &out.counts);
    return out;
  });
}

std::string coarse_contact_warning(const integration_counts& c) {
  if (c.coarse_contact_steps == 0) return {};
  std::ostringstream out;
  out.precision(4);
  out << "warning: " << c.coarse_contact_steps << " fixed rk4 steps (dt = " << c.fixed_dt << " s) crossed a contact at rate * dt up to "
      << c.max_contact_rate_dt << " (> " << kCoarseContactStep << "), first at t = " << c.first_coarse_contact_t
      << " s: the contact is under-resolved and the orbit may be wrong; use a smaller " << setting("dt") << " or an adaptive stepper";
  return out.str();
}

void accumulate(integration_counts& total, const integration_counts& c) {
  if (c.coarse_contact_steps > 0 && total.coarse_contact_steps == 0) total.first_coarse_contact_t = c.first_coarse_contact_t;
  total.steps += c.steps;
  total.events += c.events;
  total.coarse_contact_steps += c.coarse_contact_steps;
  total.max_contact_rate_dt = std::max(total.max_contact_rate_dt, c.max_contact_rate_dt);
  total.fixed_dt = std::max(total.fixed_dt, c.fixed_dt);
}

}  // namespace rubref
