// The chatter rule of the restitution variant (docs/model.md, "Chatter"). When the unbalance
// presses the rotor against the stator, rebounds shrink geometrically (v -> r v per impact for
// short flights) and the impact times accumulate. Below `stick_velocity` the rotor sticks at
// y = delta until the free vertical acceleration turns negative, then it is released.
// Setting: 300 rpm, 10 um clearance, 1 mm eccentricity: m e w^2 = 1.5 N against k_y delta = 0.41 N.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "test_support.hpp"

namespace rubref::testing {
namespace {

// For flights short against the forcing period, successive approach speeds fall by r; the
// slowly varying push changes the ratio by well under 1 %.
constexpr double kRatioTol = 0.01;
// The release instant is a root of a function of time alone, bracketed to 1e-13 s.
constexpr double kReleaseTimeTol = 1e-11;  // s
constexpr int kMinRebounds = 10;  // the geometric check needs a run of rebounds to mean something

struct pressed_rotor {
  parameters p = [] {
    parameters q;
    q.delta = 1e-5;
    q.e = 1e-3;
    return q;
  }();
  double omega = rpm_to_rad_s(300.0);
  double period = 2.0 * std::numbers::pi / omega;
  rotor_system<restitution> model{p, omega};

  // Release: m e w^2 sin(wt) = k_y delta on the falling side of the sine (y' = 0, y = delta).
  double release_time(double after) const {
    const double phase = std::numbers::pi - std::asin(p.k_y * p.delta / (p.m * p.e * omega * omega));
    double t = phase / omega;
    while (t < after) t += period;
    return t;
  }
};

TEST(chatter, impacts_shrink_by_r_then_stick_then_release_on_time) {
  const pressed_rotor c;
  const auto opt = options_for(stepper_kind::dopri5);
  const auto tr = run(c.model, state_type{}, 3 * c.period, opt, {0.0, c.period / 4096, 3 * 4096});

  int sticks = 0;
  std::vector<double> approach;
  for (std::size_t i = 0; i < tr.events.size(); ++i) {
    const auto& ev = tr.events[i];
    if (ev.kind == event_kind::impact) {
      approach.push_back(ev.approach_velocity);
    } else if (ev.kind == event_kind::stick) {
      ++sticks;
      SCOPED_TRACE(::testing::Message() << "stick at t = " << ev.t);
      EXPECT_LT(std::abs(c.p.r * ev.approach_velocity), opt.events.stick_velocity);
      ASSERT_GE(approach.size(), static_cast<std::size_t>(kMinRebounds));
      // The last rebounds before sticking form a geometric sequence of ratio r.
      for (std::size_t k = approach.size() - kMinRebounds + 1; k < approach.size(); ++k)
        EXPECT_NEAR(approach[k] / approach[k - 1], c.p.r, kRatioTol) << "rebound " << k;
      approach.clear();
      ASSERT_LT(i + 1, tr.events.size());
      const auto& rel = tr.events[i + 1];
      EXPECT_EQ(rel.kind, event_kind::release);
      EXPECT_NEAR(rel.t, c.release_time(ev.t), kReleaseTimeTol);
    }
  }
  EXPECT_GE(sticks, 2);

  // While stuck the rotor sits exactly on the stator, at rest vertically, carrying a positive force.
  int stuck_samples = 0;
  for (std::size_t i = 0; i < tr.t.size(); ++i) {
    if (tr.phase[i] != contact_phase::stuck) continue;
    ++stuck_samples;
    EXPECT_EQ(tr.s[i][idx::y], c.p.delta);
    EXPECT_EQ(tr.s[i][idx::vy], 0.0);
    EXPECT_GT(c.model.with_phase(contact_phase::stuck).normal_force(tr.s[i], tr.t[i]), 0.0);
  }
  EXPECT_GT(stuck_samples, 0);
}

// r = 0 is a plastic impact: the first contact while pressed sticks at once.
TEST(chatter, plastic_impact_sticks_at_once) {
  pressed_rotor c;
  c.p.r = 0.0;
  const rotor_system<restitution> model(c.p, c.omega);
  const auto tr = run(model, state_type{}, c.period, options_for(stepper_kind::dopri5));
  ASSERT_FALSE(tr.events.empty());
  EXPECT_EQ(tr.events.front().kind, event_kind::stick);
}

// Without the rule (stick_velocity = 0) the accumulation never ends: an error, never a hang or
// a silently wrong orbit.
TEST(chatter, without_the_rule_the_accumulation_is_reported) {
  const pressed_rotor c;
  auto opt = options_for(stepper_kind::dopri5);
  opt.events.stick_velocity = 0.0;
  EXPECT_THROW(run(c.model, state_type{}, c.period, opt), numerical_error);
}

}  // namespace
}  // namespace rubref::testing
