// Symmetries of Eq. 1-2 that any correct integration must keep: the mirror image, the unbalance
// phase as a time shift, linearity in e and circular orbits of an isotropic rotor without
// contact, and event times that do not depend on the step size.

#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "props/generators.hpp"
#include "props/prop_support.hpp"

namespace rubref::props {
namespace {

using testing::trajectory;

// Two integrations at rtol 1e-12 of the same motion agree to ~1e-11 of the motion's scale over a
// few revolutions; contact episodes amplify a difference by at most a few per revolution.
// 1e-8 leaves that margin and is still 1e4 times below a 0.1 um probe reading of a 1 mm orbit.
constexpr double kSameMotionTol = 1e-8;   // of the largest |position| and |velocity| of the run
// Event times of the same motion: the ~1e-11 relative state differences above move a crossing
// at 0.01 m/s by ~1e-12 s; 1e-9 s is a millionth of a contact episode of the paper's k1.
constexpr double kEventTimeTol = 1e-9;    // s
// rk4 with 200 and 400 steps per contact episode (the shortest one dopri5 finds) and at least
// 2048 per revolution: its phase error, ~(w h)^4 / 120 per radian with w h ~ pi / 200, is ~1e-8
// of the elapsed time, ~3e-9 s over the first episode. Its events agree with the halved step's,
// and with dopri5's, to 1e-8 s there. Later events inherit any difference amplified by the
// dynamics: the identified law's way out, z'' ~ -(c2/m) z'^2, amplifies a perturbation of the
// exit speed by exp(2 (c2/m) integral |z'| dt), e^13 for c2 = 7e4 kg/m, m = 0.5 kg at 0.46 m/s;
// that is the law's conditioning, not a dependence on the step. (dopri5, error-controlled, is
// compared over every event.)
constexpr double kRk4EventTimeTol = 1e-8;  // s
// Linearity in e and circularity: one integration each at rtol 1e-12, compared sample by sample.
constexpr double kLinearTol = 1e-9;       // of the orbit's scale
constexpr int kRevolutions = 3;
constexpr int kSamplesPerRev = 64;

// Runs `model` from `s0` at `t0` over kRevolutions, sampled uniformly from t0.
template <class Law>
trajectory revolutions(const rotor_system<Law>& model, const state_type& s0, double t0, const integration_options& opt) {
  const double period = model.period();
  trajectory out;
  const sample_grid grid{t0, period / kSamplesPerRev, kRevolutions * kSamplesPerRev};
  out.end = integrate_hybrid(model, start_state(model, s0, t0), t0 + kRevolutions * period, opt, grid, out);
  return out;
}

// Largest difference between two sampled runs after mapping the first by `map`, relative to
// the larger position and velocity scales of the first.
template <class Map>
double largest_difference(const trajectory& a, const trajectory& b, Map&& map) {
  RC_ASSERT(a.s.size() == b.s.size());
  double pos = 0.0, vel = 0.0;
  for (const auto& s : a.s) {
    pos = std::max({pos, std::abs(s[idx::x]), std::abs(s[idx::y])});
    vel = std::max({vel, std::abs(s[idx::vx]), std::abs(s[idx::vy])});
  }
  double worst = 0.0;
  for (std::size_t i = 0; i < a.s.size(); ++i) {
    const state_type want = map(a.s[i]);
    for (int c = 0; c < 4; ++c) worst = std::max(worst, std::abs(want[c] - b.s[i][c]) / (c < 2 ? pos : vel));
  }
  return worst;
}

// A graze, a touch of the stator at (nearly) zero speed, is an event or not by rounding: a
// plastic impact (r = 0) leaves the rotor on an orbit that touches y = delta tangentially every
// period. So is the tail of a chatter sequence: its impacts slow by r each, and whether one more
// comes before sticking (rebound < 1e-6 m/s) is decided in the last digits. Events approached
// slower than 1e-4 m/s (a 0.1 um rise over a millisecond) are not compared; releases, approached
// at rest by definition and located by the sign of a force, always are.
constexpr double kGrazeSpeed = 1e-4;  // m/s

std::vector<contact_event> firm(const std::vector<contact_event>& events) {
  std::vector<contact_event> out;
  for (const auto& e : events)
    if (std::abs(e.approach_velocity) >= kGrazeSpeed || e.kind == event_kind::release) out.push_back(e);
  return out;
}

// The events up to the end of the first contact episode (separation, or the first impact).
std::vector<contact_event> first_episode(std::vector<contact_event> events) {
  const auto end = std::find_if(events.begin(), events.end(), [](const contact_event& e) {
    return e.kind == event_kind::separation || e.kind == event_kind::impact;
  });
  if (end != events.end()) events.erase(end + 1, events.end());
  return events;
}

void assert_same_events(const std::vector<contact_event>& a, const std::vector<contact_event>& b, double time_shift = 0.0,
                        double tol = kEventTimeTol) {
  const auto ea = firm(a), eb = firm(b);
  RC_ASSERT(ea.size() == eb.size());
  for (std::size_t i = 0; i < ea.size(); ++i) {
    RC_ASSERT(ea[i].kind == eb[i].kind);
    RC_ASSERT(std::abs(ea[i].t + time_shift - eb[i].t) <= tol);
  }
}

state_type mirrored(const state_type& s) { return {-s[idx::x], s[idx::y], -s[idx::vx], s[idx::vy]}; }

// x -> -x with the rotation reversed: the unbalance m e w^2 (cos(wt + phi), sin(wt + phi))
// becomes m e w^2 (-cos(wt + phi), sin(wt + phi)), the forcing of speed -w and angle pi - phi.
// So the mirror image of a solution solves the reversed rotor. Without contact, as the issue
// states it...
RC_GTEST_PROP(symmetry, mirror_image_with_reversed_rotation_without_contact, (const throw_case& c)) {
  parameters p = c.p;
  p.clearance = kNoContactClearance;
  parameters reversed = p;
  reversed.unbalance_phase = std::numbers::pi - p.unbalance_phase;
  const double omega = rpm_to_rad_s(c.rpm);
  for_each_variant_type(
      [&]<class Law>() {
        const trajectory a = revolutions(rotor_system<Law>(p, omega), c.start, 0.0, careful());
        const trajectory b = revolutions(rotor_system<Law>(reversed, -omega), mirrored(c.start), 0.0, careful());
        RC_ASSERT(a.events.empty());
        RC_ASSERT(largest_difference(a, b, mirrored) <= kSameMotionTol);
      });
}

// ... and with contact: the protrusion is on the mirror axis, and rubref turns the friction with
// the rotation (f_x = sgn(w) mu f_N, docs/model.md), so the symmetry holds for every variant.
RC_GTEST_PROP(symmetry, mirror_image_with_reversed_rotation_in_contact, (const throw_case& c)) {
  parameters reversed = c.p;
  reversed.unbalance_phase = std::numbers::pi - c.p.unbalance_phase;
  const double omega = rpm_to_rad_s(c.rpm);
  for_each_variant_type(
      [&]<class Law>() {
        const trajectory a = revolutions(rotor_system<Law>(c.p, omega), c.start, 0.0, careful());
        const trajectory b = revolutions(rotor_system<Law>(reversed, -omega), mirrored(c.start), 0.0, careful());
        RC_PRE(!a.events.empty());  // damping can stop a weak throw short of the stator
        assert_same_events(a.events, b.events);
        RC_ASSERT(largest_difference(a, b, mirrored) <= kSameMotionTol);
      });
}

// The unbalance angle is a time shift: the rotor with angle phi started at t = 0 moves exactly
// as the rotor with angle 0 started from the same state at t = phi / w, shifted by phi / w. With
// contact, every variant.
RC_GTEST_PROP(symmetry, unbalance_phase_shifts_the_orbit_in_time, (const throw_case& c)) {
  const double omega = rpm_to_rad_s(c.rpm), tau = c.p.unbalance_phase / omega;
  parameters at_zero = c.p;
  at_zero.unbalance_phase = 0.0;
  for_each_variant_type(
      [&]<class Law>() {
        const trajectory a = revolutions(rotor_system<Law>(c.p, omega), c.start, 0.0, careful());
        const trajectory b = revolutions(rotor_system<Law>(at_zero, omega), c.start, tau, careful());
        assert_same_events(a.events, b.events, tau);
        RC_ASSERT(largest_difference(a, b, [](const state_type& s) { return s; }) <= kSameMotionTol);
      });
}

// Without contact Eq. 1 is linear in the forcing: from rest, e times lambda gives the orbit
// times lambda.
RC_GTEST_PROP(symmetry, response_without_contact_is_linear_in_e, (parameters p)) {
  p.clearance = kNoContactClearance;
  p.e = *uniform(1e-6, 0.2e-3);
  const double lambda = *log_uniform(0.01, 100.0), omega = rpm_to_rad_s(*uniform(600.0, 3000.0));
  parameters scaled = p;
  scaled.e = lambda * p.e;
  const trajectory a = revolutions(rotor_system<identified>(p, omega), state_type{}, 0.0, careful());
  const trajectory b = revolutions(rotor_system<identified>(scaled, omega), state_type{}, 0.0, careful());
  const auto times_lambda = [lambda](const state_type& s) {
    return state_type{lambda * s[0], lambda * s[1], lambda * s[2], lambda * s[3]};
  };
  RC_ASSERT(largest_difference(a, b, times_lambda) <= kLinearTol);
}

// Isotropic (k_x = k_y, c_x = c_y), no contact: the steady orbit is a circle, x + j y =
// R e^{j(wt + ...)}, whatever the speed. Damping ratios of at least ~1 % let it settle in
// 30 decay times 2m/c (e^-30 ~ 1e-13 of the transient left).
RC_GTEST_PROP(symmetry, isotropic_rotor_without_contact_whirls_on_a_circle, (parameters p)) {
  p.clearance = kNoContactClearance;
  p.e = *uniform(1e-6, 0.2e-3);
  p.k_y = p.k_x;
  p.c_x = p.c_y = *uniform(0.02, 0.2) * std::sqrt(p.k_x * p.m);
  const double omega = rpm_to_rad_s(*uniform(600.0, 3000.0));
  const rotor_system<identified> model(p, omega);
  const double t_settle = 30.0 * 2.0 * p.m / p.c_x;
  trajectory tr;
  const sample_grid grid{t_settle, model.period() / kSamplesPerRev, kSamplesPerRev};
  integrate_hybrid(model, start_state(model, state_type{}, 0.0), t_settle + model.period(), careful(), grid, tr);
  RC_ASSERT(tr.s.size() == static_cast<std::size_t>(kSamplesPerRev));
  double lo = 1e300, hi = 0.0;
  for (const auto& s : tr.s) {
    const double radius = std::hypot(s[idx::x], s[idx::y]);
    lo = std::min(lo, radius);
    hi = std::max(hi, radius);
  }
  RC_ASSERT(hi - lo <= kLinearTol * hi);
}

// A change of step size within the integrator's tolerance moves no event by more than that
// tolerance: dopri5 at its default rtol with its largest step period/16 and period/128, and rk4
// with 200 and 400 steps per contact episode (a fixed step must resolve the contact).
RC_GTEST_PROP(symmetry, event_times_do_not_depend_on_the_step_size, (const throw_case& c)) {
  const double omega = rpm_to_rad_s(c.rpm), period = 2.0 * std::numbers::pi / omega;
  const auto with = [](stepper_kind kind, double dt, double max_dt) {
    integration_options opt;
    opt.stepper.kind = kind;
    opt.stepper.dt = dt;
    opt.stepper.max_dt = max_dt;
    return opt;
  };
  for_each_variant_type(
      [&]<class Law>() {
        const rotor_system<Law> model(c.p, omega);
        const trajectory coarse = revolutions(model, c.start, 0.0, with(stepper_kind::dopri5, 0.0, period / 16));
        const trajectory fine = revolutions(model, c.start, 0.0, with(stepper_kind::dopri5, 0.0, period / 128));
        RC_PRE(!coarse.events.empty());  // damping can stop a weak throw short of the stator
        assert_same_events(coarse.events, fine.events);
        double dt = period / 2048;
        for (std::size_t i = 1; i < fine.events.size(); ++i)
          if (fine.events[i].kind == event_kind::separation) dt = std::min(dt, (fine.events[i].t - fine.events[i - 1].t) / 200);
        const trajectory rk4 = revolutions(model, c.start, 0.0, with(stepper_kind::rk4, dt, 0.0));
        const trajectory rk4_half = revolutions(model, c.start, 0.0, with(stepper_kind::rk4, dt / 2, 0.0));
        assert_same_events(first_episode(rk4.events), first_episode(rk4_half.events), 0.0, kRk4EventTimeTol);
        assert_same_events(first_episode(fine.events), first_episode(rk4_half.events), 0.0, kRk4EventTimeTol);
      });
}

}  // namespace
}  // namespace rubref::props
