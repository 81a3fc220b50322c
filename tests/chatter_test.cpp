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

// A chatter hop can be far shorter than a step. Found by props/symmetry_props.cpp: after the
// impact at t = 0.0493 s the next hop (1.3e-5 m/s rebound, ~5e-5 s) lay wholly inside one rkf78
// step of 5.8e-4 s that ended 2.7e-8 m inside the stator, and the impact was missed. Every hop
// must end in an impact: the rotor never goes into the stator by more than the location accuracy.
TEST(chatter, a_hop_inside_one_step_is_not_missed) {
  parameters p;
  p.m = 1.7168943521755864;
  p.e = 9.246691616554018e-05;
  p.unbalance_phase = 1.8461044375856286;
  p.c_x = 24.940784751470346;
  p.c_y = 35.625636329905319;
  p.k_x = 65502.783822892925;
  p.k_y = 22214.369593455158;
  p.delta = 0.00012973126644110381;
  p.r = 0.41836382726796728;
  const rotor_system<restitution> model(p, rpm_to_rad_s(2620.9151998285961));
  const state_type start{6.6724544691246676e-05, 4.032193187005027e-05, 0.059565672001372166, 0.026612319021257602};
  auto opt = options_for(stepper_kind::rkf78, 1e-12, 1e-17);
  const double period = model.period();
  const auto tr = run(model, start, 3 * period, opt, {0.0, period / 4096, 3 * 4096});
  constexpr double kLocationTol = 1e-12;  // m, the documented |y - delta| at a located event
  double deepest = 0.0, when = 0.0;
  for (std::size_t i = 0; i < tr.t.size(); ++i)
    if (tr.s[i][idx::y] - p.delta > deepest) {
      deepest = tr.s[i][idx::y] - p.delta;
      when = tr.t[i];
    }
  EXPECT_LE(deepest, kLocationTol) << "inside the stator by " << deepest << " m at t = " << when << " s";
  EXPECT_GE(tr.events.size(), 9u);  // the hop at t = 0.04936 s is an impact
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
