// Periodic orbits by shooting (ref/integrate/shooting.hpp): the exact monodromy against finite
// differences of the one-revolution map for every variant (saltation at onsets, separations,
// impacts), shooting against the closed-form linear response and against the golden files'
// settled orbits, and the Floquet multipliers of the linear rotor in closed form.

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <filesystem>
#include <functional>
#include <string>

#include "ref/analysis/orbit_io.hpp"
#include "ref/integrate/shooting.hpp"
#include "ref/model/rotor_model.hpp"
#include "ref/validation/golden.hpp"
#include "test_support.hpp"

namespace rubref {
namespace {

using testing::all_variant_types;
using testing::variant_name;

// Fourth-order central differences of the map with steps of kStepFraction of each state's scale:
// truncation ~kStepFraction^4 and the flow's noise (events located to 1e-15 s, steps to rtol
// 1e-13) over the step ~1e-9 relative, both well below this; a wrong saltation term is O(1).
constexpr double kMonodromyRelTol = 1e-5;
constexpr double kStepFraction = 1e-4;

// d P(s0) / d s0 column j by the fourth-order stencil.
template <class Map, class State>
State map_derivative(const Map& map, const State& s0, std::size_t j, double h) {
  const auto at = [&](double d) {
    State s = s0;
    s[j] += d;
    return map(s);
  };
  const State a = at(2.0 * h), b = at(h), c = at(-h), d = at(-2.0 * h);
  State out{};
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = (-a[i] + 8.0 * b[i] - 8.0 * c[i] + d[i]) / (12.0 * h);
  return out;
}
// Shooting converges to 1e-12 m; the golden files are the settled end of a 200-revolution run
// (decayed to ~1e-16 relative) at rtol 1e-13: the two agree to this.
constexpr double kGoldenStateTol = 1e-11;  // m

shooting_settings careful() {
  shooting_settings s;
  s.integration.stepper.kind = stepper_kind::rkf78;
  s.integration.stepper.rtol = 1e-13;
  s.integration.stepper.atol = 1e-18;
  s.integration.events.time_tolerance = 1e-15;
  return s;
}

template <class Law>
rotor_system<Law> paper_rotor(double rpm, double clearance = 0.3e-3) {
  parameters p;
  p.clearance = clearance;
  return rotor_system<Law>(p, rpm_to_rad_s(rpm));
}

template <class V>
class monodromy : public ::testing::Test {};
TYPED_TEST_SUITE(monodromy, all_variant_types, variant_name);

// On a rubbing orbit (found by a transient) the exact monodromy matches central differences of
// the one-revolution map: the variational equations and every event's saltation matrix.
TYPED_TEST(monodromy, matches_finite_differences_of_the_map) {
  const auto sys = paper_rotor<TypeParam>(1600.0);
  const integration_options opt = careful().integration;
  null_observer none;
  const auto settled = integrate_hybrid(sys, start_state(sys, state_type{}, 0.0), 60.0 * sys.period(), opt, sample_grid{}, none);
  const double t0 = settled.t, t1 = t0 + sys.period();
  // Start just out of contact so that the map is smooth around s0 (an orbit through contact at
  // t0 is too, but the finite differences would cross the phase boundary).
  state_type s0 = settled.s;
  if (sys.penetration(s0) > -1e-6) s0[idx::y] = sys.clearance() - 1e-6;
  const auto exact = flow_and_monodromy(sys, s0, t0, t1, opt);
  ASSERT_GT(exact.counts.events, 0u) << "the orbit must touch the stator for the test to mean anything";
  const std::array<double, 4> scale{1e-4, 1e-4, 1e-2, 1e-2};
  const auto map = [&](const state_type& s) { return flow_and_monodromy(sys, s, t0, t1, opt).end; };
  for (int j = 0; j < 4; ++j) {
    const auto col = static_cast<std::size_t>(j);
    const state_type fd = map_derivative(map, s0, col, kStepFraction * scale[col]);
    for (int i = 0; i < 4; ++i)
      EXPECT_NEAR(exact.monodromy(i, j), fd[static_cast<std::size_t>(i)], kMonodromyRelTol * exact.monodromy.col(j).cwiseAbs().maxCoeff())
          << "d s" << i << " / d s" << j;
  }
}

// The exact sensitivities of a rubbing periodic orbit (the implicit-function theorem on the
// fixed point: (I - M)^-1 dP/dlambda, one flow) against central differences of the orbit shot at
// lambda +- h, for every parameter the map differentiates and every variant. The differences'
// error: truncation (h / scale)^2 ~ 1e-8 and the shooting's 1e-12 m over 2 h; the orbit's motion
// per unit parameter is O(orbit / scale), so kOrbitSensitivityRelTol of the largest component.
constexpr double kOrbitSensitivityRelTol = 1e-4;
TYPED_TEST(monodromy, orbit_sensitivities_match_finite_differences_of_the_shot_orbit) {
  const double rpm = 1600.0;
  const auto settle = [&](const rotor_system<TypeParam>& sys) {
    null_observer none;
    return integrate_hybrid(sys, start_state(sys, state_type{}, 0.0), 60.0 * sys.period(), careful().integration, sample_grid{}, none).s;
  };
  const auto base = paper_rotor<TypeParam>(rpm);
  const state_type guess = settle(base);
  const auto orbit = shoot_periodic_orbit(base, guess, 0.0, 1, careful());
  ASSERT_TRUE(orbit.converged) << orbit.failure;
  ASSERT_GT(orbit.events_per_period, 0u) << "the orbit must touch the stator for the test to mean anything";
  struct case_t {
    model_parameter p;
    const char* name;
    double h;  // the central difference's step, in the parameter's unit
    std::function<rotor_system<TypeParam>(double)> at;
  };
  parameters p0;
  p0.clearance = 0.3e-3;
  const std::vector<case_t> cases{
      {model_parameter::omega, "omega", 1e-4 * rpm_to_rad_s(rpm), [&](double d) { return rotor_system<TypeParam>(p0, rpm_to_rad_s(rpm) + d); }},
      {model_parameter::clearance, "clearance", 1e-4 * p0.clearance,
       [&](double d) {
         parameters q = p0;
         q.clearance += d;
         return rotor_system<TypeParam>(q, rpm_to_rad_s(rpm));
       }},
      {model_parameter::unbalance, "unbalance", 1e-4 * p0.e,
       [&](double d) {
         parameters q = p0;
         q.e += d;
         return rotor_system<TypeParam>(q, rpm_to_rad_s(rpm));
       }},
      {model_parameter::mu, "mu", 1e-4,
       [&](double d) {
         parameters q = p0;
         q.mu += d;
         return rotor_system<TypeParam>(q, rpm_to_rad_s(rpm));
       }},
  };
  int moving = 0;
  for (const auto& c : cases) {
    const auto exact = periodic_orbit_sensitivity(base, orbit, c.p, careful().integration);
    const auto plus = shoot_periodic_orbit(c.at(c.h), orbit.state, 0.0, 1, careful());
    const auto minus = shoot_periodic_orbit(c.at(-c.h), orbit.state, 0.0, 1, careful());
    ASSERT_TRUE(plus.converged && minus.converged) << c.name;
    Eigen::Vector4d fd;
    for (int i = 0; i < 4; ++i) fd[i] = (plus.state[static_cast<std::size_t>(i)] - minus.state[static_cast<std::size_t>(i)]) / (2.0 * c.h);
    const double size = std::max(exact.state.cwiseAbs().maxCoeff(), fd.cwiseAbs().maxCoeff());
    if (size == 0.0) continue;  // both exactly 0 (the impact law's orbit here does not depend on mu)
    ++moving;
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(exact.state[i], fd[i], kOrbitSensitivityRelTol * size) << "d s" << i << " / d " << c.name;
  }
  EXPECT_GE(moving, 3) << "the orbit must move with most parameters for the test to mean anything";
}

// Without contact the orbit is the particular solution and the multipliers are e^{lambda T} of
// the two damped modes: lambda = -c/2m +- i sqrt(k/m - (c/2m)^2).
TEST(shooting, linear_rotor_in_closed_form) {
  parameters p;
  p.clearance = 1.0;
  const double omega = rpm_to_rad_s(1500.0);
  const rotor_system<identified> sys(p, omega);
  const auto orbit = shoot_periodic_orbit(sys, state_type{}, 0.0, 1, careful());
  ASSERT_TRUE(orbit.converged) << orbit.failure;
  EXPECT_LE(orbit.iterations, 3);  // a linear map: one Newton step, one check
  const free_flight<4> ff(*sys.free_dynamics());
  const state_type p0 = ff.particular(0.0);
  for (int i = 0; i < 2; ++i) EXPECT_NEAR(orbit.state[static_cast<std::size_t>(i)], p0[static_cast<std::size_t>(i)], 1e-14);
  std::vector<double> expected;
  for (const auto& [k, c] : {std::pair{p.k_x, p.c_x}, std::pair{p.k_y, p.c_y}}) {
    const double modulus = std::exp(-c / (2.0 * p.m) * sys.period());
    expected.push_back(modulus);
    expected.push_back(modulus);
  }
  std::sort(expected.rbegin(), expected.rend());
  ASSERT_EQ(orbit.multipliers.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(std::abs(orbit.multipliers[i]), expected[i], 1e-12);
  EXPECT_TRUE(orbit.stable());
}

// Calls f.template operator()<Law>(sys, golden case, file name) for each period-1 golden orbit.
template <class F>
void for_each_period_one_golden_orbit(F&& f) {
  for (const golden_spec& spec : golden_matrix()) {
    const auto path = std::filesystem::path(RUBREF_GOLDEN_DIR) / golden_file_name(spec);
    const golden_case g = read_golden_case(read_record(path), path.string());
    if (g.comparison != comparison_kind::orbit || g.period_revs != 1) continue;
    visit_variant(g.request.variant, [&]<class V>() {
      f.template operator()<V>(rotor_system<V>(g.request.params, rpm_to_rad_s(g.request.rpm)), g, path.string());
    });
  }
}

// Shooting from near a golden file's settled state (1 um and 1 mm/s off) lands on the orbit a
// 200-revolution run settles on (the golden files of period 1), and finds it stable. (From far
// away Newton may land on a coexisting orbit: above the jump the contact-free one.)
TEST(shooting, finds_the_golden_orbits_settled_state) {
  int checked = 0;
  for_each_period_one_golden_orbit([&]<class V>(const rotor_system<V>& sys, const golden_case& g, const std::string& path) {
      const double t0 = g.t.front();
      const state_type guess{g.x.front() + 1e-6, g.y.front() - 1e-6, g.vx.front() + 1e-3, g.vy.front() - 1e-3};
      const auto orbit = shoot_periodic_orbit(sys, guess, t0, 1, careful());
      if (!orbit.converged) {
        ADD_FAILURE() << path << ": " << orbit.failure;
        return;
      }
      EXPECT_NEAR(orbit.state[idx::x], g.x.front(), kGoldenStateTol) << path;
      EXPECT_NEAR(orbit.state[idx::y], g.y.front(), kGoldenStateTol) << path;
      EXPECT_TRUE(orbit.stable()) << path << ": largest multiplier " << orbit.max_multiplier_modulus();
      ++checked;
  });
  EXPECT_GT(checked, 5);
}

// Inexact Newton (shooting_settings::coarse_while_far) from a guess far from each period-1 golden
// orbit lands where exact Newton does: the coarse evaluations change the path, not the fixed
// point, and the converged evaluation is at the full tolerance (so the multipliers are the same).
// The guess is 30 um and 30 mm/s off (Newton's residual there ~0.1 of the orbit: coarse steps).
constexpr double kSameFixedPointTol = 5e-12;  // m: two solutions each within 1e-12 m of P(s) = s, through M - I
constexpr double kSameMultiplierTol = 1e-8;   // both monodromies' Phi held to ~1e-9 (steppers.hpp), with margin
TEST(shooting, inexact_newton_lands_on_the_exact_newton_orbit) {
  int compared = 0;
  for_each_period_one_golden_orbit([&]<class V>(const rotor_system<V>& sys, const golden_case& g, const std::string& path) {
      const double t0 = g.t.front();
      const state_type guess{g.x.front() + 3e-5, g.y.front() - 3e-5, g.vx.front() + 3e-2, g.vy.front() - 3e-2};
      shooting_settings exact_newton, inexact_newton;
      inexact_newton.coarse_while_far = true;
      const auto a = shoot_periodic_orbit(sys, guess, t0, 1, exact_newton);
      const auto b = shoot_periodic_orbit(sys, guess, t0, 1, inexact_newton);
      if (!a.converged) return;  // (from this far a coexisting orbit or none: not the point here)
      ASSERT_TRUE(b.converged) << path << ": " << b.failure;
      EXPECT_LE(b.residual, inexact_newton.tolerance) << path;
      for (int i = 0; i < 4; ++i)
        EXPECT_NEAR(b.state[static_cast<std::size_t>(i)], a.state[static_cast<std::size_t>(i)], kSameFixedPointTol * (i < 2 ? 1.0 : sys.omega()))
            << path << " state " << i;
      EXPECT_NEAR(b.max_multiplier_modulus(), a.max_multiplier_modulus(), kSameMultiplierTol) << path;
      ++compared;
  });
  EXPECT_GT(compared, 10);
}

// The rig's model (6 states with a compliant stator, 4 moving with a rigid one) shoots too, and
// its monodromy matches finite differences across Hertz and Hunt-Crossley terms and a stator.
TEST(shooting, rig_model_with_effects_matches_finite_differences) {
  parameters p;
  effect_parameters fx;
  fx.hertz_k = 5e8;
  fx.hc_lambda = 1e10;
  fx.stator_k = 5e7;
  fx.stator_m = 0.3;
  fx.stator_c = 200.0;
  fx.mu_static = 0.4;
  const rotor_with_effects<identified> sys(p, fx, rpm_to_rad_s(1600.0));
  const integration_options opt = careful().integration;
  null_observer none;
  const auto settled = integrate_hybrid(sys, start_state(sys, std::array<double, 6>{}, 0.0), 60.0 * sys.period(), opt, sample_grid{}, none);
  auto s0 = settled.s;
  if (sys.penetration(s0) > -1e-6) s0[idx::y] -= sys.penetration(s0) + 1e-6;
  const double t0 = settled.t, t1 = t0 + sys.period();
  const auto exact = flow_and_monodromy(sys, s0, t0, t1, opt);
  ASSERT_GT(exact.counts.events, 0u);
  // The stator's (w, w') reach the rotor only through the next contact, a weak signal: steps large
  // enough for it to stand above the flow's noise (1e-8 m, 1e-4 m/s move the stator by < 1e-8 m).
  const std::array<double, 6> scale{1e-4, 1e-4, 1e-2, 1e-2, 1e-4, 1.0};
  const auto map = [&](const std::array<double, 6>& s) { return flow_and_monodromy(sys, s, t0, t1, opt).end; };
  for (int j = 0; j < 6; ++j) {
    const auto col = static_cast<std::size_t>(j);
    const auto fd = map_derivative(map, s0, col, kStepFraction * scale[col]);
    for (int i = 0; i < 6; ++i)
      EXPECT_NEAR(exact.monodromy(i, j), fd[static_cast<std::size_t>(i)], kMonodromyRelTol * exact.monodromy.col(j).cwiseAbs().maxCoeff())
          << "d s" << i << " / d s" << j;
  }
  const auto orbit = shoot_periodic_orbit(sys, settled.s, t0, 1, careful());
  ASSERT_TRUE(orbit.converged) << orbit.failure;
  EXPECT_EQ(orbit.multipliers.size(), 6u);
}

}  // namespace
}  // namespace rubref
