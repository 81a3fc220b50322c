// The loop's building blocks (ref/loop/) on virtual-rig records whose truth is known: noise
// estimate, keyphasor timing, the linear part by harmonic balance, contact's fingerprint, the
// fit's coordinates, the model's orbits at the truth, and the synchronous energy.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "ref/base/errors.hpp"
#include "ref/inference/evidence.hpp"
#include "ref/loop/coordinates.hpp"
#include "ref/loop/fit.hpp"
#include "ref/loop/loop.hpp"
#include "ref/loop/paper_fit.hpp"
#include "ref/rig/rig.hpp"

namespace rubref::testing {
namespace {

// Dwells of a rig record, timed by their keyphasor as the loop does.
std::vector<loop_dwell> rig_dwells(const rig_request& req) {
  const rig_output o = run_rig(req);
  std::vector<loop_dwell> out;
  std::vector<std::string> notes;
  for (auto& d : split_dwells(o.measurement, "rig")) {
    loop_dwell ld{std::move(d), "rig"};
    align_by_keyphasor(ld, notes);
    out.push_back(std::move(ld));
  }
  EXPECT_TRUE(notes.empty());
  return out;
}

// The dwells of a rig without keyphasor whose t_s is shaft-synchronous, with their clearance.
std::vector<loop_dwell> shaft_synchronous_dwells(const rig_request& req) {
  std::vector<loop_dwell> dwells;
  for (auto& d : split_dwells(run_rig(req).measurement, "rig")) {
    d.clearance = req.params.clearance;
    dwells.push_back({std::move(d), "rig"});
  }
  return dwells;
}

rig_request below_the_rub() {
  rig_request req;
  req.params.clearance = 1.0;  // m: never reached
  req.speeds_rpm = {1200, 1300, 1400, 1700};
  req.record_revs = 16;
  return req;
}

// sigma from the median absolute 4th difference: ~1e5 samples give it to ~1 %.
TEST(loop_steps, noise_is_estimated_from_the_data) {
  rig_request req = below_the_rub();
  req.probes.quantisation = 0.0;
  constexpr double kNoiseTol = 0.03;
  for (const double sigma : {0.2e-6, 1e-6}) {
    req.probes.noise = sigma;
    EXPECT_NEAR(estimate_noise(rig_dwells(req)), sigma, kNoiseTol * sigma) << sigma;
  }
}

// After alignment, t = 0 is a notch passage to within the bracket the pulses leave: the shaft
// angle w t at every pulse is within [-w sigma sqrt(12), w dt] of a whole turn.
TEST(loop_steps, keyphasor_alignment_finds_the_notch) {
  rig_request req = below_the_rub();
  req.probes.keyphasor_angle = 0.7;  // the notch 0.7 rad before the unbalance
  for (const auto& ld : rig_dwells(req)) {
    const double w = ld.data.omega();
    ASSERT_TRUE(std::isfinite(ld.timing_sigma));
    EXPECT_LE(ld.timing_sigma, 1.001 * ld.data.dt / std::sqrt(12.0));  // at most one sample wide (plus the hair)
    for (std::size_t i = 1; i < ld.data.size(); ++i)
      if (ld.data.keyphasor[i] > 0.5) {
        const double past = std::remainder(w * ld.data.t[i], 2.0 * std::numbers::pi);
        EXPECT_GT(past, -1e-9);
        EXPECT_LT(past, w * ld.data.dt + 1e-9);
      }
  }
}

// Without contact the 1X phasors give c, k, e and the unbalance angle by linear least squares;
// with 0.5 um noise over 16 revolutions the 1X phasor is good to ~0.01 um of ~100 um. The angle
// is the keyphasor's: good to half a sample, w dt / 2 = 9e-3 rad at 1700 rpm and 10 kHz.
TEST(loop_steps, harmonic_balance_recovers_the_linear_part) {
  rig_request req = below_the_rub();
  req.probes.keyphasor_angle = 0.0;  // the unbalance angle from the notch is then the truth's
  auto dwells = rig_dwells(req);
  const parameters p = fit_linear_harmonic(dwells, req.params.m);
  const parameters& t = req.params;
  // k sets the phasors' size (good to ~1e-4 of it); c shows only through the 1/Q part of the
  // response (~1e-2 of it near resonance, so its error is ~100x larger); e scales every phasor.
  constexpr double kStiffnessTol = 1e-3, kDampingTol = 3e-2, kUnbalanceTol = 1e-2, kAngleTol = 9e-3;
  EXPECT_NEAR(p.k_x, t.k_x, kStiffnessTol * t.k_x);
  EXPECT_NEAR(p.k_y, t.k_y, kStiffnessTol * t.k_y);
  EXPECT_NEAR(p.c_x, t.c_x, kDampingTol * t.c_x);
  EXPECT_NEAR(p.c_y, t.c_y, kDampingTol * t.c_y);
  EXPECT_NEAR(p.e, t.e, kUnbalanceTol * t.e);
  EXPECT_NEAR(p.unbalance_phase, t.unbalance_phase, kAngleTol);
  // One speed is not enough: named.
  dwells.resize(1);
  EXPECT_THROW(fit_linear_harmonic(dwells, req.params.m), input_error);
}

// Contact puts orders >= 3 into the orbit; the linear orbit has none beyond the noise.
TEST(loop_steps, contact_shows_as_high_orders) {
  rig_request req;
  req.speeds_rpm = {1400, 1600};
  for (const auto& ld : rig_dwells(req)) {
    const averaged_dwell a = synchronous_average(ld.data);
    const double floor = req.probes.noise / std::sqrt(static_cast<double>(a.revolutions));
    if (ld.data.rpm == 1400)
      EXPECT_LT(high_order_content(a.cycle), 2.0 * floor);
    else
      EXPECT_GT(high_order_content(a.cycle), 10.0 * floor);  // measured: 47x; the loop's threshold is 5x
  }
}

// Every effect's coordinates: its switches off at 0, on when set, and set/get round trip; its
// shapes (after the switches) inside their physical range round trip, act on nothing while the
// effect is off, and move only themselves in the chart (each set keeps every other coordinate).
TEST(loop_steps, effect_coordinates_switch_their_effect) {
  for (const auto& e : effect_library()) {
    const auto coords = effect_coordinates(e);
    ASSERT_FALSE(coords.empty()) << e.name;
    const std::size_t switches = switch_count(coords);
    ASSERT_GT(switches, 0u) << e.name;
    model_point m;
    EXPECT_FALSE(has_effect(m.fx, e)) << e.name;
    for (std::size_t j = 0; j < coords.size(); ++j) {
      const auto& c = coords[j];
      EXPECT_EQ(c.effect, e.name) << c.name;
      if (j < switches) {
        EXPECT_FALSE(c.shape) << c.name;
        model_point q = m;
        c.set(q, 0.37 * c.scale);
        EXPECT_TRUE(has_effect(q.fx, e)) << c.name;
        EXPECT_NEAR(c.get(q), 0.37 * c.scale, 1e-12 * c.scale) << c.name;
        c.set(q, 0.0);
        EXPECT_FALSE(has_effect(q.fx, e)) << c.name;
        continue;
      }
      ASSERT_TRUE(c.shape) << c.name;
      ASSERT_LT(c.range_lo, c.range_hi) << c.name;
      EXPECT_FALSE(c.quantity.empty() || c.unit.empty()) << c.name;
      model_point off = m;
      c.set(off, c.chart(std::sqrt(c.range_lo * c.range_hi)));
      EXPECT_FALSE(has_effect(off.fx, e)) << c.name << ": a shape alone must not switch the effect on";
      // On at the switches' moderate levels, then the shape at a third of its range (log or
      // linear): it round trips, and every other coordinate of the effect keeps its value.
      model_point on = m;
      for (const auto& q : e.parameters)
        if (q.is_switch) on.fx.*q.member = q.moderate;
      std::vector<double> before;
      for (const auto& other : coords) before.push_back(other.get(on));
      const double target = c.logarithmic ? c.range_lo * std::pow(c.range_hi / c.range_lo, 1.0 / 3.0) : c.range_lo + (c.range_hi - c.range_lo) / 3.0;
      c.set(on, c.chart(target));
      EXPECT_NEAR(c.natural(c.get(on)), target, 1e-9 * target) << c.name;
      EXPECT_TRUE(has_effect(on.fx, e)) << c.name;
      for (std::size_t i = 0; i < coords.size(); ++i)
        if (i != j) {
          EXPECT_NEAR(coords[i].get(on), before[i], 1e-9 * std::max(std::abs(before[i]), coords[i].scale)) << c.name << " moved " << coords[i].name;
        }
    }
  }
}

// Three contact dwells of an undisturbed rig (no ADC step) on the rig's own time origin, so the
// truth's timing shifts are 0.
rig_request truth_rig() {
  rig_request req;
  req.speeds_rpm = {1300, 1600, 1700};
  req.probes.quantisation = 0.0;
  return req;
}
std::vector<loop_dwell> truth_timed_dwells(const rig_request& req) {
  auto dwells = rig_dwells(req);
  for (auto& d : dwells) {  // the rig's own time origin: a whole number of turns before the dwell
    const double t0 = d.data.t.front();
    for (double& t : d.data.t) t -= t0;
    d.timing_sigma = std::numeric_limits<double>::infinity();
    d.data.clearance = req.params.clearance;
  }
  return dwells;
}

// The truth rig's timed dwells, their predictor, and the residual of the truth's orbits (timing
// shifts 0): what the tests of the residual's measures start from. Built in place (the predictor
// holds the dwells).
struct at_the_truth {
  rig_request req = truth_rig();
  std::vector<loop_dwell> dwells = truth_timed_dwells(req);
  orbit_predictor predictor{dwells, req.probes.noise};
  model_point truth = [this] {
    model_point m;
    m.shift.assign(dwells.size(), 0.0);
    return m;
  }();
  Eigen::VectorXd r = predictor.residuals(truth).value();
};

// At the truth (timing shifts fitted aside) the model's periodic orbits leave only the probe
// noise: the residual RMS is the noise to within its sampling spread.
TEST(loop_steps, the_truths_orbits_leave_the_noise) {
  const at_the_truth at;
  const auto& req = at.req;
  const auto& r = at.r;
  const double rms = std::sqrt(r.squaredNorm() / static_cast<double>(r.size()));
  constexpr double kRmsTol = 0.02;  // ~3e4 samples: the sample RMS of white noise is good to ~0.5 %
  EXPECT_NEAR(rms, req.probes.noise, kRmsTol * req.probes.noise);
}

// A dwell with a whole number of samples per revolution (10 kHz at 1500 rpm: 400) and t_s
// shaft-synchronous puts samples exactly on revolution boundaries; each must fall in [0, T) of
// the periodic orbit (floor-based phases put some at -1e-17 s, lost to the integrator, and the
// dwell was scored as failed). Without a keyphasor the truth's orbits leave the noise there too.
TEST(loop_steps, whole_samples_per_revolution_are_all_predicted) {
  constexpr double kPeriod = 60.0 / 1500.0;
  for (int k = 0; k < 4000; ++k) {
    const double f = phase_in_period(2.4 + k * 1e-4, kPeriod);
    ASSERT_GE(f, 0.0) << k;
    ASSERT_LT(f, kPeriod) << k;
  }
  rig_request req = truth_rig();
  req.speeds_rpm = {1200, 1500, 1600};  // 500, 400 and 375 samples per revolution
  req.probes.keyphasor = false;
  req.time_base = rig_time_base::shaft;
  const std::vector<loop_dwell> dwells = shaft_synchronous_dwells(req);
  orbit_predictor predictor(dwells, req.probes.noise);
  model_point truth;
  truth.p = req.params;
  truth.fx = req.effects;
  truth.shift.assign(dwells.size(), 0.0);
  const Eigen::VectorXd r = predictor.residuals(truth).value();
  constexpr double kRmsTol = 0.03;  // ~2e4 samples: the sample RMS of white noise is good to ~1 %
  EXPECT_NEAR(std::sqrt(r.squaredNorm() / static_cast<double>(r.size())), req.probes.noise, kRmsTol * req.probes.noise);
}

// A new timing shift re-sorts the sample phases as a rotation of the old order (predictor.cpp);
// the residuals must be the sort's, bit for bit: a predictor that saw other shifts first and a
// fresh one give the same vector, also with a whole number of samples per revolution, where
// samples of different revolutions share a phase (ties).
TEST(loop_steps, a_new_shift_predicts_what_a_fresh_sort_does) {
  for (const bool whole_samples : {false, true}) {
    rig_request req = truth_rig();
    if (whole_samples) req.speeds_rpm = {1200, 1500, 1600};  // 500, 400 and 375 samples per revolution
    req.probes.keyphasor = false;
    req.time_base = rig_time_base::shaft;
    const std::vector<loop_dwell> dwells = shaft_synchronous_dwells(req);
    model_point m;
    m.p = req.params;
    m.fx = req.effects;
    m.shift.assign(dwells.size(), 0.0);
    orbit_predictor seen(dwells, req.probes.noise);
    (void)seen.residuals(m).value();
    for (const double turn : {1e-5, 0.37, -0.61}) {  // of a revolution: a little, and across many wraps
      for (std::size_t k = 0; k < dwells.size(); ++k) m.shift[k] = turn * 60.0 / dwells[k].data.rpm;
      orbit_predictor fresh(dwells, req.probes.noise);
      const Eigen::VectorXd a = seen.residuals(m).value(), b = fresh.residuals(m).value();
      ASSERT_EQ(a.size(), b.size());
      EXPECT_TRUE(a == b) << (whole_samples ? "whole samples, " : "") << "turn " << turn << ": largest difference "
                          << (a - b).cwiseAbs().maxCoeff() << " m";
    }
  }
}

// A model point whose orbit cannot be computed (a 20 g stator under the identified law runs
// away, docs/loop.md) is a failure, named per dwell, never a number in the residual; the dwell
// without contact still gets its orbit.
model_point runaway(model_point m) {
  m.fx.stator_k = 4e6;
  m.fx.stator_m = 0.02;
  return m;
}
TEST(loop_steps, an_orbit_that_cannot_be_computed_is_a_failure_not_a_number) {
  const rig_request req = truth_rig();
  const auto dwells = truth_timed_dwells(req);
  orbit_predictor predictor(dwells, req.probes.noise);
  model_point truth;
  truth.shift.assign(dwells.size(), 0.0);
  EXPECT_FALSE(predictor.residuals(runaway(truth)).has_value());
  for (std::size_t k = 0; k < dwells.size(); ++k)
    EXPECT_EQ(predictor.kinds()[k] == orbit_kind::failed, dwells[k].data.rpm > 1400.0) << dwells[k].data.rpm;
}

// A finite difference about a point where a dwell took the transient (no periodic orbit found
// near its data) takes the transient there again, without a shot (harmonic_residuals_as): at the
// point itself that is the same vector bit for bit (the transient continues the failed shot's
// first settle, step for step), and beside it the dwell keeps the transient where a shot would
// converge; the other dwells are shot as ever. The point: a 1 kg stator on 1 MN/m with 10 N s/m
// (ring frequency 1000 rad/s), whose 1600 rpm dwell has no period-1 orbit Newton finds.
TEST(loop_steps, a_difference_about_a_transient_takes_the_transient_again) {
  at_the_truth truth;
  orbit_predictor& predictor = truth.predictor;
  model_point at = truth.truth;
  at.fx.stator_k = 1e6, at.fx.stator_m = 1.0, at.fx.stator_c = 10.0;
  const Eigen::VectorXd r = predictor.harmonic_residuals(at).value();
  const std::vector<orbit_kind> kinds = predictor.kinds();
  ASSERT_EQ(kinds, (std::vector<orbit_kind>{orbit_kind::periodic, orbit_kind::transient, orbit_kind::periodic}));
  const Eigen::VectorXd again = predictor.harmonic_residuals_as(at, kinds).value();
  EXPECT_TRUE(again == r) << "largest difference " << (again - r).cwiseAbs().maxCoeff() << " m";
  EXPECT_EQ(predictor.kinds(), kinds);
  // Beside it, where every dwell's shot converges (a 200 g stator), the held dwell stays the transient.
  model_point beside = at;
  beside.fx.stator_m = 0.2;
  ASSERT_TRUE(predictor.harmonic_residuals(beside).has_value());
  EXPECT_EQ(predictor.kinds(), std::vector<orbit_kind>(3, orbit_kind::periodic));
  ASSERT_TRUE(predictor.harmonic_residuals_as(beside, kinds).has_value());
  EXPECT_EQ(predictor.kinds(), kinds);
}

// The loop leaves out a dwell whose orbit no start of its fit can compute, and only such a dwell.
TEST(loop_steps, dwells_no_start_can_compute_are_named) {
  const rig_request req = truth_rig();
  const auto dwells = truth_timed_dwells(req);
  model_point truth;
  truth.shift.assign(dwells.size(), 0.0);
  std::vector<std::size_t> contact;
  for (std::size_t k = 0; k < dwells.size(); ++k)
    if (dwells[k].data.rpm > 1400.0) contact.push_back(k);
  EXPECT_EQ(uncomputable_dwells(dwells, req.probes.noise, {{"runaway", runaway(truth)}}), contact);
  EXPECT_TRUE(uncomputable_dwells(dwells, req.probes.noise, {{"runaway", runaway(truth)}, {"truth", truth}}).empty());
}

// Levenberg-Marquardt next to such a region: a step into it is rejected like a step that raises
// the residual, and the fit ends no worse than its start, short of the region.
TEST(loop_steps, a_fit_rejects_steps_it_cannot_compute) {
  const rig_request req = truth_rig();
  const auto dwells = truth_timed_dwells(req);
  orbit_predictor predictor(dwells, req.probes.noise);
  // One coordinate v: k1 = truth (0.5 + v), so the data ask for v = 0.5, but past v = 0.2 the
  // model has the runaway stator. From v = 0 the first Gauss-Newton step lands in the region.
  const double k1 = req.params.k1;
  constexpr double kEdge = 0.2;
  fit_coordinate v{"v", 1.0, [k1](const model_point& m) { return m.p.k1 / k1 - 0.5; },
                   [k1](model_point& m, double x) {
                     m.p.k1 = k1 * (0.5 + x);
                     if (x > kEdge) m = runaway(m);
                   }};
  model_point start;
  start.shift.assign(dwells.size(), 0.0);
  v.set(start, 0.0);
  const fit_problem problem = make_problem(predictor, dwells, start, {v}, req.probes.noise);
  const double start_rss = residual_at(predictor, start).value().squaredNorm();
  const fit_result f = fit(problem, problem.of(start), 30);
  ASSERT_TRUE(f.ok);
  EXPECT_GT(f.rejected, 0);
  EXPECT_LT(f.rss, start_rss);
  EXPECT_LE(v.get(f.at), kEdge);
  EXPECT_GT(v.get(f.at), 0.5 * kEdge);  // it went as far towards the data as the model allows
}

// A race of starts (a refit's): every start is fitted for a lap, the leader on to the end of the
// budget; the result is no worse than any lap, and with a budget of no more than a lap per start
// only the lowest start is fitted.
// The truth rig's dwells fitted in one coordinate, v = k1 / the truth's k1 (the data ask for
// v = 1), from a start far from it (v = 0.6) and one near (v = 0.9): the multistart tests' problem.
// Built in place (the predictor holds the dwells, the problem the predictor).
struct k1_from_two_starts {
  rig_request req = truth_rig();
  std::vector<loop_dwell> dwells = truth_timed_dwells(req);
  orbit_predictor predictor{dwells, req.probes.noise};
  double k1 = req.params.k1;
  fit_coordinate v{"v", 1.0, [k1 = k1](const model_point& m) { return m.p.k1 / k1; }, [k1 = k1](model_point& m, double x) { m.p.k1 = k1 * x; }};
  model_point start_at(double x) const {
    model_point m;
    m.shift.assign(dwells.size(), 0.0);
    v.set(m, x);
    return m;
  }
  named_start far{"far", start_at(0.6)}, near{"near", start_at(0.9)};
  fit_problem problem = make_problem(predictor, dwells, far.at, {v}, req.probes.noise);
};

TEST(loop_steps, a_race_fits_every_start_a_lap_and_the_leader_on) {
  k1_from_two_starts k;
  const rig_request& req = k.req;
  const fit_problem& problem = k.problem;
  const std::vector<named_start> starts{k.far, k.near};
  const multistart_result raced = race_starts(problem, starts, 10, 1);
  ASSERT_TRUE(raced.best.ok);
  ASSERT_EQ(raced.starts.size(), 2u);
  for (const auto& o : raced.starts) {
    EXPECT_TRUE(std::isfinite(o.rss_fit)) << o.name;  // every start ran its lap
    EXPECT_LE(raced.best.rss, o.rss_fit) << o.name;
  }
  // It ends where a plain fit from the better start ends: both stop when a step gains less than
  // 0.01 in chi^2, so their chi^2 agree to a few such steps.
  const fit_result plain = fit(problem, problem.of(starts.back().at), 30);
  constexpr double kChi2Tol = 0.1;
  EXPECT_NEAR(raced.best.rss / (req.probes.noise * req.probes.noise), plain.rss / (req.probes.noise * req.probes.noise), kChi2Tol);
  const multistart_result lowest_only = race_starts(problem, starts, 2, 1);
  EXPECT_EQ(lowest_only.winner, "near");
  EXPECT_TRUE(std::isnan(lowest_only.starts.front().rss_fit));  // "far" was not fitted
}

// Fits from several starts (the before-fit's) that end alike within their numerical uncertainty
// are a tie, won by the first start in the declared order, not by the lower residual's last digits:
// the same two starts declared in either order, both fitted to the truth's k1, give the win to
// whichever is declared first (a rule of the lower residual would name the same start both times).
TEST(loop_steps, fits_from_starts_that_end_alike_are_a_tie_won_by_the_first_start) {
  k1_from_two_starts k;
  const auto never = [](const fit_result&) { return false; };  // both starts fitted
  for (const auto& starts : {std::vector<named_start>{k.far, k.near}, std::vector<named_start>{k.near, k.far}}) {
    const multistart_result m = fit_from_starts(k.problem, starts, 30, never, 2);
    ASSERT_TRUE(m.best.ok);
    for (const auto& o : m.starts) EXPECT_TRUE(std::isfinite(o.rss_fit)) << o.name;
    EXPECT_TRUE(m.tie);
    EXPECT_EQ(m.winner, starts.front().name);
  }
}

// The staged model keeps the weak form's own law beside the one identify's orbit fit refined from
// it, and the before-fit starts from both (neither leads it lower on every record, docs/loop.md
// step 2): the third start carries the staged linear part with the weak form's law, and it is
// fitted while the others leave more than noise.
TEST(loop_steps, the_weak_forms_own_law_is_a_start_of_the_before_fit) {
  at_the_truth at;
  std::vector<std::string> notes;
  const staged_start staged = staged_model(at.dwells, at.req.params.m, notes);
  ASSERT_TRUE(staged.weak_form.has_value()) << "the orbit fit left the weak form's law as it was";
  const std::vector<named_start> starts = before_fit_starts(staged.model, staged.weak_form);
  ASSERT_EQ(starts.size(), 3u);
  const parameters& third = starts[2].at.p;
  EXPECT_EQ(third.k1, staged.weak_form->k1);
  EXPECT_EQ(third.c2, staged.weak_form->c2);
  EXPECT_EQ(third.mu, staged.weak_form->mu);
  EXPECT_EQ(third.k_x, staged.model.p.k_x);  // the linear part is the staged one
  EXPECT_EQ(third.e, staged.model.p.e);
  EXPECT_FALSE(third.k1 == staged.model.p.k1 && third.k3 == staged.model.p.k3 && third.c2 == staged.model.p.c2 && third.mu == staged.model.p.mu)
      << "a third start with the staged law again";
  constexpr int kJacobians = 3;  // enough to run each fit; the test is which starts are fitted
  const auto never = [](const fit_result&) { return false; };
  const multistart_result m = fit_paper_model(at.predictor, at.dwells, staged.model, staged.weak_form, at.req.probes.noise, kJacobians, never);
  ASSERT_EQ(m.starts.size(), 3u);
  for (const auto& o : m.starts) EXPECT_TRUE(std::isfinite(o.rss_fit)) << o.name;
}

// Comparing in harmonics (orbit_predictor::harmonic_residuals, what every fit searches on):
// |r~|^2 plus the data's part outside the band is exactly |d - m_band|^2 on the samples, where
// m_band is the model's reading summed from its band, at the truth and at a model far off it,
// with timing shifts or not. The band holds the model's readings: to round-off in a dwell without
// contact, and within a tenth of the noise at every sample of the contact dwells (what a contact
// puts above a quarter of the sampling rate; measured 0.04 at its worst sample, 0.004 RMS). The
// fit's end is taken on the samples (fit.cpp).
TEST(loop_steps, the_harmonic_comparison_is_the_sample_comparison_within_the_band) {
  at_the_truth at;
  const double sigma = at.req.probes.noise;
  for (const double eccentricity : {1.0, 1.1})
    for (const double turn : {0.0, 0.013}) {  // of a revolution
      model_point m = at.truth;
      m.p.e *= eccentricity;
      for (std::size_t k = 0; k < at.dwells.size(); ++k) m.shift[k] = turn * 60.0 / at.dwells[k].data.rpm;
      const Eigen::VectorXd r = at.predictor.residuals(m).value();
      const Eigen::VectorXd h = at.predictor.harmonic_residuals(m).value();
      ASSERT_LT(h.size(), r.size() / 4) << "the band must be far smaller than the samples";
      double on_band = 0.0;
      for (std::size_t k = 0; k < at.dwells.size(); ++k) {
        const dwell& d = at.dwells[k].data;
        double worst = 0.0, model_scale = 0.0;
        for (std::size_t i = 0; i < d.size(); ++i) {
          const auto band = at.predictor.band_reading(k, d.t[i], m.shift[k]);
          const auto row = static_cast<Eigen::Index>(at.predictor.offset(k) + 2 * i);
          const double mx = r[row] + d.x[i], my = r[row + 1] + d.y[i];  // the model's reading at the sample
          on_band += (band[0] - d.x[i]) * (band[0] - d.x[i]) + (band[1] - d.y[i]) * (band[1] - d.y[i]);
          worst = std::max({worst, std::abs(band[0] - mx), std::abs(band[1] - my)});
          model_scale = std::max({model_scale, std::abs(mx), std::abs(my)});
        }
        const bool contact = d.rpm > 1500.0;  // truth_rig: 1300 rpm runs free, 1600 and 1700 rub
        constexpr double kRoundOff = 1e-12;     // of the orbit's size: sums of ~100 harmonics
        constexpr double kContactTail = 0.1;    // of the noise: what a contact puts above the band
        EXPECT_LT(worst, contact ? kContactTail * sigma : kRoundOff * model_scale) << "dwell " << k;
      }
      constexpr double kIdentity = 1e-10;  // relative: the Gram matrix's Cholesky and the sums' rounding
      EXPECT_NEAR(h.squaredNorm() + at.predictor.harmonic_offset(), on_band, kIdentity * on_band) << "e x" << eccentricity << ", turn " << turn;
    }
}

// A timing shift turns harmonic h by h w_T s: harmonic_shift_columns is the derivative of the
// harmonic residuals, against central differences.
TEST(loop_steps, harmonic_shift_columns_are_the_harmonic_residuals_derivative) {
  at_the_truth at;
  model_point m = at.truth;
  for (std::size_t k = 0; k < at.dwells.size(); ++k) m.shift[k] = 0.07 * 60.0 / at.dwells[k].data.rpm;
  (void)at.predictor.harmonic_residuals(m).value();
  const Eigen::MatrixXd J = at.predictor.harmonic_shift_columns(m);
  for (std::size_t k = 0; k < at.dwells.size(); ++k) {
    // A step of 1e-4 of a revolution: the residuals' third derivative keeps the central
    // difference's error below 1e-6 of the column.
    const double step = 1e-4 * 60.0 / at.dwells[k].data.rpm;
    model_point up = m, down = m;
    up.shift[k] += step;
    down.shift[k] -= step;
    const Eigen::VectorXd fd = (at.predictor.harmonic_residuals(up).value() - at.predictor.harmonic_residuals(down).value()) / (2.0 * step);
    const Eigen::VectorXd col = J.col(static_cast<Eigen::Index>(k));
    constexpr double kDifferenceError = 1e-5;
    EXPECT_LT((fd - col).norm(), kDifferenceError * col.norm()) << "dwell " << k;
    EXPECT_GT(col.norm(), 0.0);
  }
}

// The harmonic Jacobian's model columns from the orbits' exact sensitivities
// (orbit_predictor::harmonic_columns: the implicit-function theorem on each dwell's fixed point,
// one flow for all columns) against central differences of the harmonic residuals, at a point
// away from the truth with effects on: the paper's coordinates, an effect in the free flight's
// matrix (cross-coupling), one in the contact's normal (its angle) and the probes' own (runout,
// misorientation). They need no new evaluation; a column whose move switches on another state
// (a stator's compliance from rigid) is differenced instead, one evaluation each.
TEST(loop_steps, exact_sensitivities_are_the_harmonic_residuals_derivative) {
  at_the_truth at;
  model_point m = at.truth;
  m.p.e *= 1.05;
  m.p.k1 *= 0.9;
  m.fx.k_xy = 2e3;
  m.fx.contact_angle = 0.05;
  m.fx.runout_1x = 2e-6;
  m.fx.misorientation = 0.02;
  std::vector<fit_coordinate> coords = paper_coordinates();
  for (const char* name : {"cross_coupling", "contact_angle", "probe_runout", "probe_misorientation"})
    for (auto& c : effect_coordinates(find_effect(name))) coords.push_back(std::move(c));
  const std::size_t dynamic = coords.size();
  for (auto& c : effect_coordinates(find_effect("stator_compliance"))) coords.push_back(std::move(c));
  fit_problem problem = make_problem(at.predictor, at.dwells, m, coords, at.req.probes.noise);
  const Eigen::VectorXd u = problem.of(m);
  m = problem.at(u);  // the point the coordinates give (their charts round)
  at.predictor.anchor(m);
  const Eigen::VectorXd r0 = at.predictor.harmonic_residuals(m).value();
  const std::size_t before = at.predictor.evaluations();
  const Eigen::MatrixXd J = problem.harmonic_jacobian(u, r0);
  // The stator's switch is differenced (its move makes the stator's states move); its shapes,
  // with the stator rigid, move nothing and are exact zeros.
  EXPECT_EQ(at.predictor.evaluations() - before, 1u) << "every other column must come from the sensitivities";
  for (std::size_t j = 0; j < dynamic; ++j) {
    // A step moving the residuals by ~1e-8 m, 1e4 times the orbits' error (the shooting's
    // 1e-12 m), and at least 1e-4 in the scaled coordinates: k3's column is ~1e-6 of the others
    // (z^3 at micrometres of penetration) and needs a step of ~1, at most half its way to its bound
    // (0) so that both sides are the law's.
    const Eigen::VectorXd col = J.col(static_cast<Eigen::Index>(j));
    const double room = u[static_cast<Eigen::Index>(j)] - coords[j].lower / coords[j].scale;
    const double kStep = std::min(std::max(1e-4, 1e-8 / col.norm()), 0.5 * room);
    Eigen::VectorXd up = u, down = u;
    up[static_cast<Eigen::Index>(j)] += kStep;
    down[static_cast<Eigen::Index>(j)] -= kStep;
    const Eigen::VectorXd fd =
        (at.predictor.harmonic_residuals(problem.at(up)).value() - at.predictor.harmonic_residuals(problem.at(down)).value()) / (2.0 * kStep);
    // The difference's own error (the shooting's 1e-12 m over the 1e-8 m change, 1e-4) and the
    // sensitivities' (the vector field's central difference, ~1e-8): 1e-3 of the column.
    constexpr double kAgreement = 1e-3;
    EXPECT_LT((fd - col).norm(), kAgreement * fd.norm()) << coords[j].name;
    EXPECT_GT(fd.norm(), 0.0) << coords[j].name;
  }
}

// The synchronous energy (the synchronous check's and the share rule's measure): at the truth
// it is the noise's, chi^2 with `dof` degrees of freedom; a forward order-2 whirl of amplitude a
// added to the residual adds n a^2 per dwell, to within the cross term with the noise.
TEST(loop_steps, synchronous_energy_measures_the_periodic_residual) {
  const at_the_truth at;
  double n_total = 0.0;
  for (const auto& d : at.dwells) n_total += static_cast<double>(d.data.size());
  constexpr int kOrders = 20;
  constexpr double kZ = 3.29;  // two-sided 0.1 %
  const double sigma = at.req.probes.noise;
  const synchronous_energy noise_only = synchronous_part(at.dwells, at.predictor, at.truth, at.r, kOrders);
  EXPECT_EQ(noise_only.dof, 2.0 * (2 * kOrders + 1) * static_cast<double>(at.dwells.size()));
  EXPECT_NEAR(noise_only.energy / (sigma * sigma), noise_only.dof, kZ * std::sqrt(2.0 * noise_only.dof));

  constexpr double a = 1e-6;  // m, twice the noise
  Eigen::VectorXd whirl = at.r;
  for (std::size_t k = 0; k < at.dwells.size(); ++k) {
    const dwell& d = at.dwells[k].data;
    for (std::size_t i = 0; i < d.size(); ++i) {
      const double psi = d.omega() * d.t[i];
      whirl[static_cast<Eigen::Index>(at.predictor.offset(k) + 2 * i)] += a * std::cos(2.0 * psi);
      whirl[static_cast<Eigen::Index>(at.predictor.offset(k) + 2 * i + 1)] += a * std::sin(2.0 * psi);
    }
  }
  const double added = synchronous_part(at.dwells, at.predictor, at.truth, whirl, kOrders).energy - noise_only.energy;
  const double expected = n_total * a * a;
  // Cross term 2 n Re(conj(a) c_noise): standard deviation 2 a sigma sqrt(n) summed over dwells.
  const double tol = kZ * 2.0 * a * sigma * std::sqrt(n_total);
  EXPECT_NEAR(added, expected, tol);
}


// The noise test's margins: each check's uncertainty bounds how far its value moves when the
// residual moves by a vector of the norm given (random directions, and the directions each
// statistic is most sensitive to: along r, along a shaft order, along a state series), and a test
// whose limit lies within it is on the margin. residual_error_of reads cost_uncertainty's bound
// backwards.
TEST(loop_steps, validity_checks_bound_their_change_under_the_residual_error) {
  const at_the_truth at;
  const auto& req = at.req;
  const auto& dwells = at.dwells;
  const auto& predictor = at.predictor;
  const auto& truth = at.truth;
  const auto& r = at.r;
  constexpr int kOrders = 20, kLags = 10;
  const double sigma = req.probes.noise;
  const Eigen::Index rows = static_cast<Eigen::Index>(predictor.orbit_rows());
  // An error a thousandth of the residual: far from the checks' limits, where the first order holds.
  const double e = 1e-3 * r.head(rows).norm();
  const validity_report bounded = validity(dwells, predictor, truth, r, sigma, kOrders, kLags, e);
  const auto checks = [](const validity_report& v) {
    std::vector<correlation_check> all{v.noise_level, v.synchronous, v.whiteness};
    all.insert(all.end(), v.state.begin(), v.state.end());
    return all;
  };
  const auto within_of = [&](const Eigen::VectorXd& at, const Eigen::VectorXd& direction, const std::string& what) {
    const validity_report here = validity(dwells, predictor, truth, at, sigma, kOrders, kLags, e);
    Eigen::VectorXd moved = at;
    moved.head(rows) += e * direction.head(rows).normalized();
    const auto before = checks(here), after = checks(validity(dwells, predictor, truth, moved, sigma, kOrders, kLags));
    for (std::size_t i = 0; i < before.size(); ++i) {
      EXPECT_GT(before[i].uncertainty, 0.0) << before[i].name;
      // The RMS's bound is reached exactly along r (it is 1/sqrt(N)-Lipschitz): rounding only above it.
      constexpr double kRounding = 1e-9;
      EXPECT_LE(std::abs(after[i].value - before[i].value), before[i].uncertainty * (1.0 + kRounding)) << before[i].name << ", moved " << what;
    }
  };
  const auto within = [&](const Eigen::VectorXd& direction, const std::string& what) { within_of(r, direction, what); };
  std::mt19937_64 gen(20261129);
  std::normal_distribution<double> unit;
  for (int k = 0; k < 5; ++k) {
    Eigen::VectorXd d(r.size());
    for (auto& x : d) x = unit(gen);
    within(d, "at random " + std::to_string(k));
  }
  within(r, "along r");
  Eigen::VectorXd order(r.size()), along_x = Eigen::VectorXd::Zero(r.size());
  order.setZero();
  for (std::size_t k = 0; k < dwells.size(); ++k) {
    const dwell& d = dwells[k].data;
    const auto& st = predictor.states(k);
    for (std::size_t i = 0; i < d.size(); ++i) {
      const auto row = static_cast<Eigen::Index>(predictor.offset(k) + 2 * i);
      order[row] = std::cos(d.omega() * d.t[i]);
      order[row + 1] = std::sin(d.omega() * d.t[i]);
      along_x[row] = st[i][idx::x];
    }
  }
  // r one sample later in each channel: what raises the lag-1 autocorrelation, Box-Pierce's direction.
  Eigen::VectorXd later = Eigen::VectorXd::Zero(r.size());
  for (std::size_t k = 0; k < dwells.size(); ++k)
    for (std::size_t i = 0; i + 1 < dwells[k].data.size(); ++i)
      for (int ch = 0; ch < 2; ++ch) {
        const auto row = static_cast<Eigen::Index>(predictor.offset(k) + 2 * i + static_cast<std::size_t>(ch));
        later[row] = r[row + 2];
      }
  within(later, "along r one sample later");
  // A coloured residual (r plus itself one sample later: lag-1 autocorrelation ~1/2), where Q's
  // first-order term dominates, moved the same way.
  const Eigen::VectorXd coloured = r + later;
  Eigen::VectorXd coloured_later = Eigen::VectorXd::Zero(r.size());
  for (Eigen::Index row = 0; row + 2 < rows; ++row) coloured_later[row] = coloured[row + 2];
  within_of(coloured, coloured_later, "coloured, along itself one sample later");
  within(order, "along the first shaft order");
  within(along_x, "along the state x in e_x");
  EXPECT_FALSE(bounded.on_margin);  // a thousandth of the residual decides every check here

  // An error as large as the residual itself leaves every limit within reach: on the margin, never decided.
  const validity_report vague = validity(dwells, predictor, truth, r, sigma, kOrders, kLags, r.head(rows).norm());
  EXPECT_TRUE(vague.on_margin);
  EXPECT_TRUE(vague.noise_level.on_margin);
  // Without an error nothing is on the margin, and the decision is the values'.
  const validity_report exact = validity(dwells, predictor, truth, r, sigma, kOrders, kLags);
  EXPECT_FALSE(exact.on_margin);
  EXPECT_EQ(exact.pass, bounded.pass);

  // (|r| + e)^2 = |r|^2 + u, exactly enough to hold to rounding.
  for (const double u : {1e-30, 1e-3 * r.squaredNorm(), 4.0 * r.squaredNorm()}) {
    const double back = residual_error_of(r, u);
    EXPECT_NEAR(std::pow(r.norm() + back, 2), r.squaredNorm() + u, 1e-12 * (r.squaredNorm() + u)) << u;
  }
  EXPECT_EQ(residual_error_of(r, 0.0), 0.0);
  EXPECT_TRUE(std::isinf(residual_error_of(r, std::numeric_limits<double>::infinity())));
  EXPECT_TRUE(std::isinf(residual_error_of(r, std::nan(""))));
}

// The verdict's check (docs/loop.md, "Check"): a loop whose check with tighter orbits names other
// effects claims nothing, and whatever either chose is tentative, so that a re-run at other
// tolerances can differ from it only by a claim against "tentative", never by a different effect.
TEST(loop_steps, a_check_that_names_other_effects_leaves_both_tentative) {
  const loop_settings s;
  const auto claimed = [&](std::vector<std::string> names) {
    loop_result r;
    for (const auto& n : names) {
      loop_step step;
      step.effect = n;
      r.effects.push_back(std::move(step));
    }
    r.validity_after.pass = true;  // the residual is noise: a full claim
    claim_inputs in;
    in.residual_is_noise = true;
    r.decision = decide("effects", std::move(names), in, s.rules);
    return r;
  };
  const auto sorted = [](std::vector<std::string> v) { return std::sort(v.begin(), v.end()), v; };
  {  // the check names the same effects (in another order): the claim stands
    loop_result r = claimed({"shaft_bow", "preload"});
    apply_check(r, claimed({"preload", "shaft_bow"}).decision, "", s);
    ASSERT_TRUE(r.check);
    EXPECT_TRUE(r.check->agrees);
    EXPECT_EQ(r.decision.claim, "full");
    EXPECT_EQ(sorted(r.decision.named), sorted({"shaft_bow", "preload"}));
    EXPECT_DOUBLE_EQ(r.check->tolerance_scale, s.orbits.tolerance_scale * s.check_tolerance_scale);
  }
  {  // the check names nothing: the fit's effect is tentative
    loop_result r = claimed({"shaft_bow"});
    apply_check(r, claimed({}).decision, "", s);
    EXPECT_FALSE(r.check->agrees);
    EXPECT_EQ(r.decision.claim, "tentative");
    EXPECT_TRUE(r.decision.named.empty());
    EXPECT_EQ(r.decision.tentative, std::vector<std::string>{"shaft_bow"});
    EXPECT_NE(r.decision.reasons.front().find("names nothing where the fit names shaft_bow"), std::string::npos);
  }
  {  // the check names another effect: both are tentative
    loop_result r = claimed({"shaft_bow"});
    apply_check(r, claimed({"preload"}).decision, "", s);
    EXPECT_EQ(r.decision.claim, "tentative");
    EXPECT_TRUE(r.decision.named.empty());
    EXPECT_EQ(sorted(r.decision.tentative), sorted({"shaft_bow", "preload"}));
  }
  {  // the fit names nothing and the check an effect: it is tentative, nothing is claimed
    loop_result r = claimed({});
    apply_check(r, claimed({"preload"}).decision, "", s);
    EXPECT_TRUE(r.decision.named.empty());
    EXPECT_EQ(r.decision.tentative, std::vector<std::string>{"preload"});
  }
  {  // the check failed: the verdict is tentative and says why
    loop_result r = claimed({"shaft_bow"});
    apply_check(r, std::nullopt, "no orbit", s);
    EXPECT_FALSE(r.check->agrees);
    EXPECT_EQ(r.decision.tentative, std::vector<std::string>{"shaft_bow"});
    EXPECT_NE(r.decision.reasons.front().find("failed (no orbit)"), std::string::npos);
  }
}

}  // namespace
}  // namespace rubref::testing
