// Continuity between the variants: each law is the limit of a richer one. Piecewise-nonlinear
// with k3 = 0 is piecewise-linear, identified with c2 = 0 is piecewise-nonlinear, and a very
// stiff penalty contact approaches the restitution law with r = 1.

#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "props/generators.hpp"
#include "props/prop_support.hpp"

namespace rubref::props {
namespace {

using testing::trajectory;

// k3 z^3 and c2 z_dot^2 with a zero coefficient add exact zeros: the laws give the same forces
// to the bit, and so the same trajectory; 1e-12 of its scale allows for a compiler that
// contracts the arithmetic differently.
constexpr double kSameLawTol = 1e-12;
constexpr double kEventTimeTol = 1e-12;  // s
constexpr int kRevolutions = 3;

template <class Law>
trajectory run_for(const parameters& p, double rpm, const state_type& s0, double t_end, std::size_t samples) {
  const rotor_system<Law> model(p, rpm_to_rad_s(rpm));
  return testing::run(model, s0, t_end, careful(), sample_grid{0.0, t_end / static_cast<double>(samples), samples});
}

void assert_same_trajectory(const trajectory& a, const trajectory& b) {
  RC_ASSERT(a.events.size() == b.events.size());
  for (std::size_t i = 0; i < a.events.size(); ++i) RC_ASSERT(std::abs(a.events[i].t - b.events[i].t) <= kEventTimeTol);
  RC_ASSERT(a.s.size() == b.s.size());
  double scale = 0.0, worst = 0.0;
  for (std::size_t i = 0; i < a.s.size(); ++i)
    for (int c = 0; c < 2; ++c) {
      scale = std::max(scale, std::abs(a.s[i][c]));
      worst = std::max(worst, std::abs(a.s[i][c] - b.s[i][c]));
    }
  RC_ASSERT(worst <= kSameLawTol * scale);
  RC_TAG(worst == 0.0 ? "bitwise identical" : "differs by rounding");
}

RC_GTEST_PROP(continuity, piecewise_nonlinear_with_k3_zero_is_piecewise_linear, (throw_case c)) {
  c.p.k3 = 0.0;
  const double t_end = kRevolutions * 60.0 / c.rpm;
  assert_same_trajectory(run_for<piecewise_nonlinear>(c.p, c.rpm, c.start, t_end, 512),
                         run_for<piecewise_linear>(c.p, c.rpm, c.start, t_end, 512));
}

RC_GTEST_PROP(continuity, identified_with_c2_zero_is_piecewise_nonlinear, (throw_case c)) {
  c.p.c2 = 0.0;
  const double t_end = kRevolutions * 60.0 / c.rpm;
  assert_same_trajectory(run_for<identified>(c.p, c.rpm, c.start, t_end, 512),
                         run_for<piecewise_nonlinear>(c.p, c.rpm, c.start, t_end, 512));
}

// A penalty contact f_N = k1 z (no friction: the restitution law has none) is the impact map
// with r = 1 in the limit k1 -> infinity. Its episode lasts ~pi sqrt(m / (k_y + k1)), during
// which the penalty rotor lags the instantly reflected one, and its viscous loss in contact
// shrinks with it; so the state a while after the episode, and 1 - r_eff = 1 - |y'_out / y'_in|,
// both fall as k1^-1/2. Measured over the 200 cases of the fixed seed: the log-log slope of the
// state error between k1 = 1e10 and 1e12 N/m is -0.498 to -0.502, e.g. relative errors 4.3e-2,
// 4.3e-3, 4.3e-4 at k1 = 1e8, 1e10, 1e12 N/m, and 1 - r_eff 3.0e-3, 3.3e-4, 3.3e-5. Asserted:
// both fall at every step of k1, and the slope is within kSlopeTol of -1/2.
constexpr double kSlopeTol = 0.02;  // 10x the spread measured: the k1^-1/2 law is the leading term

RC_GTEST_PROP(continuity, stiff_penalty_contact_approaches_restitution_with_r_one, (throw_case c)) {
  c.p.mu = 0.0;
  c.p.r = 1.0;
  // No unbalance, and damping of at least 1 kg/s in y: then 1 - r_eff is the contact's viscous
  // loss alone (at ~1e-9, rounding of the event velocities and the unbalance's work in the
  // episode would decide whether it falls).
  c.p.e = 0.0;
  c.p.c_y = std::max(c.p.c_y, 1.0);
  const double period_y = vertical_period(c.p);
  const rotor_system<restitution> impact_model(c.p, rpm_to_rad_s(c.rpm));
  const trajectory scout = testing::run(impact_model, c.start, 0.75 * period_y, careful());
  RC_PRE(!scout.events.empty());
  // A while after the impact, before the next approach (at least a quarter period away).
  const double t_after = scout.events.front().t + period_y / 8.0;
  const trajectory exact = run_for<restitution>(c.p, c.rpm, c.start, t_after, 1);
  RC_PRE(exact.events.size() == 1u);
  const state_type& want = exact.end.s;

  constexpr std::array<double, 3> kStiffness{1e8, 1e10, 1e12};  // N/m
  std::array<double, 3> state_error{}, restitution_defect{};
  for (std::size_t i = 0; i < kStiffness.size(); ++i) {
    parameters p = c.p;
    p.k1 = kStiffness[i];
    const trajectory penalty = run_for<piecewise_linear>(p, c.rpm, c.start, t_after, 1);
    RC_ASSERT(penalty.events.size() == 2u);
    const double pos = std::hypot(want[idx::x], want[idx::y]), vel = std::hypot(want[idx::vx], want[idx::vy]);
    state_error[i] = std::max(std::hypot(penalty.end.s[idx::x] - want[idx::x], penalty.end.s[idx::y] - want[idx::y]) / pos,
                              std::hypot(penalty.end.s[idx::vx] - want[idx::vx], penalty.end.s[idx::vy] - want[idx::vy]) / vel);
    restitution_defect[i] = std::abs(1.0 - std::abs(penalty.events[1].approach_velocity / penalty.events[0].approach_velocity));
  }
  for (std::size_t i = 1; i < kStiffness.size(); ++i) {
    RC_ASSERT(state_error[i] < state_error[i - 1]);
    RC_ASSERT(restitution_defect[i] < restitution_defect[i - 1]);
  }
  const double slope = std::log(state_error[2] / state_error[1]) / std::log(kStiffness[2] / kStiffness[1]);
  RC_ASSERT(std::abs(slope + 0.5) <= kSlopeTol);
}

}  // namespace
}  // namespace rubref::props
