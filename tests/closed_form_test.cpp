// Without contact Eq. 1 is linear with harmonic forcing; its steady state is closed form
// (ref/model/closed_form.hpp). Every variant must reproduce it when the clearance is never reached.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "ref/model/closed_form.hpp"
#include "test_support.hpp"

namespace rubref::testing {
namespace {

// The bar for the reference stepper; rkf78 at rtol 1e-13 reaches about 1e-12.
constexpr double kReferenceRelTol = 1e-9;
// What each stepper owes at its documented default accuracy (rtol 1e-10, rk4 at period/1024):
// 1e-7 of the amplitude is ten times below the 1 um resolution of a proximity probe per 1 mm.
constexpr double kDefaultRelTol = 1e-7;
// A clearance of 1 m is never reached by the ~1 mm unbalance orbit: contact-free.
constexpr double kNoContactClearance = 1.0;

struct orbit_error {
  double rel = 0.0;
  double t = 0.0;
  state_type got{}, want{};
};

// Largest position error over the samples, relative to the larger orbit semi-axis.
orbit_error compare_to_closed_form(const trajectory& tr, const unbalance_response& exact) {
  const double scale = std::max(std::abs(exact.x_phasor), std::abs(exact.y_phasor));
  orbit_error worst;
  for (std::size_t i = 0; i < tr.t.size(); ++i) {
    const state_type want = exact.at(tr.t[i]);
    const double err = std::max(std::abs(tr.s[i][0] - want[0]), std::abs(tr.s[i][1] - want[1])) / scale;
    if (err > worst.rel) worst = {err, tr.t[i], tr.s[i], want};
  }
  return worst;
}

::testing::AssertionResult within(const orbit_error& e, double tol) {
  if (e.rel <= tol) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "worst relative error " << e.rel << " > " << tol << " at t = " << e.t
                                       << " s: got (x, y) = (" << e.got[0] << ", " << e.got[1] << "), closed form ("
                                       << e.want[0] << ", " << e.want[1] << ")";
}

template <class V>
class contact_free : public ::testing::Test {
  static_assert(odeint_system<rotor_system<V>>, "every variant's model is an odeint System");
};
TYPED_TEST_SUITE(contact_free, all_variant_types, variant_name);

TYPED_TEST(contact_free, reference_stepper_follows_closed_form) {
  parameters p;
  p.clearance = kNoContactClearance;
  // Below, between and above the two natural frequencies (1520 and 1569 rpm), where the orbit
  // turns from a horizontal to a vertical ellipse to a circle (Fig. 3).
  for (const double rpm : {1200.0, 1540.0, 1600.0, 2400.0}) {
    SCOPED_TRACE(::testing::Message() << "rpm " << rpm);
    p.unbalance_phase = rpm / 1000.0;  // rad: a different unbalance angle at every speed
    const double omega = rpm_to_rad_s(rpm);
    const double period = 2.0 * std::numbers::pi / omega;
    const unbalance_response exact(p, omega);
    const rotor_system<TypeParam> model(p, omega);
    const auto tr = run(model, exact.at(0.0), 10 * period, reference_options(), {0.0, period / 64, 640});
    ASSERT_EQ(tr.t.size(), 640u);
    EXPECT_TRUE(tr.events.empty());
    EXPECT_TRUE(within(compare_to_closed_form(tr, exact), kReferenceRelTol));
  }
}

TEST(contact_free, every_stepper_at_default_accuracy) {
  parameters p;
  p.clearance = kNoContactClearance;
  const double omega = rpm_to_rad_s(1600.0);
  const double period = 2.0 * std::numbers::pi / omega;
  const unbalance_response exact(p, omega);
  const rotor_system<identified> model(p, omega);
  for (const auto& [kind, name] : stepper_names) {
    SCOPED_TRACE(name);
    const auto tr = run(model, exact.at(0.0), 20 * period, options_for(kind), {0.0, period / 64, 1280});
    EXPECT_TRUE(within(compare_to_closed_form(tr, exact), kDefaultRelTol));
  }
}

// From rest the transient decays with time constant 2m/c (about 0.2 s) onto the closed form.
TEST(contact_free, transient_from_rest_decays_onto_closed_form) {
  parameters p;
  p.clearance = kNoContactClearance;
  const double omega = rpm_to_rad_s(1500.0);
  const double period = 2.0 * std::numbers::pi / omega;
  const unbalance_response exact(p, omega);
  const rotor_system<piecewise_linear> model(p, omega);
  const double decay_time = 2.0 * p.m / std::min(p.c_x, p.c_y);
  const double t_end = 40.0 * decay_time;  // e^-40 ~ 4e-18 of the initial offset remains
  const auto tr = run(model, state_type{}, t_end, reference_options(), {t_end - period, period / 32, 32});
  EXPECT_TRUE(within(compare_to_closed_form(tr, exact), kReferenceRelTol));
}

// The ellipse of the contact-free orbit (Eq. 7's components) against the orbit itself, sampled
// finely over one revolution at speeds below, between and above the two resonances: the extreme
// radii are the semi-axes, the farthest sample lies along the tilt, and the sense is the sign of
// the angular momentum x vy - y vx. 1e-4 relative is the sampling's own error (4096 samples:
// 1 - cos(pi / 4096) ~ 3e-7 on a radius, 8e-4 rad on an angle, so 2e-3 rad on the tilt).
TEST(whirl_ellipse, matches_the_sampled_orbit) {
  constexpr int kSamples = 4096;
  constexpr double kRadiusRelTol = 1e-4, kTiltTol = 2e-3;
  const parameters p;
  for (const double rpm : {900.0, 1450.0, 1500.0, 1540.0, 1560.0, 1600.0, 2400.0}) {
    const unbalance_response r(p, rpm * 2.0 * std::numbers::pi / 60.0);
    const whirl_ellipse e = ellipse_of(r);
    double r_max = 0.0, r_min = 1e9, tilt = 0.0, momentum = 0.0;
    for (int i = 0; i < kSamples; ++i) {
      const state_type s = r.at(i * (2.0 * std::numbers::pi / r.omega) / kSamples);
      const double rad = std::hypot(s[0], s[1]);
      if (rad > r_max) {
        r_max = rad;
        tilt = std::fmod(std::atan2(s[1], s[0]) + 2.0 * std::numbers::pi, std::numbers::pi);
      }
      r_min = std::min(r_min, rad);
      momentum += s[0] * s[3] - s[1] * s[2];
    }
    EXPECT_NEAR(e.semi_major, r_max, kRadiusRelTol * r_max) << rpm;
    EXPECT_NEAR(e.semi_minor, r_min, kRadiusRelTol * r_max) << rpm;
    const double d = std::abs(e.tilt - tilt);
    EXPECT_LT(std::min(d, std::numbers::pi - d), kTiltTol) << rpm;
    EXPECT_EQ(e.forward, momentum > 0.0) << rpm;
  }
}

// The forcing's (cos, sin) without libm (ref/model/state.hpp): within a few ulp of std::cos/std::sin
// over every angle a run meets (w t + phi to ~1e5 rad) and at the reduction's seams. 4e-16 is
// four ulp of 1: the node table and the final turn each round once, the polynomials twice.
TEST(forcing_phasor, phasor_of_matches_libm) {
  constexpr double kTol = 4e-16;
  std::vector<double> angles;
  for (int k = -300; k <= 300; ++k) {
    const double node = k * std::numbers::pi / 64;  // seams of the reduction at odd k
    for (const double d : {-1e-12, 0.0, 1e-12}) angles.push_back(node + d);
  }
  for (int i = 0; i < 20000; ++i) angles.push_back(-1e5 + 2e5 * ((i * 0.6180339887498949) - std::floor(i * 0.6180339887498949)));
  for (const double a : {7.99e5, -7.99e5, 8e5, 3e7, -1e12}) angles.push_back(a);  // each side of the libm fallback
  for (const double a : angles) {
    const forcing_phasor p = phasor_of(a);
    ASSERT_NEAR(p.cos, std::cos(a), kTol) << "a = " << a;
    ASSERT_NEAR(p.sin, std::sin(a), kTol) << "a = " << a;
  }
}

}  // namespace
}  // namespace rubref::testing
