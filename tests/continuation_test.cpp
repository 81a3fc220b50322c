// Branches of periodic orbits (ref/orbits/continuation.hpp): the contact-free branch against the
// closed form, every point a fixed point of the map, folds where a Floquet multiplier crosses +1
// and where the sweeps jump, grazing where the closed-form orbit touches the stator, bad requests;
// the map's exact dP/dlambda (ref/integrate/shooting.hpp) against central differences, and a
// restitution branch reaching its grazing from either side in a few dozen points.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <set>
#include <string>

#include "ref/base/errors.hpp"
#include "ref/integrate/shooting.hpp"
#include "ref/model/closed_form.hpp"
#include "ref/orbits/continuation.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "ref/sweep/sweep.hpp"
#include "test_support.hpp"

namespace rubref {
namespace {

// Each point converges to |P(s) - s| <= 1e-12 m; an orbit amplitude of >= 1e-5 m then carries a
// relative error of <= 1e-7 into its 1X coefficients (a DFT of 128 exact samples of a pure
// harmonic, exact to rounding).
constexpr double kClosedFormRelTol = 1e-7;
// Re-integrating a converged point for one period with the recording integrator (dense output,
// rtol 1e-10) returns to it within this: the shooting tolerance plus the recorder's own error.
constexpr double kFixedPointTol = 1e-9;  // m

// A speed branch traced from `from` to `to` (downward when from > to).
continuation_request speed_branch(const std::string& variant, double clearance, double from, double to) {
  continuation_request r;
  r.variant = variant;
  r.params.clearance = clearance;
  r.from = std::min(from, to);
  r.to = std::max(from, to);
  r.downward = from > to;
  return r;
}

// det(M - I) from the multipliers: it changes sign where one real multiplier crosses +1 (a fold).
double det_monodromy_minus_identity(const branch_point& p) {
  std::complex<double> d = 1.0;
  for (const auto& m : p.multipliers) d *= m - 1.0;
  return d.real();
}

TEST(continuation, bad_requests_are_rejected) {
  auto r = speed_branch("identified", 0.3e-3, 1500, 1500);
  EXPECT_THROW(validate(r), input_error);  // an empty range
  r.from = 1600;
  EXPECT_THROW(validate(r), input_error);  // from > to (downward is a setting)
  r = speed_branch("identified", 0.3e-3, 1500, 1600);
  r.periods = 0;
  EXPECT_THROW(validate(r), input_error);
  r = speed_branch("identified", -0.3e-3, 1500, 1600);
  EXPECT_THROW(validate(r), input_error);  // a parameter, checked at the ends of the range
  r = speed_branch("identified", 0.3e-3, -5, 1500);
  EXPECT_THROW(validate(r), input_error);  // a negative speed at the start
  EXPECT_THROW(parse_continuation_parameter("rpm"), input_error);
  EXPECT_EQ(parse_continuation_parameter("clearance"), continuation_parameter::clearance);
}

// Far from the stator the branch is the linear unbalance response at every speed, stable, with
// no special point, and it covers the range in both directions.
TEST(continuation, contact_free_branch_is_the_closed_form) {
  for (const auto& [from, to] : {std::pair{1300.0, 2200.0}, std::pair{2200.0, 1300.0}}) {
    const auto r = speed_branch("piecewise-linear", 5e-3, from, to);
    const auto b = continue_branch(r);
    ASSERT_TRUE(b.reached_end) << b.stopped;
    EXPECT_TRUE(b.special.empty());
    EXPECT_EQ(b.points.front().rpm, from);
    EXPECT_EQ(b.points.back().rpm, to);
    EXPECT_GE(b.points.size(), 20u);  // the 5-degree turn per step resolves the critical speed's phase swing
    for (const auto& p : b.points) {
      const unbalance_response exact(r.params, rpm_to_rad_s(p.rpm));
      const std::complex<double> j(0.0, 1.0);
      const auto fwd = (exact.x_phasor + j * exact.y_phasor) / 2.0;
      const auto bwd = (std::conj(exact.x_phasor) + j * std::conj(exact.y_phasor)) / 2.0;
      EXPECT_LE(std::abs(p.summary.forward_1x - fwd), kClosedFormRelTol * std::abs(fwd)) << p.rpm;
      EXPECT_LE(std::abs(p.summary.backward_1x - bwd), kClosedFormRelTol * std::abs(fwd)) << p.rpm;
      EXPECT_TRUE(p.stable) << p.rpm;
      EXPECT_LT(p.max_z, 0.0) << p.rpm;
    }
  }
}

// The speed at which the contact-free orbit's top |Y(w)| equals the clearance, on the side of
// the resonance given by [lo, hi] (|Y| monotone there), by bisection on the closed form.
double closed_form_grazing_rpm(const parameters& p, double lo, double hi) {
  const auto top = [&](double rpm) { return std::abs(unbalance_response(p, rpm_to_rad_s(rpm)).y_phasor) - p.clearance; };
  const bool rising = top(lo) < top(hi);
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    ((top(mid) < 0.0) == rising ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// max_z is exact to rounding on both sides (Brent on the exact free flight; episode peaks on the
// dense output); the zero is located to 1e-10 of arclength, which near the grazing (where the
// rubbing states move fast with the speed) is up to ~1e-6 rpm of the parameter (3e-7 rpm seen).
constexpr double kGrazingRpmTol = 1e-5;

// Run up at 0.3 mm, the branch leaves the contact-free response where its top touches the
// stator; run down at 0.4 mm, the contact-free branch from 2200 rpm grazes where the closed form
// says and folds back at once (unstable, rubbing): below that speed the contact-free orbit does
// not exist, which is the down sweep's jump (docs/sweeps.md).
TEST(continuation, grazing_is_where_the_closed_form_orbit_touches) {
  {
    const auto r = speed_branch("identified", 0.3e-3, 1300, 2200);
    const auto b = continue_branch(r);
    ASSERT_TRUE(b.reached_end) << b.stopped;
    const auto g = std::find_if(b.special.begin(), b.special.end(), [](const auto& s) { return s.kind == special_kind::grazing; });
    ASSERT_NE(g, b.special.end());
    EXPECT_TRUE(g->located);
    EXPECT_NEAR(g->rpm, closed_form_grazing_rpm(r.params, 1300, b.points[g->after_point + 1].rpm), kGrazingRpmTol);
  }
  {
    const auto r = speed_branch("identified", 0.4e-3, 2200, 1300);
    const auto b = continue_branch(r);
    EXPECT_FALSE(b.reached_end) << "the rubbing branch born at the grazing turns back to higher speeds";
    const auto g = std::find_if(b.special.begin(), b.special.end(), [](const auto& s) { return s.kind == special_kind::grazing; });
    ASSERT_NE(g, b.special.end());
    EXPECT_TRUE(g->located);
    EXPECT_NEAR(g->rpm, closed_form_grazing_rpm(r.params, b.points[g->after_point + 1].rpm, 2200), kGrazingRpmTol);
  }
}

// Whether a transient from `start` at `rpm` ends rubbing (400 revolutions: the slow passage past
// a fold's ghost takes tens of revolutions at 3 rpm from it, the damping's decay ~5 per e-fold).
bool transient_ends_rubbing(const continuation_request& r, double rpm, const state_type& start) {
  run_request run = request_at(r, rpm);
  run.initial_state = start;
  run.settle_revs = 400;
  run.record_revs = 6;
  return summarize(simulate(run)).contact_episodes_per_rev > 0.0;
}

// Over 1300-3500 rpm at 0.3 mm the branch is an S: contact-free, grazing, rubbing (period
// doubled in a band), an upper fold, the unstable rubbing branch back down, a lower fold at the
// second grazing, contact-free again. Every point is a periodic orbit; at each fold a real
// multiplier crosses +1 (det(M - I) changes sign: the tangent test and the monodromy are
// independent computations of one event) and stability changes; a fold is the extreme speed
// between its neighbours. A transient started from each fold's orbit 3 rpm beyond it jumps to
// the other branch, as the sweeps do (docs/sweeps.md).
TEST(continuation, folds_bound_the_coexisting_branches) {
  const auto r = speed_branch("identified", 0.3e-3, 1300, 3500);
  const auto b = continue_branch(r);
  ASSERT_TRUE(b.reached_end) << b.stopped;
  for (const auto& p : b.points) {
    const orbit o = record_periods(request_at(r, p.parameter), p.state, r.periods);
    for (std::size_t i = 0; i < 4; ++i) {
      const double scale = i < 2 ? 1.0 : rpm_to_rad_s(p.rpm);
      EXPECT_LE(std::abs(o.end.s[i] - p.state[i]) / scale, kFixedPointTol) << p.rpm << " component " << i;
    }
  }
  std::vector<special_point> folds;
  for (const auto& s : b.special) {
    if (s.kind != special_kind::fold) continue;
    folds.push_back(s);
    EXPECT_TRUE(s.located);
    const auto& a = b.points[s.after_point];
    const auto& c = b.points[s.after_point + 1];
    EXPECT_LT(det_monodromy_minus_identity(a) * det_monodromy_minus_identity(c), 0.0) << s.rpm;
    EXPECT_NE(a.stable, c.stable) << s.rpm;
    const double lo = std::min(a.rpm, c.rpm), hi = std::max(a.rpm, c.rpm);
    EXPECT_TRUE(s.rpm >= hi - 1e-9 || s.rpm <= lo + 1e-9) << s.rpm << " between " << lo << " and " << hi;
  }
  ASSERT_EQ(folds.size(), 2u);
  const auto& upper = folds[0];  // traced first: the rubbing branch's end
  const auto& lower = folds[1];  // the contact-free branch's end, at its grazing
  ASSERT_GT(upper.rpm, lower.rpm);
  EXPECT_FALSE(transient_ends_rubbing(r, upper.rpm + 3.0, upper.state)) << "above the upper fold only the contact-free orbit is left";
  EXPECT_TRUE(transient_ends_rubbing(r, lower.rpm - 3.0, lower.state)) << "below the lower fold only the rubbing orbit is left";
  // Between the folds both stable orbits exist: the branch has stable rubbing and stable
  // contact-free points there.
  bool rubbing_stable = false, free_stable = false;
  for (const auto& p : b.points) {
    if (p.rpm <= lower.rpm || p.rpm >= upper.rpm || !p.stable) continue;
    (p.max_z > 0.0 ? rubbing_stable : free_stable) = true;
  }
  EXPECT_TRUE(rubbing_stable && free_stable);
}

// The speed of a sweep's jump off the branch it starts on: the last grid speed on it and the
// first off it (rubbing or not, by whether the point touches the stator).
std::pair<double, double> sweep_jump(const sweep_branch& b) {
  const auto touches = [](const sweep_point& p) { return p.summary.contact_episodes_per_rev > 0.0; };
  for (std::size_t i = 1; i < b.points.size(); ++i)
    if (touches(b.points[i]) != touches(b.points[0])) return {b.points[i - 1].rpm, b.points[i].rpm};
  return {NAN, NAN};
}

// The brute-force check of the folds at 0.4 mm: a run-up sweep (10 rpm steps, 60 settling
// revolutions each) leaves the rubbing branch at the upper fold, a run-down leaves the
// contact-free branch at the lower one, each jump within one step of its fold: the slow passage
// past a fold's ghost may carry a sweep a step beyond it, and next to a grazing fold the
// contact-free orbit clears the stator by so little that the transient of a speed step touches
// it a step early.
TEST(continuation, sweeps_jump_within_one_step_of_the_folds) {
  const auto r = speed_branch("identified", 0.4e-3, 1300, 3000);
  const auto b = continue_branch(r);
  ASSERT_TRUE(b.reached_end) << b.stopped;
  std::vector<double> folds;
  for (const auto& s : b.special)
    if (s.kind == special_kind::fold) folds.push_back(s.rpm);
  ASSERT_EQ(folds.size(), 2u);
  const double upper = std::max(folds[0], folds[1]), lower = std::min(folds[0], folds[1]);
  constexpr double step = 10.0;

  sweep_settings up;
  up.params = r.params;
  up.from_rpm = 1500.0;  // past the period-doubled band, on the stable rubbing branch
  up.to_rpm = std::ceil(upper / step) * step + 2.0 * step;
  up.step_rpm = step;
  up.first_settle_revs = 300;
  const auto [up_last, up_first_off] = sweep_jump(run_branch(up, sweep_direction::up));
  EXPECT_LE(up_last - step, upper);
  EXPECT_LE(upper, up_first_off + step);

  sweep_settings down = up;
  down.from_rpm = std::floor(lower / step) * step - 3.0 * step;
  down.to_rpm = std::ceil(lower / step) * step + 3.0 * step;  // contact-free there
  const auto [down_last, down_first_off] = sweep_jump(run_branch(down, sweep_direction::down));
  EXPECT_GE(down_last + step, lower);
  EXPECT_GE(lower, down_first_off - step);
}

// ---- dP/dlambda, the continuation's last Jacobian column (ref/integrate/shooting.hpp) ----

// The model with one parameter moved by d (w in rad/s, delta and e in m, mu).
template <class Law>
rotor_system<Law> moved(const parameters& p, double omega, model_parameter which, double d) {
  parameters q = p;
  switch (which) {
    case model_parameter::omega: omega += d; break;
    case model_parameter::clearance: q.clearance += d; break;
    case model_parameter::unbalance: q.e += d; break;
    case model_parameter::mu: q.mu += d; break;
  }
  return rotor_system<Law>(q, omega);
}

// The flows as shooting_test's: rkf78 near the limit of double, events to 1e-15 s.
integration_options careful_flows() {
  integration_options o = testing::reference_options();
  o.events.time_tolerance = 1e-15;
  return o;
}

// The fourth-order central difference of the one-revolution map P(s0; lambda) = s(T(lambda)) with
// a step of kParameterStep of the parameter's value: truncation ~1e-16 relative, and the flows'
// noise (events to 1e-15 s, rtol 1e-13, ~1e-17 m) over the step ~1e-9 relative.
constexpr double kParameterStep = 1e-4;
// The exact column is integrated with Phi's step control, 1e3 looser than the state's (rtol 1e-10
// here), and its events carry the same 1e-15 s: it agrees with the difference to ~1e-9 of the
// column (measured: <= 2e-9 over the 4 laws and 4 parameters). A missing saltation term or dT/dw
// column errs by O(1).
constexpr double kParameterColumnRelTol = 1e-7;

// From the state `revs` revolutions after rest (rotor_system<Law>(p, w)), the exact dP/dlambda of
// map_and_sensitivities matches central differences of the map for each of w, delta, e and mu,
// over a revolution whose events are `kinds`.
template <class Law>
void expect_exact_parameter_columns(const parameters& p, double rpm, int revs, const std::set<event_kind>& kinds) {
  const double omega = rpm_to_rad_s(rpm);
  const auto sys = rotor_system<Law>(p, omega);
  const integration_options opt = careful_flows();
  // The state after whole revolutions (the forcing's angle as at t = 0), put just out of contact
  // so that the map is smooth around it.
  null_observer none;
  state_type s0 = integrate_hybrid(sys, start_state(sys, state_type{}, 0.0), revs * sys.period(), opt, sample_grid{}, none).s;
  if (sys.penetration(s0) > -1e-2 * p.clearance) s0[idx::y] = sys.clearance() * (1.0 - 1e-2);
  std::set<event_kind> seen;
  for (const auto& e : testing::run(sys, s0, sys.period(), opt).events) seen.insert(e.kind);
  ASSERT_EQ(seen, kinds) << "the revolution's events";
  double state_size = 0.0;
  // Velocities weigh as positions over a radian of the shaft (as the shooting's residual).
  const std::array<double, 4> weight{1.0, 1.0, 1.0 / omega, 1.0 / omega};
  for (std::size_t i = 0; i < 4; ++i) state_size = std::max(state_size, std::abs(s0[i]) * weight[i]);
  const std::array<std::pair<model_parameter, double>, 4> cases{
      {{model_parameter::omega, omega}, {model_parameter::clearance, p.clearance}, {model_parameter::unbalance, p.e}, {model_parameter::mu, p.mu}}};
  for (const auto& one : cases) {
    const model_parameter which = one.first;  // (a named copy: clang before 16 cannot capture a structured binding)
    const double value = one.second;
    SCOPED_TRACE(::testing::Message() << "d/d parameter " << static_cast<int>(which) << " (w, delta, e, mu)");
    const auto exact = map_and_sensitivities(sys, s0, 0.0, 1, which, opt);
    const auto map = [&](double d) {
      const auto moved_sys = moved<Law>(p, omega, which, d);
      return integrate_hybrid(moved_sys, start_state(moved_sys, s0, 0.0), moved_sys.period(), opt, sample_grid{}, none).s;
    };
    const double h = kParameterStep * value;
    const state_type a = map(2.0 * h), b = map(h), c = map(-h), d = map(-2.0 * h);
    double size = 0.0;
    for (std::size_t i = 0; i < 4; ++i) size = std::max(size, std::abs(exact.parameter[static_cast<int>(i)]) * weight[i]);
    // Relative to the column's size, or for a column that vanishes (mu in the impact law) to the
    // state's size over the parameter's: the differences there are rounding, ~1e-16 m.
    const double tol = kParameterColumnRelTol * std::max(size, state_size / value);
    for (std::size_t i = 0; i < 4; ++i) {
      const double fd = (-a[i] + 8.0 * b[i] - 8.0 * c[i] + d[i]) / (12.0 * h);
      EXPECT_NEAR(exact.parameter[static_cast<int>(i)] * weight[i], fd * weight[i], tol) << "component " << i;
    }
    if (which == model_parameter::mu && !compliant_law<Law>) {
      EXPECT_EQ(size, 0.0) << "the impact law has no friction: mu does not enter its map";
    } else {
      EXPECT_GT(size, 0.0);
    }
    if (which == model_parameter::omega) {  // the end's dT/dw term is not small: without it the column is wrong
      EXPECT_GT((exact.parameter - exact.parameter_at_fixed_end).cwiseAbs().maxCoeff(), 1e3 * kParameterColumnRelTol * size / weight[2]);
    }
  }
}

template <class V>
class parameter_column : public ::testing::Test {};
TYPED_TEST_SUITE(parameter_column, testing::all_variant_types, testing::variant_name);

// The paper's rotor at 1600 rpm and 0.3 mm: the compliant laws slide through a contact episode
// each revolution (the parameter's variational equation in contact, its saltation at the onset,
// where c2 z'^2 makes the force jump, and at the separation), the restitution law impacts once.
TYPED_TEST(parameter_column, matches_central_differences_of_the_map) {
  if constexpr (compliant_law<TypeParam>) {
    expect_exact_parameter_columns<TypeParam>(parameters{}, 1600.0, 60, {event_kind::contact_onset, event_kind::separation});
  } else {
    expect_exact_parameter_columns<TypeParam>(parameters{}, 1600.0, 60, {event_kind::impact});
  }
}

// chatter_test's pressed rotor (300 rpm, 10 um, e = 1 mm) with a plastic impact (r = 0), in its
// sixth revolution from rest: an impact (y' -> 0) where the unbalance does not press it, then one
// where it does, which sticks at once; stuck, y = delta is held (and moves with delta: the stick's
// R_lambda) until the release, where the free acceleration turns (a function of w and e).
TEST(parameter_column, matches_central_differences_through_a_stuck_phase) {
  parameters p;
  p.clearance = 1e-5;
  p.e = 1e-3;
  p.r = 0.0;
  expect_exact_parameter_columns<restitution>(p, 300.0, 5, {event_kind::impact, event_kind::stick, event_kind::release});
}

// A restitution branch meets its grazing with an unbounded slope (the impact velocity ~
// sqrt(lambda - lambda_g), docs/orbits.md). With a forward difference for dP/dlambda that erred
// by ~h / (lambda - lambda_g) the corrector slowed down there and the branch crept towards the
// grazing until max_points (5000: issue 45; in speed from the impacting side down, in clearance from
// it up). With the exact column each side reaches it in a few dozen points, and stops at the
// contact-free orbit's grazing in closed form: the speed where |Y(w)| is the clearance, or the
// clearance |Y(w)|.
// Measured 20-71 points (the impacting side's steps follow its turning from the range's end).
constexpr std::size_t kMaxPointsOntoGrazing = 100;
// The impacting side stops where its largest multiplier (~1 / impact velocity) is ~4e6 and
// Newton cannot reach 1e-12 m any more: 2e-7 of the range from the grazing in speed, 7e-7 in
// clearance (with the forward difference: 1e-4 and 7e-3). The contact-free side grazes to 1e-14 m.
constexpr double kGrazingReachedTol = 1e-5;  // of the range

TEST(continuation, restitution_branches_reach_their_grazing_from_either_side) {
  struct approach {
    continuation_parameter parameter;
    double from, to;
    bool downward;
    bool impacting;  // the side the branch comes from
  };
  const approach approaches[] = {
      // at 0.3 mm the contact-free orbit grazes at 1416.7 rpm; above it only the impacting one exists
      {continuation_parameter::speed, 1300.0, 1600.0, false, false},
      {continuation_parameter::speed, 1300.0, 1600.0, true, true},
      // at 1400 rpm the contact-free orbit's top is at 0.2675 mm: it impacts under a smaller clearance
      {continuation_parameter::clearance, 0.2e-3, 0.4e-3, false, true},
      {continuation_parameter::clearance, 0.2e-3, 0.4e-3, true, false},
  };
  for (const approach& a : approaches) {
    continuation_request r;
    r.variant = "restitution";
    r.parameter = a.parameter;
    r.from = a.from;
    r.to = a.to;
    r.downward = a.downward;
    r.rpm = 1400.0;
    const std::string what = std::string(to_string(a.parameter)) + (a.downward ? " down" : " up");
    const auto b = continue_branch(r);
    ASSERT_FALSE(b.reached_end) << what;
    EXPECT_LE(b.points.size(), kMaxPointsOntoGrazing) << what << ": " << b.stopped;
    ASSERT_FALSE(b.special.empty()) << what;
    const special_point& g = b.special.back();
    EXPECT_EQ(g.kind, special_kind::grazing) << what;
    EXPECT_EQ(g.after_point, b.points.size() - 1) << what << ": the grazing ends the branch";
    for (const auto& p : b.points) EXPECT_EQ(p.summary.contact_episodes_per_rev > 0.0, a.impacting) << what << " at " << p.parameter;
    const double grazing = a.parameter == continuation_parameter::speed
                               ? closed_form_grazing_rpm(r.params, 1300.0, 1500.0)
                               : std::abs(unbalance_response(r.params, rpm_to_rad_s(r.rpm)).y_phasor);
    EXPECT_NEAR(b.points.back().parameter, grazing, kGrazingReachedTol * (r.to - r.from)) << what;
  }
}

}  // namespace
}  // namespace rubref
