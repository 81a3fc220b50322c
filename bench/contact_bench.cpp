// The contact-integration hot path, measured (docs/performance.md). Each benchmark reports its
// work as counters (steps, rhs, events) beside the time, so per-step and per-event costs can be
// read off any machine's output:
//
//   scripts/bench                         # builds with -DRUBREF_BUILD_BENCHMARKS=ON and runs all
//   build-bench/bench/contact_bench --benchmark_filter=rk4
//
// The case is the paper's: 1600 rpm, clearance 0.3 mm (docs/validation.md's golden case), where
// the identified law rubs once per revolution.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <boost/numeric/odeint.hpp>
#include <chrono>
#include <cmath>
#include <vector>

#include "ref/integrate/hybrid_integrator.hpp"
#include "ref/integrate/steppers.hpp"
#include "ref/model/free_flight.hpp"
#include "ref/model/rotor_model.hpp"
#include "ref/orbits/continuation.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "ref/run/simulate.hpp"
#include "ref/study/study_run.hpp"
#include "ref/sweep/sweep.hpp"
#include "variants/all_variants.hpp"

namespace rubref {
namespace {

constexpr double kRpm = 1600.0;
constexpr double kClearance = 0.3e-3;  // m

parameters paper_case() {
  parameters p;
  p.clearance = kClearance;
  return p;
}

double omega() { return rpm_to_rad_s(kRpm); }

// A state 10 um inside the stator, moving in: every RHS evaluates the contact law.
state_type in_contact() { return {1e-4, kClearance + 1e-5, -0.05, 0.02}; }

// The model with its forcing from libm's cos and sin: what a first implementation evaluates (the
// issue's ~100 ns per RK4 step starting point), kept as the baseline.
template <class Law>
struct libm_forcing {
  using state_type = rubref::state_type;
  rotor_system<Law> sys;
  void operator()(const state_type& x, state_type& dxdt, double t) const {
    const double a = sys.forcing_angle(t);
    sys(x, dxdt, forcing_phasor{std::cos(a), std::sin(a)});
  }
};

// ---- right-hand side ----------------------------------------------------------------------

// One RHS evaluation of `sys` at t, in contact.
template <class System>
void time_rhs_at_t(benchmark::State& state, const System& sys) {
  state_type s = in_contact(), ds{};
  double t = 0.0;
  for (auto _ : state) {
    sys(s, ds, t);
    benchmark::DoNotOptimize(ds);
    t += 1e-5;
  }
  state.counters["rhs"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

template <class Law>
void rhs_with_libm_trig(benchmark::State& state) {
  time_rhs_at_t(state, libm_forcing<Law>{rotor_system<Law>(paper_case(), omega())});
}

// rubref's System at t: the forcing by phasor_of (ref/model/state.hpp), as the adaptive steppers use it.
template <class Law>
void rhs_with_phasor_of(benchmark::State& state) {
  time_rhs_at_t(state, rotor_system<Law>(paper_case(), omega()));
}

template <class Law>
void rhs_with_given_phasor(benchmark::State& state) {
  // The forcing given, turned between calls: what rubref's rk4 stages see.
  const rotor_system<Law> sys(paper_case(), omega());
  state_type s = in_contact(), ds{};
  forcing_phasor p{1.0, 0.0};
  const forcing_phasor turn{std::cos(omega() * 1e-5), std::sin(omega() * 1e-5)};
  for (auto _ : state) {
    sys(s, ds, p);
    benchmark::DoNotOptimize(ds);
    p = rotated(p, turn);
  }
  state.counters["rhs"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// ---- one RK4 step -------------------------------------------------------------------------
// Steps of rk4's default size (T/1024) along the steady orbit from a point in contact; the
// state is reset every revolution so that the loop stays on the orbit's mix of free flight and
// contact (Eq. 2 as written: the contact force switches inside the RHS).

constexpr int kStepsPerRev = 1024;

template <class Law>
void rk4_odeint_libm_trig(benchmark::State& state) {
  // What a user writes first: odeint's runge_kutta4 on the System, libm's trig in the RHS.
  const libm_forcing<Law> sys{rotor_system<Law>(paper_case(), omega())};
  boost::numeric::odeint::runge_kutta4<state_type> rk4;
  const double dt = sys.sys.period() / kStepsPerRev;
  state_type s = in_contact();
  double t = 0.0;
  int k = 0;
  for (auto _ : state) {
    rk4.do_step(sys, s, t, dt);
    t += dt;
    if (++k == kStepsPerRev) k = 0, s = in_contact(), t = 0.0;
  }
  benchmark::DoNotOptimize(s);
  state.counters["steps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

template <class Law>
void rk4_handwritten_libm_trig(benchmark::State& state) {
  // The baseline: a plain RK4 loop, written out, libm's trig in the RHS.
  const libm_forcing<Law> sys{rotor_system<Law>(paper_case(), omega())};
  const double h = sys.sys.period() / kStepsPerRev;
  state_type s = in_contact(), k1, k2, k3, k4, xs;
  double t = 0.0;
  int k = 0;
  for (auto _ : state) {
    sys(s, k1, t);
    for (int i = 0; i < 4; ++i) xs[i] = s[i] + 0.5 * h * k1[i];
    sys(xs, k2, t + 0.5 * h);
    for (int i = 0; i < 4; ++i) xs[i] = s[i] + 0.5 * h * k2[i];
    sys(xs, k3, t + 0.5 * h);
    for (int i = 0; i < 4; ++i) xs[i] = s[i] + h * k3[i];
    sys(xs, k4, t + h);
    for (int i = 0; i < 4; ++i) s[i] += (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    t += h;
    if (++k == kStepsPerRev) k = 0, s = in_contact(), t = 0.0;
  }
  benchmark::DoNotOptimize(s);
  state.counters["steps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

template <class Law>
void rk4_rubref(benchmark::State& state) {
  // The library path: rubref's rk4 stepper (ref/integrate/steppers.hpp), forcing turned by a phasor.
  const rotor_system<Law> sys(paper_case(), omega());
  rk4_dense<rotor_system<Law>> st(sys.period() / kStepsPerRev);
  st.initialize(in_contact(), 0.0, 0.0);
  int k = 0;
  for (auto _ : state) {
    st.do_step(sys);
    if (++k == kStepsPerRev) k = 0, st.initialize(in_contact(), 0.0, 0.0);
  }
  benchmark::DoNotOptimize(st.current_state());
  state.counters["steps"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// ---- locating one contact event -------------------------------------------------------------
// A dopri5 step that crosses y = delta (onset), then the event bracketed to 1e-13 s on the
// step's dense output, as the hybrid integrator does it.
void locate_contact_onset(benchmark::State& state) {
  namespace ode = boost::numeric::odeint;
  const rotor_system<identified> free(paper_case(), omega(), contact_phase::free);
  auto st = ode::make_dense_output(1e-14, 1e-10, free.period() / 16, ode::runge_kutta_dopri5<state_type>());
  const state_type before{0.0, kClearance - 2e-6, 0.0, 0.05};  // 40 us before touching
  st.initialize(before, 0.0, 1e-4);
  const auto [ta, tb] = st.do_step(free);
  state_type tmp{};
  const auto h_at = [&](double t) {
    st.calc_state(t, tmp);
    return -free.penetration(tmp);  // exit value of the free phase: > 0 outside
  };
  const double h_lo = h_at(ta), h_hi = h_at(tb);
  if (!(h_lo > 0.0 && h_hi < 0.0)) {
    state.SkipWithError("the step does not cross the clearance");
    return;
  }
  std::size_t evaluations = 0;
  for (auto _ : state) {
    const auto counted = [&](double t) {
      ++evaluations;
      return h_at(t);
    };
    benchmark::DoNotOptimize(detail::bracket_root(counted, ta, tb, h_lo, h_hi, 1e-13));
  }
  state.counters["events"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["dense_evals_per_event"] = static_cast<double>(evaluations) / static_cast<double>(state.iterations());
}

// ---- reading a free flight at record samples ------------------------------------------------
// The paper's rotor with the stator out of reach, its free flight, and the points of a 10-revolution
// record at 19 kHz: what both free-arc benchmarks read.
struct paper_free_arc {
  static constexpr double kSampleRate = 19015.0;  // Hz
  rotor_system<identified> sys{[] {
    parameters p = paper_case();
    p.clearance = 1.0;  // m: free flight only
    return p;
  }(), omega(), contact_phase::free};
  free_flight<4> ff{*sys.free_dynamics()};
  free_flight<4>::arc arc = ff.from(0.0, state_type{1e-4, -2e-4, 0.03, 0.05});
  std::size_t n = static_cast<std::size_t>(10.0 * sys.period() * kSampleRate);
};

// The arc read at the record's sample phases folded into one revolution and sorted: how the
// loop's predictor reads a dwell at the record's samples (ref/loop/predictor.cpp). Counter
// `samples`: the time per sample.
void sample_free_arc(benchmark::State& state) {
  const paper_free_arc f;
  const auto& [sys, ff, arc, n] = f;
  std::vector<double> phases(n);
  for (std::size_t i = 0; i < n; ++i) phases[i] = std::fmod(static_cast<double>(i) / paper_free_arc::kSampleRate, sys.period());
  std::sort(phases.begin(), phases.end());
  for (auto _ : state)
    for (const double t : phases) benchmark::DoNotOptimize(arc.at(t));
  state.counters["samples"] =
      benchmark::Counter(static_cast<double>(state.iterations() * n), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// The same arc walked along a uniform grid of as many points (free_flight::arc::walk: how the
// integrator reads records and the loop's harmonic band): phasors turned by one step's, taken
// exactly every 32nd point. Counter `samples`: the time per sample, against sample_free_arc's.
void walk_free_arc(benchmark::State& state) {
  const paper_free_arc f;
  const auto& [sys, ff, arc, n] = f;
  const double dt = sys.period() / static_cast<double>(n);
  const auto step = ff.step_phasors(dt);
  for (auto _ : state) {
    auto walk = arc.walk_by(step);
    for (std::size_t i = 0; i < n; ++i) benchmark::DoNotOptimize(walk.next(static_cast<double>(i) * dt));
  }
  state.counters["samples"] =
      benchmark::Counter(static_cast<double>(state.iterations() * n), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// ---- one steady-state simulation ----------------------------------------------------------
// 200 revolutions from rest at 1600 rpm, 0.3 mm, 8 recorded at 128 per revolution (the golden
// case), with located events.
void steady_state(benchmark::State& state, const std::string& variant, stepper_kind kind, double rtol) {
  run_request req;
  req.variant = variant;
  req.params = paper_case();
  req.rpm = kRpm;
  req.settle_revs = 200;
  req.record_revs = 8;
  req.integration.stepper.kind = kind;
  if (kind != stepper_kind::rk4) {  // rk4: its default step, T/1024
    req.integration.stepper.rtol = rtol;
    req.integration.stepper.atol = rtol * 1e-4;  // m: the orbit is ~1e-3 m
  }
  integration_counts counts;
  for (auto _ : state) {
    const orbit o = simulate(req);
    counts = o.counts;
    benchmark::DoNotOptimize(o.samples.data());
  }
  state.counters["steps"] = static_cast<double>(counts.steps);
  state.counters["events"] = static_cast<double>(counts.events);
  state.counters["ns_per_step"] = benchmark::Counter(static_cast<double>(counts.steps) * static_cast<double>(state.iterations()),
                                                     benchmark::Counter::kIsRate | benchmark::Counter::kInvert,
                                                     benchmark::Counter::kIs1000);
}

// ---- a steady orbit by shooting, and a branch by continuation (docs/orbits.md) -------------
// The golden case's orbit as `rubref orbit` finds it: Newton on the one-revolution map from the
// contact-free response to 1e-12 m, its Floquet multipliers, one recorded period (128 samples).
// Issue 21's target: <= 0.3 ms.
void periodic_orbit_by_shooting(benchmark::State& state) {
  periodic_orbit_request req;
  req.run.params = paper_case();
  req.run.rpm = kRpm;
  int iterations = 0;
  for (auto _ : state) {
    const periodic_orbit_result r = find_periodic_orbit(req);
    if (!r.converged) state.SkipWithError(("shooting failed: " + r.failure).c_str());
    iterations = r.iterations;
    benchmark::DoNotOptimize(r.samples.samples.data());
  }
  state.counters["newton_iterations"] = iterations;
}

// A whole branch 1300-2200 rpm at one clearance (0.2, 0.3, 0.4 mm), with stability and the
// special points located. Issue 21's target: <= 50 ms per clearance.
void branch_by_continuation(benchmark::State& state) {
  continuation_request req;
  req.params.clearance = static_cast<double>(state.range(0)) * 1e-4;
  req.from = 1300.0;
  req.to = 2200.0;
  std::size_t points = 0;
  for (auto _ : state) {
    const continuation_result r = continue_branch(req);
    if (!r.reached_end) state.SkipWithError(("the branch stopped: " + r.stopped).c_str());
    points = r.points.size();
    benchmark::DoNotOptimize(r.points.data());
  }
  state.counters["points"] = static_cast<double>(points);
}

// ---- a reproduce-sized sweep ----------------------------------------------------------------
// The paper's sweep, 1400 -> 1800 -> 1400 rpm in 5 rpm steps, default settle/record revolutions,
// at the three clearances of Fig. 12: six independent branches on 1 or 2 threads.
void paper_sweeps(benchmark::State& state) {
  const auto threads = static_cast<unsigned>(state.range(0));
  const int clearances = static_cast<int>(state.range(1));
  const bool from_orbit = state.range(2) != 0;  // sweep --start-from-orbit
  std::vector<branch_task> tasks;
  for (int c = 0; c < clearances; ++c)
    for (const auto d : {sweep_direction::up, sweep_direction::down}) {
      sweep_settings s;
      s.params.clearance = (0.2 + 0.1 * c) * 1e-3;
      s.start_from_orbit = from_orbit;
      tasks.push_back({s, d});
    }
  integration_counts counts;
  for (auto _ : state) {
    const auto branches = run_branches(tasks, threads);
    counts = {};
    for (const auto& b : branches) counts.steps += b.counts.steps, counts.events += b.counts.events;
  }
  state.counters["branches"] = static_cast<double>(tasks.size());
  state.counters["steps"] = static_cast<double>(counts.steps);
  state.counters["events"] = static_cast<double>(counts.events);
}

// A regime map's points (docs/studies.md): the orbit job on a clearance x speed grid of the
// identified law (0.1-0.5 mm x 1200-3000 rpm, 1547 points, every regime of the paper's rotor), on
// 1 or 2 threads, without the folder (its journal is one append per 128 rows). The target is
// >= 1e6 periodic orbits per hour on this 2-core machine (issue 26): the counter orbits_per_hour.
void study_regime_map(benchmark::State& state) {
  const auto threads = static_cast<unsigned>(state.range(0));
  const study::spec s = study::parse_spec(R"({"study": "regime_map", "grid": [
      {"name": "clearance_m", "from": 1e-4, "to": 5e-4, "count": 17}, {"name": "speed_rpm", "from": 1200, "to": 3000, "step": 20}]})",
                                          "bench");
  std::vector<std::size_t> all(study::point_count(s));
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
  std::size_t rows = 0;
  double seconds = 0.0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    study::compute_points(s, all, threads, 0, [&](auto&& r) { rows += r.size(); });
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  state.counters["points"] = static_cast<double>(all.size());
  state.counters["orbits_per_hour"] = 3600.0 * static_cast<double>(rows) / seconds;
}

#define RUBREF_PER_VARIANT(fn)                                        \
  BENCHMARK_TEMPLATE(fn, piecewise_linear);                           \
  BENCHMARK_TEMPLATE(fn, piecewise_nonlinear);                        \
  BENCHMARK_TEMPLATE(fn, identified)

RUBREF_PER_VARIANT(rhs_with_libm_trig);
RUBREF_PER_VARIANT(rhs_with_phasor_of);
RUBREF_PER_VARIANT(rhs_with_given_phasor);
RUBREF_PER_VARIANT(rk4_odeint_libm_trig);
RUBREF_PER_VARIANT(rk4_handwritten_libm_trig);
RUBREF_PER_VARIANT(rk4_rubref);
BENCHMARK(locate_contact_onset);
BENCHMARK(sample_free_arc)->Unit(benchmark::kMicrosecond);
BENCHMARK(walk_free_arc)->Unit(benchmark::kMicrosecond);

BENCHMARK_CAPTURE(steady_state, identified_rk4, std::string("identified"), stepper_kind::rk4, 0.0)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(steady_state, identified_dopri5_1e-6, std::string("identified"), stepper_kind::dopri5, 1e-6)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(steady_state, identified_dopri5_1e-10, std::string("identified"), stepper_kind::dopri5, 1e-10)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(steady_state, identified_rkf78_1e-10, std::string("identified"), stepper_kind::rkf78, 1e-10)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(steady_state, identified_bulirsch_stoer_1e-10, std::string("identified"), stepper_kind::bulirsch_stoer, 1e-10)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(steady_state, restitution_dopri5_1e-10, std::string("restitution"), stepper_kind::dopri5, 1e-10)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(steady_state, piecewise_linear_dopri5_1e-10, std::string("piecewise-linear"), stepper_kind::dopri5, 1e-10)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(steady_state, piecewise_nonlinear_dopri5_1e-10, std::string("piecewise-nonlinear"), stepper_kind::dopri5, 1e-10)->Unit(benchmark::kMillisecond);

BENCHMARK(periodic_orbit_by_shooting)->Unit(benchmark::kMicrosecond);
BENCHMARK(branch_by_continuation)->Arg(2)->Arg(3)->Arg(4)->Unit(benchmark::kMillisecond);

// (threads, clearances, start from orbit): one clearance's two branches on 1 and 2 threads, all
// three on 2; then both settling nowhere the shot orbit is stable.
BENCHMARK(paper_sweeps)->Args({1, 1, 0})->Args({2, 1, 0})->Args({2, 3, 0})->Args({2, 1, 1})->Args({2, 3, 1})->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(study_regime_map)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

}  // namespace
}  // namespace rubref

BENCHMARK_MAIN();
