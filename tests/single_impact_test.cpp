// One impact of a rotor thrown straight up into the stator, without unbalance (e = 0), checked
// against an answer computed without the hybrid integrator:
//  - restitution, piecewise-linear: every phase is a linear oscillator, so closed form; event
//    times are roots of the closed forms found by bisection.
//  - piecewise-nonlinear, identified (with c_y = 0): the vertical motion in contact conserves
//    w(z) = z_dot^2 along dw/dz = -(2/m)(K(z) + c2 w), the same ODE on the way in and out, so
//    the peak penetration is the root of w, the exit speed equals the entry speed, and the
//    contact lasts 2 * integral_0^zmax dz / sqrt(w(z)) (Gauss-Kronrod quadrature).
// Each variant has a known answer below; a new variant without one does not compile.

#include <gtest/gtest.h>

#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <functional>
#include <numbers>

#include "test_support.hpp"

namespace rubref::testing {
namespace {

// Event times agree with the independent answer to 1e-12 s, the location bound; the
// reference trajectory itself is accurate to ~1e-13 relative, i.e. ~1e-16 s at these speeds.
constexpr double kEventTimeTol = 1e-12;      // s
// Velocities and penetrations: 1e-9 relative, limited by the quadratures (~1e-11) and the
// cancellation in w(z) near the peak, not by the integration.
constexpr double kRelTol = 1e-9;
constexpr double kThrowSpeed = 0.1;          // m/s, vertical speed at y = 0: reaches ~0.6 mm > delta

// m y'' + c y' + k y = F (underdamped), from (y0, v0) at t0: closed form.
struct linear_oscillator {
  double m, c, k, F, t0, y0, v0;

