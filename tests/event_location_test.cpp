// Event location on every variant and stepper at the paper's operating point (1600 rpm, 0.3 mm,
// where the rotor rubs once per revolution): where each event is placed, what it reports, and
// that the answer does not depend on how large a step the integrator may take.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "test_support.hpp"

namespace rubref::testing {
namespace {

// The bound on the located instant, as a position: |y - delta| <= 1e-12 m. With a
// 1e-13 s bracket and |y_dot| < 0.2 m/s the located states sit within ~2e-14 m.
constexpr double kEventPositionTol = 1e-12;  // m
// Halving the largest step changes an adaptive solution by ~rtol times its amplification over
// 30 revolutions; at rtol 1e-12 event times move by less than 1e-9 s and orbits by 1e-9 of delta.
constexpr double kStepHalvingTimeTol = 1e-9;  // s
constexpr double kStepHalvingRelTol = 1e-9;   // of the clearance

constexpr double kRpm = 1600.0;
constexpr double kRevs = 30.0;

template <class V>
class event_location : public ::testing::Test {
 protected:
  parameters p;
  double omega = rpm_to_rad_s(kRpm);
  double period = 2.0 * std::numbers::pi / omega;
  rotor_system<V> model{p, omega};
};
TYPED_TEST_SUITE(event_location, all_variant_types, variant_name);

TYPED_TEST(event_location, events_sit_on_the_stator_surface_for_every_stepper) {
  for (const auto& [kind, name] : stepper_names) {
    SCOPED_TRACE(name);
    const auto tr = run(this->model, state_type{}, kRevs * this->period, options_for(kind));
    ASSERT_GE(tr.events.size(), 10u) << "the operating point rubs in most revolutions";
    for (const auto& ev : tr.events) {
      SCOPED_TRACE(::testing::Message() << to_string(ev.kind) << " at t = " << ev.t);
      EXPECT_LE(std::abs(ev.state[idx::y] - this->p.clearance), kEventPositionTol);
      switch (ev.kind) {
        case event_kind::contact_onset:
        case event_kind::impact:
          EXPECT_GT(ev.approach_velocity, 0.0);  // moving into the stator
          break;
        case event_kind::separation:
          EXPECT_LT(ev.approach_velocity, 0.0);  // moving away from it
          EXPECT_GT(ev.max_penetration, 0.0);
          break;
        default:
          break;
      }
      if (ev.kind == event_kind::impact) {
        EXPECT_EQ(ev.state[idx::vy], -this->p.r * ev.approach_velocity);
      }
    }
  }
}

// Compliant phases alternate strictly: onset, separation, onset, ...
TYPED_TEST(event_location, compliant_phases_alternate) {
  if constexpr (compliant_law<TypeParam>) {
    const auto tr = run(this->model, state_type{}, kRevs * this->period, options_for(stepper_kind::dopri5));
    for (std::size_t i = 0; i < tr.events.size(); ++i)
      EXPECT_EQ(tr.events[i].kind, i % 2 == 0 ? event_kind::contact_onset : event_kind::separation) << "event " << i;
  }
}

TYPED_TEST(event_location, halving_the_largest_step_changes_nothing_beyond_tolerance) {
  const auto with_max_dt = [&](double max_dt) {
    auto opt = options_for(stepper_kind::dopri5, 1e-12, 1e-17);
    opt.stepper.max_dt = max_dt;
    return run(this->model, state_type{}, kRevs * this->period, opt,
               {(kRevs - 1) * this->period, this->period / 64, 64});
  };
  const auto coarse = with_max_dt(this->period / 16);
  const auto fine = with_max_dt(this->period / 32);
  ASSERT_EQ(coarse.events.size(), fine.events.size());
  for (std::size_t i = 0; i < coarse.events.size(); ++i) {
    EXPECT_EQ(coarse.events[i].kind, fine.events[i].kind);
    EXPECT_NEAR(coarse.events[i].t, fine.events[i].t, kStepHalvingTimeTol) << "event " << i;
  }
  for (std::size_t i = 0; i < coarse.t.size(); ++i)
    for (int c = 0; c < 2; ++c)
      EXPECT_NEAR(coarse.s[i][c], fine.s[i][c], kStepHalvingRelTol * this->p.clearance) << "sample " << i;
}

// A grazing contact (y peaks just above delta between two step ends) is found from the interior
// minimum of the exit function, not lost: a large max step must see the same events as a small one.
TEST(event_location, grazing_contact_inside_one_step_is_found) {
  parameters p;
  p.e = 0.0;
  p.c_y = 0.0;
  const double wy = std::sqrt(p.k_y / p.m);
  const double peak = p.clearance + 1e-9;  // 1 nm above the stator surface
  const rotor_system<piecewise_linear> model(p, rpm_to_rad_s(kRpm));
  const state_type start{0.0, 0.0, 0.0, peak * wy};  // y = (peak) sin(wy t): tops out at delta + 1 nm
  auto opt = options_for(stepper_kind::dopri5);
  opt.stepper.max_dt = 0.5 * std::numbers::pi / wy;  // a quarter of the y period per step
  const auto tr = run(model, start, std::numbers::pi / wy, opt);
  ASSERT_EQ(tr.events.size(), 2u);
  EXPECT_EQ(tr.events[0].kind, event_kind::contact_onset);
  EXPECT_EQ(tr.events[1].kind, event_kind::separation);
  EXPECT_NEAR(tr.events[1].max_penetration, 1e-9, 1e-12);  // the k1 spring barely changes a 1 nm graze
}

}  // namespace
}  // namespace rubref::testing
