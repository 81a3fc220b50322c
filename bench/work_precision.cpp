// Work-precision study (docs/performance.md): for each stepper and setting, the largest error
// of the steady-state orbit against a golden orbit (docs/validation.md) and the wall time of the
// whole run (200 settle + 8 recorded revolutions from rest), with located contact events (rubref's
// hybrid integrator) and without (Eq. 2 as written, the contact switch inside the RHS, odeint's
// integrate_times as a user would call it).
//
//   work_precision [GOLDEN.csv] > table.csv      (default: golden/identified_0.3mm_1600rpm.csv)
//
// Output: CSV rows  method,events,setting,steps,error_m,time_s  (setting: "dt = T/N" or "rtol 1e-N";
// time: best of kRepeats runs).

#include <algorithm>
#include <boost/numeric/odeint.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "ref/base/errors.hpp"
#include "ref/format/record.hpp"
#include "ref/model/rotor_model.hpp"
#include "ref/run/simulate.hpp"
#include "ref/validation/golden.hpp"
#include "variants/all_variants.hpp"

namespace rubref {
namespace {

namespace ode = boost::numeric::odeint;
constexpr int kRepeats = 3;  // best of: the machine's noise is one-sided (other load only slows)

struct result {
  std::size_t steps = 0;
  double error = 0.0;  // m
  double seconds = std::numeric_limits<double>::infinity();
};

double max_error(const golden_case& g, const std::vector<state_type>& at_samples) {
  double e = 0.0;
  for (std::size_t i = 0; i < g.t.size(); ++i) e = std::max(e, std::hypot(at_samples[i][idx::x] - g.x[i], at_samples[i][idx::y] - g.y[i]));
  return e;
}

template <class Run>
result timed(Run&& run) {
  result best;
  for (int r = 0; r < kRepeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    result one = run();
    one.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (one.seconds < best.seconds) best = one;
  }
  return best;
}

// With events: rubref's simulate (hybrid integrator), at the golden file's sample times.
result with_events(const golden_case& g, stepper_kind kind, double setting) {
  run_request req = g.request;
  req.integration.stepper.kind = kind;
  if (kind == stepper_kind::rk4) {
    req.integration.stepper.dt = setting;
  } else {
    req.integration.stepper.rtol = setting;
    req.integration.stepper.atol = setting * 1e-4;  // m: the orbit is ~1e-3 m
  }
  return timed([&] {
    const orbit o = simulate(req);
    std::vector<state_type> s;
    for (const auto& smp : o.samples) s.push_back(smp.s);
    return result{o.counts.steps, max_error(g, s), 0.0};
  });
}

// Without events: odeint on Eq. 1-2 as written (by_penetration), one call to integrate_times.
template <class Law>
result without_events(const golden_case& g, stepper_kind kind, double setting) {
  const rotor_system<Law> sys(g.request.params, g.omega(), contact_phase::by_penetration);
  std::vector<double> times{0.0};
  times.insert(times.end(), g.t.begin(), g.t.end());
  const double max_dt = sys.period() / 16.0;
  return timed([&] {
    std::vector<state_type> out;
    const auto observe = [&](const state_type& s, double t) {
      if (t > 0.0) out.push_back(s);
    };
    state_type x{};
    std::size_t steps = 0;
    switch (kind) {
      case stepper_kind::rk4:
        steps = ode::integrate_times(ode::runge_kutta4<state_type>(), sys, x, times.begin(), times.end(), setting, observe);
        break;
      case stepper_kind::dopri5:
        steps = ode::integrate_times(ode::make_dense_output(setting * 1e-4, setting, max_dt, ode::runge_kutta_dopri5<state_type>()), sys, x,
                                     times.begin(), times.end(), max_dt / 100.0, observe);
        break;
      case stepper_kind::rkf78:
        steps = ode::integrate_times(ode::make_controlled(setting * 1e-4, setting, max_dt, ode::runge_kutta_fehlberg78<state_type>()), sys, x,
                                     times.begin(), times.end(), max_dt / 100.0, observe);
        break;
      case stepper_kind::bulirsch_stoer:
        steps = ode::integrate_times(ode::bulirsch_stoer_dense_out<state_type>(setting * 1e-4, setting, 1.0, 1.0, max_dt), sys, x,
                                     times.begin(), times.end(), max_dt / 100.0, observe);
        break;
    }
    return result{steps, max_error(g, out), 0.0};
  });
}

int run(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : "golden/identified_0.3mm_1600rpm.csv";
  const golden_case g = read_golden_case(read_record(path), path);
  if (g.comparison != comparison_kind::orbit) throw input_error(path + ": a statistics case has no reference orbit to measure errors against");
  const double period = 2.0 * std::numbers::pi / g.omega();
  std::printf("method,events,setting,steps,error_m,time_s\n");
  const auto row = [](std::string_view method, bool events, const std::string& setting, const result& r) {
    std::printf("%s,%s,%s,%zu,%.3e,%.4e\n", std::string(method).c_str(), events ? "located" : "none", setting.c_str(), r.steps, r.error,
                r.seconds);
    std::fflush(stdout);
  };
  for (const int per_rev : {256, 362, 512, 1024, 2048, 4096}) {
    const double dt = period / per_rev;
    const std::string setting = "dt = T/" + std::to_string(per_rev);
    row("rk4", true, setting, with_events(g, stepper_kind::rk4, dt));
    visit_variant(g.request.variant, [&]<class Law>() {
      // (An impact law has no force to put in a RHS: it has no run without events.)
      if constexpr (rotor_system<Law>::compliant) row("rk4", false, setting, without_events<Law>(g, stepper_kind::rk4, dt));
      return 0;
    });
  }
  for (const auto kind : {stepper_kind::dopri5, stepper_kind::rkf78, stepper_kind::bulirsch_stoer})
    for (const int decade : {6, 7, 8, 9, 10, 12}) {
      const double rtol = std::pow(10.0, -decade);
      const std::string setting = "rtol 1e-" + std::to_string(decade);
      row(to_string(kind), true, setting, with_events(g, kind, rtol));
      visit_variant(g.request.variant, [&]<class Law>() {
        if constexpr (rotor_system<Law>::compliant) row(to_string(kind), false, setting, without_events<Law>(g, kind, rtol));
        return 0;
      });
    }
  return 0;
}

}  // namespace
}  // namespace rubref

int main(int argc, char** argv) {
  try {
    return rubref::run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "work_precision: %s\n", e.what());
    return 2;
  }
}
