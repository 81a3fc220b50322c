// A numerical failure is an error with the time and state, never a silently wrong orbit.

#include <gtest/gtest.h>

#include <numbers>
#include <string>

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

}  // namespace
}  // namespace rubref::testing
