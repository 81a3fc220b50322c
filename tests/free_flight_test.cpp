// Exact free flight (ref/model/free_flight.hpp): the closed-form arc against the careful
// stepper, its transition matrix against finite differences, and the onset search against grazing
// orbits whose crossing is known in closed form.

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <iomanip>
#include <random>
#include <vector>

#include "ref/model/free_flight.hpp"
#include "ref/model/rotor_model.hpp"
#include "test_support.hpp"

namespace rubref {
namespace {

using testing::reference_options;

// rkf78 at rtol 1e-13 is good to ~1e-16 m per revolution on a 0.1 mm orbit; over 10 revolutions
// the two solutions agree to this (the arc itself is exact to rounding).
constexpr double kArcTol = 1e-13;  // m
// The onset bracket's width (event_settings::time_tolerance) plus the closed form's rounding.
constexpr double kOnsetTimeTol = 2e-13;  // s

template <class System>
state_of<System> numeric_flow(const System& sys, const state_of<System>& s0, double t1) {
  integration_options opt = reference_options();
  opt.exact_free_flight = false;
  null_observer none;
  return integrate_hybrid(sys, basic_hybrid_state<state_of<System>>{s0, 0.0, contact_phase::free, 0.0}, t1, opt, sample_grid{}, none).s;
}

parameters far_stator() {
  parameters p;
  p.clearance = 1.0;  // m: no contact, free flight only
  return p;
}

TEST(free_flight, arc_matches_the_numeric_flow_of_the_rotor) {
  const rotor_system<identified> sys(far_stator(), rpm_to_rad_s(1600.0), contact_phase::free);
  const free_flight<4> ff(*sys.free_dynamics());
  const state_type s0{1e-4, -2e-4, 0.03, 0.05};
  const auto arc = ff.from(0.0, s0);
  for (double revs : {0.3, 1.0, 10.0}) {
    const double t = revs * sys.period();
    const state_type a = arc.at(t), n = numeric_flow(sys, s0, t);
    EXPECT_NEAR(a[idx::x], n[idx::x], kArcTol) << revs << " rev";
    EXPECT_NEAR(a[idx::y], n[idx::y], kArcTol) << revs << " rev";
    EXPECT_NEAR(a[idx::vx], n[idx::vx], kArcTol * sys.omega()) << revs << " rev";
    EXPECT_NEAR(a[idx::vy], n[idx::vy], kArcTol * sys.omega()) << revs << " rev";
  }
}

// The rig's linear effects: preload, cross-coupling, bow, 2X misalignment, a compliant stator.
TEST(free_flight, arc_matches_the_numeric_flow_with_linear_effects) {
  effect_parameters fx;
  fx.preload_x = 2.0;
  fx.preload_y = -3.0;
  fx.k_xy = 1500.0;
  fx.k_yx = -1500.0;
  fx.bow = 2e-5;
  fx.bow_phase = 0.7;
  fx.misalignment_force = 0.5;
  fx.misalignment_phase = -1.1;
  fx.stator_k = 5e6;
  fx.stator_m = 0.5;
  fx.stator_c = 100.0;
  const rotor_with_effects<identified> sys(far_stator(), fx, rpm_to_rad_s(1550.0), {}, contact_phase::free);
  const free_flight<6> ff(*sys.free_dynamics());
  const std::array<double, 6> s0{1e-4, -2e-4, 0.03, 0.05, 1e-7, -1e-4};
  const auto arc = ff.from(0.0, s0);
  for (double revs : {0.5, 4.0}) {
    const double t = revs * sys.period();
    const auto a = arc.at(t), n = numeric_flow(sys, s0, t);
    for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(a[i], n[i], i < 2 || i == 4 ? kArcTol : kArcTol * sys.omega()) << i;
  }
}

// Along a uniform grid an arc is walked (free_flight::arc::walk): its phasors turned by one
// step's, taken exactly every 32nd point. It must agree with at() to rounding: each term's phasor
// is at most ~32 complex multiplies off (~1e-14 of the term), and the terms here are below a
// millimetre, so 1e-16 m (times w for velocities) bounds it with room. A wrong step, a mode
// turned by another's step or a missed turn is off by a term's size, far above it.
constexpr double kWalkTol = 1e-16;  // m

TEST(free_flight, a_walk_along_a_uniform_grid_is_the_arc) {
  effect_parameters fx;
  fx.k_xy = 1500.0;
  fx.bow = 2e-5;
  fx.misalignment_force = 0.5;
  fx.stator_k = 5e6;
  fx.stator_m = 0.5;
  fx.stator_c = 100.0;
  const rotor_with_effects<identified> sys(far_stator(), fx, rpm_to_rad_s(1550.0), {}, contact_phase::free);
  const free_flight<6> ff(*sys.free_dynamics());
  const std::array<double, 6> s0{1e-4, -2e-4, 0.03, 0.05, 1e-7, -1e-4};
  const double t0 = 0.013, dt = sys.period() / 256.0;
  const auto arc = ff.from(t0, s0);
  const auto step = ff.step_phasors(dt);
  auto walk = arc.walk_by(step);
  for (std::size_t k = 0; k < 3 * 256; ++k) {
    const double t = t0 + 0.25 * dt + static_cast<double>(k) * dt;
    const auto w = walk.next(t), a = arc.at(t);
    for (std::size_t i = 0; i < 6; ++i) {
      const double tol = i < 2 || i == 4 ? kWalkTol : kWalkTol * sys.omega();
      if (k % 32 == 0)
        EXPECT_EQ(w[i], a[i]) << "point " << k << ", component " << i << ": taken exactly";
      else
        EXPECT_NEAR(w[i], a[i], tol) << "point " << k << ", component " << i;
    }
  }
}

// The integrator walks free arcs along a uniform grid and reads explicit times with at(): the same
// orbit either way (through contacts: the paper's rub at 0.3 mm, 1600 rpm).
TEST(free_flight, a_uniform_grid_samples_as_its_explicit_times) {
  parameters p;
  p.clearance = 0.3e-3;
  const rotor_system<identified> sys(p, rpm_to_rad_s(1600.0), contact_phase::free);
  integration_options opt = reference_options();
  const std::size_t n = 4 * 128;
  const double dt = sys.period() / 128.0, t_end = n * dt;
  std::vector<double> times(n);
  for (std::size_t k = 0; k < n; ++k) times[k] = static_cast<double>(k) * dt;
  struct recorder {
    std::vector<state_type> states;
    std::size_t events = 0;
    void on_sample(double, const state_type& s, const rotor_system<identified>&) { states.push_back(s); }
    void on_event(const basic_contact_event<state_type>&) { ++events; }
  } uniform, listed;
  const basic_hybrid_state<state_type> start{state_type{0.0, 0.0, 0.0, 0.0}, 0.0, contact_phase::free, 0.0};
  integrate_hybrid(sys, start, t_end, opt, sample_grid(0.0, dt, n), uniform);
  integrate_hybrid(sys, start, t_end, opt, sample_grid::at(times), listed);
  ASSERT_GT(uniform.events, 0u) << "the run must touch the stator, so arcs end and restart between samples";
  ASSERT_EQ(uniform.states.size(), n);
  ASSERT_EQ(listed.states.size(), n);
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t i = 0; i < 4; ++i)
      EXPECT_NEAR(uniform.states[k][i], listed.states[k][i], i < 2 ? kWalkTol : kWalkTol * sys.omega()) << "sample " << k << ", " << i;
}

// A rigid stator's (w, w') are constants of the flow, kept exactly.
TEST(free_flight, a_rigid_stator_stays_put) {
  const rotor_with_effects<identified> sys(far_stator(), effect_parameters{}, rpm_to_rad_s(1550.0), {}, contact_phase::free);
  const free_flight<6> ff(*sys.free_dynamics());
  const auto s = ff.from(0.0, {1e-4, 0.0, 0.0, 0.0, 0.0, 0.0}).at(3.0 * sys.period());
  EXPECT_EQ(s[idx::w], 0.0);
  EXPECT_EQ(s[idx::vw], 0.0);
}

// Models with a nonlinear term out of contact have no closed-form free flight.
TEST(free_flight, nonlinear_free_flight_is_not_linearised) {
  unmodelled_effects hard;
  hard.cubic_stiffness = 1e9;
  const rotor_with_effects<identified> sys(far_stator(), effect_parameters{}, rpm_to_rad_s(1550.0), hard, contact_phase::free);
  EXPECT_FALSE(sys.free_dynamics().has_value());
}

TEST(free_flight, transition_matrix_matches_finite_differences) {
  const rotor_system<identified> sys(far_stator(), rpm_to_rad_s(1500.0), contact_phase::free);
  const free_flight<4> ff(*sys.free_dynamics());
  const state_type s0{1e-4, -2e-4, 0.03, 0.05};
  const double tau = 0.7 * sys.period();
  const Eigen::Matrix4d phi = ff.transition(tau);
  const std::array<double, 4> scale{1e-4, 1e-4, 1e-2, 1e-2};
  for (int j = 0; j < 4; ++j) {
    state_type up = s0, down = s0;
    const double h = 1e-4 * scale[static_cast<std::size_t>(j)];
    up[static_cast<std::size_t>(j)] += h;
    down[static_cast<std::size_t>(j)] -= h;
    const state_type a = ff.from(0.0, up).at(tau), b = ff.from(0.0, down).at(tau);
    for (int i = 0; i < 4; ++i) {
      // The flow is affine in s0, so central differences are exact up to rounding (1e-16 / 1e-8).
      const double fd = (a[static_cast<std::size_t>(i)] - b[static_cast<std::size_t>(i)]) / (2.0 * h);
      EXPECT_NEAR(phi(i, j), fd, 1e-7 * (1.0 + std::abs(phi(i, j)))) << i << "," << j;
    }
  }
}

// The steady free orbit y(t) = |P| cos(w t + arg P) (the particular solution) with the stator at
// |P| - depth: the first crossing is known in closed form, and must be found for every depth
// down to a few times the smallest the search guarantees; a stator |P| + depth away is never hit.
TEST(free_flight, finds_grazing_contacts_down_to_the_guaranteed_depth) {
  parameters p;
  const double omega = rpm_to_rad_s(1600.0);
  const double wn2 = p.k_y / p.m;
  const std::complex<double> P = std::complex<double>(0.0, -1.0) * p.e * omega * omega /
                                 std::complex<double>(wn2 - omega * omega, p.c_y * omega / p.m);
  const double amplitude = std::abs(P);
  integration_options opt;
  for (double depth_fraction : {1e-2, 1e-6, 1e-9, 1e-11}) {
    p.clearance = amplitude * (1.0 - depth_fraction);
    const rotor_system<identified> sys(p, omega, contact_phase::free);
    const free_flight<4> ff(*sys.free_dynamics());
    const double t0 = 0.123 * sys.period();
    const auto arc = ff.from(t0, ff.particular(t0));
    const double min_depth = opt.events.min_depth_fraction * p.clearance;
    const auto onset = arc.first_onset(t0, t0 + 2.0 * sys.period(), min_depth, opt.events.time_tolerance, sys.period() / 8.0);
    ASSERT_TRUE(onset.has_value()) << "depth " << depth_fraction;
    // cos(w t + arg P) = delta / |P|, first on the rising side after t0.
    const double theta = -std::acos(p.clearance / amplitude);
    double t_cross = (theta - std::arg(P)) / omega;
    while (t_cross < t0) t_cross += sys.period();
    EXPECT_NEAR(onset->first, t_cross, kOnsetTimeTol + 1e-3 * std::sqrt(depth_fraction) / omega) << "depth " << depth_fraction;
    EXPECT_LE(onset->second - onset->first, opt.events.time_tolerance * 1.01);

    p.clearance = amplitude * (1.0 + depth_fraction);
    const rotor_system<identified> clear(p, omega, contact_phase::free);
    const free_flight<4> ff2(*clear.free_dynamics());
    const auto none = ff2.from(t0, ff2.particular(t0)).first_onset(t0, t0 + 2.0 * sys.period(), min_depth,
                                                                  opt.events.time_tolerance, sys.period() / 8.0);
    EXPECT_FALSE(none.has_value()) << "depth " << depth_fraction;
  }
}

// From random states (transients with two modes and the forcing), the search finds a contact
// whenever a dense scan of the same arc finds one deeper than twice the guaranteed depth, and
// never reports one where the scan's local maximisation sees the orbit stay outside.
TEST(free_flight, never_misses_a_contact_a_dense_scan_sees) {
  std::mt19937_64 rng(20261124);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  integration_options opt;
  int found = 0;
  for (int trial = 0; trial < 200; ++trial) {
    parameters p;
    p.clearance = 3e-4 * (1.0 + 0.5 * u(rng));
    const rotor_system<identified> sys(p, rpm_to_rad_s(1500.0 + 300.0 * u(rng)), contact_phase::free);
    const free_flight<4> ff(*sys.free_dynamics());
    const state_type s0{2e-4 * u(rng), 2e-4 * u(rng), 0.05 * u(rng), 0.05 * u(rng)};
    const auto arc = ff.from(0.0, s0);
    if (arc.penetration(0.0).first >= 0.0) continue;
    const double t_end = 3.0 * sys.period();
    const double min_depth = opt.events.min_depth_fraction * p.clearance;
    const auto onset = arc.first_onset(0.0, t_end, min_depth, opt.events.time_tolerance, sys.period() / 8.0);
    // The scan: 20000 points, each local maximum of z refined by golden-section search.
    constexpr int kScan = 20000;
    double first_deep = -1.0;
    double prev = arc.penetration(0.0).first, cur = arc.penetration(t_end / kScan).first;
    for (int k = 1; k < kScan && first_deep < 0.0; ++k) {
      const double next = arc.penetration(t_end * (k + 1) / kScan).first;
      if (cur >= prev && cur >= next) {
        double a = t_end * (k - 1) / kScan, b = t_end * (k + 1) / kScan;
        for (int it = 0; it < 80; ++it) {
          const double m1 = b - 0.618 * (b - a), m2 = a + 0.618 * (b - a);
          if (arc.penetration(m1).first < arc.penetration(m2).first) a = m1;
          else b = m2;
        }
        if (arc.penetration(0.5 * (a + b)).first > 2.0 * min_depth) first_deep = 0.5 * (a + b);
      }
      if (cur > 2.0 * min_depth && first_deep < 0.0) first_deep = t_end * k / kScan;
      prev = cur;
      cur = next;
    }
    if (first_deep >= 0.0) {
      ASSERT_TRUE(onset.has_value()) << "trial " << trial << ": the scan finds z > 0 at t = " << first_deep;
      EXPECT_LE(onset->first, first_deep) << "trial " << trial;
      EXPECT_LE(arc.penetration(onset->first).first, 0.0);
      EXPECT_GT(arc.penetration(onset->second).first, 0.0) << std::setprecision(17) << onset->first << " " << onset->second << " " << arc.penetration(onset->first).first << " scan " << first_deep;
      ++found;
    } else if (onset) {
      // Any crossing reported must be real: z > 0 at the bracket's inner end.
      EXPECT_GT(arc.penetration(onset->second).first, 0.0) << "trial " << trial << " " << onset->first << " " << onset->second << " z(first)=" << arc.penetration(onset->first).first << " t_end " << t_end;
    }
  }
  EXPECT_GT(found, 20);  // the draw must exercise the search (a guard on the test itself)
}

}  // namespace
}  // namespace rubref
