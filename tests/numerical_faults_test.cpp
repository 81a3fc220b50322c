// A numerical failure is an error with the time and state, never a silently wrong orbit.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <functional>
#include <numbers>
#include <string>

#include "ref/integrate/shooting.hpp"
#include "ref/rig/rig.hpp"
#include "ref/run/simulate.hpp"
#include "test_support.hpp"

namespace rubref::testing {
namespace {

// rk4 is stable for omega_c dt < 2.8; a contact stiffness of 1e12 N/m (omega_c ~ 8e5 rad/s) with
// 64 steps per revolution (dt ~ 6e-4 s) is far outside: the first contact step goes wild. The
// integrator sees a contact begin and end within one fixed step and refuses to go on (before
// this check, the state went on to blow up: "non-finite state").
TEST(numerical_faults, unresolved_stiff_contact_with_fixed_step_is_an_error) {
  parameters p;
  p.k1 = 1e12;
  const double omega = rpm_to_rad_s(1600.0);
  const rotor_system<piecewise_linear> model(p, omega);
  integration_options opt;
  opt.stepper.kind = stepper_kind::rk4;
  opt.stepper.dt = 2.0 * std::numbers::pi / omega / 64;
  try {
    run(model, state_type{}, 50 * 2.0 * std::numbers::pi / omega, opt);
    FAIL() << "an unstable integration returned an orbit";
  } catch (const numerical_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("does not resolve a contact episode"), std::string::npos) << msg;
    EXPECT_NE(msg.find("t = "), std::string::npos) << msg;
  }
}

// A numerical_error's message carries the time and the state where it happened.
void expect_error_with_state(const std::function<void()>& run_it, const std::string& what) {
  try {
    run_it();
    FAIL() << "returned an orbit; expected: " << what;
  } catch (const numerical_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(what), std::string::npos) << msg;
    EXPECT_NE(msg.find("t = "), std::string::npos) << msg;
    EXPECT_NE(msg.find("state (x, y, vx, vy) = ("), std::string::npos) << msg;
  }
}

// Negative damping (never accepted by validate: the test builds the model directly) makes the
// free orbit grow as exp(|c| t / 2m) = exp(3e4 t): within a fraction of a second it overflows.
// The adaptive stepper first retries smaller steps, then stops with the time and state.
TEST(numerical_faults, a_runaway_state_is_an_error_not_an_orbit) {
  parameters p;
  p.c_x = p.c_y = -1e5;
  p.clearance = 1e6;  // no contact: the runaway alone
  const rotor_system<identified> model(p, rpm_to_rad_s(1600.0));
  integration_options opt;
  opt.stepper.kind = stepper_kind::dopri5;
  opt.stepper.max_dt = 1e-3;
  try {
    run(model, state_type{1e-6, 0.0, 0.0, 0.0}, 10.0, opt);
    FAIL() << "a diverging integration returned an orbit";
  } catch (const numerical_error& e) {
    const std::string msg = e.what();
    // Which guard fires first depends on the stepper: a non-finite state, odeint's give-up or a
    // step size underflow; each names the time and state.
    EXPECT_NE(msg.find("t = "), std::string::npos) << msg;
  }
}