  double y(double t) const { return eval(t).first; }
  double v(double t) const { return eval(t).second; }
  std::pair<double, double> eval(double t) const {
    const double tau = t - t0, w0 = std::sqrt(k / m), a = c / (2.0 * m);
    const double wd = std::sqrt(w0 * w0 - a * a), yeq = F / k;
    const double A = y0 - yeq, B = (v0 + a * A) / wd, decay = std::exp(-a * tau);
    const double cs = std::cos(wd * tau), sn = std::sin(wd * tau);
    return {yeq + decay * (A * cs + B * sn), decay * ((wd * B - a * A) * cs - (a * B + wd * A) * sn)};
  }
  double period() const { return 2.0 * std::numbers::pi / std::sqrt(k / m); }
};

// First t in (a, b] where f crosses zero from the sign it has at a; plain scan + bisection.
double first_crossing(const std::function<double(double)>& f, double a, double b, int n = 4000) {
  double lo = a;
  const bool negative_at_a = f(a + 1e-15) < 0;
  for (int i = 1; i <= n; ++i) {
    double hi = a + (b - a) * i / n;
    if ((f(hi) < 0) != negative_at_a) {
      for (int it = 0; it < 200; ++it) {
        const double mid = 0.5 * (lo + hi);
        if (mid == lo || mid == hi) break;
        ((f(mid) < 0) == negative_at_a ? lo : hi) = mid;
      }
      return 0.5 * (lo + hi);
    }
    lo = hi;
  }
  ADD_FAILURE() << "no crossing in [" << a << ", " << b << "]";
  return b;
}

struct impact_answer {
  double t_in;          // s, contact onset / impact time
  double t_out;         // s, separation time (== t_in for an impact map)
  double v_in, v_out;   // m/s, vertical velocity entering / leaving
  double z_max;         // m, peak penetration
  double t_end;         // s, when the final state is compared
  state_type end;       // state at t_end
  bool has_end = true;  // whether `end` is part of the answer
};

template <class Law>
struct single_impact;  // parameters and independent answer, per variant

parameters thrown_rotor() {
  parameters p;
  p.e = 0.0;  // no unbalance: the rotor is only thrown up
  return p;
}

template <>
struct single_impact<restitution> {
  static parameters params() { return thrown_rotor(); }
  static state_type start() { return {0.0, 0.0, 0.02, kThrowSpeed}; }
  static impact_answer answer(const parameters& p) {
    const linear_oscillator fy{p.m, p.c_y, p.k_y, 0.0, 0.0, 0.0, kThrowSpeed};
    const linear_oscillator fx{p.m, p.c_x, p.k_x, 0.0, 0.0, 0.0, 0.02};  // no tangential force
    impact_answer a{};
    a.t_in = a.t_out = first_crossing([&](double t) { return fy.y(t) - p.clearance; }, 0.0, fy.period() / 2);
    a.v_in = fy.v(a.t_in);
    a.v_out = -p.r * a.v_in;  // Eq. 6
    const linear_oscillator after{p.m, p.c_y, p.k_y, 0.0, a.t_in, p.clearance, a.v_out};
    a.t_end = a.t_in + after.period() / 4;
    a.end = {fx.y(a.t_end), after.y(a.t_end), fx.v(a.t_end), after.v(a.t_end)};
    return a;
  }
};

template <>
struct single_impact<piecewise_linear> {
  static parameters params() { return thrown_rotor(); }
  static state_type start() { return {0.0, 0.0, 0.0, kThrowSpeed}; }
  static impact_answer answer(const parameters& p) {
    const linear_oscillator free_in{p.m, p.c_y, p.k_y, 0.0, 0.0, 0.0, kThrowSpeed};
    impact_answer a{};
    a.t_in = first_crossing([&](double t) { return free_in.y(t) - p.clearance; }, 0.0, free_in.period() / 2);
    a.v_in = free_in.v(a.t_in);
    // In contact: m y'' + c_y y' + (k_y + k1) y = k1 delta.
    const linear_oscillator contact{p.m, p.c_y, p.k_y + p.k1, p.k1 * p.clearance, a.t_in, p.clearance, a.v_in};
    a.t_out = first_crossing([&](double t) { return contact.y(t) - p.clearance; }, a.t_in, a.t_in + contact.period());
    a.v_out = contact.v(a.t_out);
    const double t_peak = first_crossing([&](double t) { return contact.v(t); }, a.t_in, a.t_out);
    a.z_max = contact.y(t_peak) - p.clearance;
    const linear_oscillator free_out{p.m, p.c_y, p.k_y, 0.0, a.t_out, p.clearance, a.v_out};
    a.t_end = a.t_out + free_out.period() / 4;

    // x is driven only by friction mu k1 z(t) during contact: integrated here by odeint with the
    // closed-form z(t) as forcing (no events involved), then the free closed form.
    namespace ode = boost::numeric::odeint;
    using pair_state = std::array<double, 2>;
    std::array<double, 2> x{0.0, 0.0};
    ode::controlled_runge_kutta<ode::runge_kutta_fehlberg78<pair_state>> stepper(
        ode::default_error_checker<double, ode::array_algebra, ode::default_operations>(1e-16, 1e-14));
    ode::integrate_adaptive(
        std::ref(stepper),
        [&](const std::array<double, 2>& s, std::array<double, 2>& ds, double t) {
          ds[0] = s[1];
          ds[1] = (p.mu * p.k1 * (contact.y(t) - p.clearance) - p.c_x * s[1] - p.k_x * s[0]) / p.m;
        },
        x, a.t_in, a.t_out, 1e-6);
    const linear_oscillator free_x{p.m, p.c_x, p.k_x, 0.0, a.t_out, x[0], x[1]};
    a.end = {free_x.y(a.t_end), free_out.y(a.t_end), free_x.v(a.t_end), free_out.v(a.t_end)};
    return a;
  }
};

// The energy method for nonlinear laws, c_y = 0: K(z) is every z-force but c2 z_dot^2.
struct energy_method {
  double m, c2;
  std::function<double(double)> K;  // N, k_y (delta + z) + contact stiffness force