// The runaway guard (integration_options::runaway_displacement) sits inside the hybrid
// integrator, so every path refuses a diverged run with where it happened: exact free flight,
// an integrated one, shooting's flow with its monodromy, and the rig. The guard is lowered to
// 50 um so that the paper's rotor run up from rest at 1600 rpm (amplitude ~0.3 mm) crosses it.
TEST(numerical_faults, a_runaway_is_refused_inside_the_integrator_on_every_path) {
  constexpr double kLoweredGuard = 5e-5;  // m, below the orbit's amplitude, above its first step
  parameters p;
  p.clearance = 1.0;  // no contact: the free orbit alone crosses the guard
  const rotor_system<identified> model(p, rpm_to_rad_s(1600.0));
  const auto expect_runaway = [](const std::function<void()>& f, const char* path) {
    SCOPED_TRACE(path);
    try {
      f();
      ADD_FAILURE() << "a run beyond the guard returned";
    } catch (const numerical_error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("runaway state at t = "), std::string::npos) << msg;
      EXPECT_NE(msg.find("beyond 5e-05 m"), std::string::npos) << msg;
    }
  };
  integration_options opt = reference_options();
  opt.runaway_displacement = kLoweredGuard;
  expect_runaway([&] { run(model, state_type{}, 2.0, opt); }, "exact free flight");
  integration_options stepped = opt;
  stepped.exact_free_flight = false;
  expect_runaway([&] { run(model, state_type{}, 2.0, stepped); }, "integrated free flight");
  expect_runaway([&] { flow_and_monodromy(model, state_type{}, 0.0, 2.0, opt); }, "shooting's flow and monodromy");
  rig_request rig;
  rig.integration.runaway_displacement = kLoweredGuard;
  expect_runaway([&] { run_rig(rig); }, "rig");
  // At its default (1 m) the same runs pass.
  EXPECT_NO_THROW(run(model, state_type{}, 2.0, reference_options()));
}

// A step budget stops a run that would take too long (the loop's trial laws), naming where.
TEST(numerical_faults, the_step_budget_is_an_error_with_the_state) {
  const parameters p;
  const rotor_system<identified> model(p, rpm_to_rad_s(1600.0));
  integration_options opt = reference_options();
  opt.max_steps = 100;
  expect_error_with_state([&] { run(model, state_type{}, 1.0, opt); }, "more than 100 steps");
}

// The fixed step's contact resolution (rotor_system::contact_rate, kCoarseContactStep): the
// paper's identified law at 1600 rpm, 0.3 mm, reaches a contact rate of ~2.9e3 1/s (k1 alone
// gives sqrt(k1/m) = 1.6e3; c2 z_dot^2 adds 2 c2 z_dot / m at impact). rk4's default T/1024
// crosses it at rate * dt = 0.107 (measured): nothing counted. T/48 (7.8e-4 s) crosses it at
// ~2: such steps are counted and the warning names the first time.
TEST(numerical_faults, a_coarse_fixed_step_through_contact_is_counted_and_warned) {
  const parameters p;
  const double omega = rpm_to_rad_s(1600.0), period = 2.0 * std::numbers::pi / omega;
  const rotor_system<identified> model(p, omega);
  const auto counts_with = [&](int steps_per_rev) {
    integration_options opt;
    opt.stepper.kind = stepper_kind::rk4;
    opt.stepper.dt = period / steps_per_rev;
    integration_counts c;
    null_observer obs;
    integrate_hybrid(model, start_state(model, state_type{}, 0.0), 60 * period, opt, sample_grid{}, obs, &c);
    return c;
  };
  const integration_counts fine = counts_with(1024);
  EXPECT_GT(fine.events, 10u) << "the case must have contacts";
  EXPECT_EQ(fine.coarse_contact_steps, 0u);
  EXPECT_GT(fine.max_contact_rate_dt, 0.05);  // measured 0.107: the rate is measured at all
  EXPECT_LT(fine.max_contact_rate_dt, 0.25);  // and the default step is well inside the limit
  EXPECT_EQ(coarse_contact_warning(fine), "");

  const integration_counts coarse = counts_with(48);
  EXPECT_GT(coarse.coarse_contact_steps, 0u);
  EXPECT_GT(coarse.max_contact_rate_dt, kCoarseContactStep);
  const std::string w = coarse_contact_warning(coarse);
  std::printf("MEASURED T/1024: max rate*dt %.3g; T/48: %zu coarse steps, max rate*dt %.3g\n", fine.max_contact_rate_dt,
              coarse.coarse_contact_steps, coarse.max_contact_rate_dt);
  EXPECT_NE(w.find("under-resolved"), std::string::npos) << w;
  EXPECT_NE(w.find("first at t = "), std::string::npos) << w;
}

}  // namespace
}  // namespace rubref::testing