  // w(z) = z_dot^2 = e^{-az} [v_in^2 - (2/m) int_0^z K(s) e^{as} ds], a = 2 c2 / m.
  double w(double z, double v_in) const {
    const double a = 2.0 * c2 / m;
    const double integral = boost::math::quadrature::gauss_kronrod<double, 61>::integrate(
        [&](double s) { return K(s) * std::exp(a * s); }, 0.0, z, 0, 1e-15);
    return std::exp(-a * z) * (v_in * v_in - 2.0 / m * integral);
  }
  double z_max(double v_in) const {
    double hi = 1e-9;
    while (w(hi, v_in) > 0) hi *= 2;  // w falls monotonically: bisect [hi/2, hi]
    return first_crossing([&](double z) { return w(z, v_in); }, hi / 2, hi, 1);
  }
  // Contact time 2 int_0^zmax dz / sqrt(w). Since w(zmax) = 0, w(z) = (2/m) e^{-az} int_z^zmax
  // K(s) e^{as} ds holds without cancellation near the peak, and z = zmax - u^2 removes the
  // endpoint singularity: the integrand tends to 2 / sqrt((2/m) K(zmax)).
  double duration(double v_in) const {
    const double zm = z_max(v_in), a = 2.0 * c2 / m;
    const auto w_below_peak = [&](double z) {
      return 2.0 / m * std::exp(-a * z) *
             boost::math::quadrature::gauss_kronrod<double, 61>::integrate(
                 [&](double s) { return K(s) * std::exp(a * s); }, z, zm, 0, 1e-15);
    };
    const auto f = [&](double u) { return 2.0 * u / std::sqrt(w_below_peak(zm - u * u)); };
    return 2.0 * boost::math::quadrature::gauss_kronrod<double, 61>::integrate(f, 0.0, std::sqrt(zm), 10, 1e-14);
  }
};

template <class Law>
impact_answer energy_answer(const parameters& p, double c2) {
  const double wy = std::sqrt(p.k_y / p.m);
  impact_answer a{};
  a.t_in = std::asin(p.clearance * wy / kThrowSpeed) / wy;  // undamped free flight y = (v0/wy) sin(wy t)
  a.v_in = std::sqrt(kThrowSpeed * kThrowSpeed - p.clearance * p.clearance * wy * wy);
  const Law law = Law::from(p);
  const energy_method em{p.m, c2, [&p, law](double z) { return p.k_y * (p.clearance + z) + law.normal_force(z, 0.0); }};
  a.z_max = em.z_max(a.v_in);
  a.t_out = a.t_in + em.duration(a.v_in);
  a.v_out = -a.v_in;  // w(z) is the same function in and out: the exit speed equals the entry speed
  a.t_end = a.t_out + 1e-4;  // just past the separation; the answer is in its event
  a.has_end = false;
  return a;
}

parameters undamped_thrown_rotor() {
  parameters p = thrown_rotor();
  p.c_y = 0.0;    // the energy method needs no viscous damping in y
  p.k3 = 1e15;    // N/m^3: large enough that k3 z^3 is ~half of k1 z at these ~60 um penetrations
  return p;
}

template <>
struct single_impact<piecewise_nonlinear> {
  static parameters params() { return undamped_thrown_rotor(); }
  static state_type start() { return {0.0, 0.0, 0.0, kThrowSpeed}; }
  static impact_answer answer(const parameters& p) { return energy_answer<piecewise_nonlinear>(p, 0.0); }
};

template <>
struct single_impact<identified> {
  static parameters params() { return undamped_thrown_rotor(); }
  static state_type start() { return {0.0, 0.0, 0.0, kThrowSpeed}; }
  static impact_answer answer(const parameters& p) { return energy_answer<identified>(p, p.c2); }
};

template <class V>
class single_impact_test : public ::testing::Test {};
TYPED_TEST_SUITE(single_impact_test, all_variant_types, variant_name);

TYPED_TEST(single_impact_test, matches_independent_answer) {
  using known = single_impact<TypeParam>;
  const parameters p = known::params();
  const impact_answer want = known::answer(p);
  // omega only sets the unbalance (zero here) and the default step caps; 1600 rpm as elsewhere.
  const rotor_system<TypeParam> model(p, rpm_to_rad_s(1600.0));
  const auto tr = run(model, known::start(), want.t_end, reference_options());

  const auto rel = [](double got, double ref) { return std::abs(got - ref) / std::abs(ref); };
  if constexpr (impact_law<TypeParam>) {
    ASSERT_EQ(tr.events.size(), 1u);
    const auto& ev = tr.events[0];
    EXPECT_EQ(ev.kind, event_kind::impact);
    EXPECT_NEAR(ev.t, want.t_in, kEventTimeTol);
    EXPECT_LE(rel(ev.approach_velocity, want.v_in), kRelTol);
    EXPECT_EQ(ev.state[idx::vy], -p.r * ev.approach_velocity);  // Eq. 6 applied exactly
  } else {
    ASSERT_EQ(tr.events.size(), 2u);
    EXPECT_EQ(tr.events[0].kind, event_kind::contact_onset);
    EXPECT_EQ(tr.events[1].kind, event_kind::separation);
    EXPECT_NEAR(tr.events[0].t, want.t_in, kEventTimeTol);
    EXPECT_NEAR(tr.events[1].t, want.t_out, kEventTimeTol);
    EXPECT_LE(rel(tr.events[0].approach_velocity, want.v_in), kRelTol);
    EXPECT_LE(rel(tr.events[1].approach_velocity, want.v_out), kRelTol);
    EXPECT_LE(rel(tr.events[1].max_penetration, want.z_max), kRelTol);
    // Friction sign (docs/model.md): the stator pushes the rotor's top towards +x.
    EXPECT_GT(tr.events[1].state[idx::vx], 0.0);
  }
  // Final state (x, y in m; velocities in m/s), relative to the throw's scale.
  const double scale_pos = p.clearance, scale_vel = kThrowSpeed;
  for (int i = 0; i < 4 && want.has_end; ++i) {
    const double scale = i < 2 ? scale_pos : scale_vel;
    EXPECT_LE(std::abs(tr.end.s[i] - want.end[i]) / scale, kRelTol) << "state component " << i;
  }
}

}  // namespace
}  // namespace rubref::testing
