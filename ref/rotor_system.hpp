#pragma once
// The rub rotor as an odeint System (Eq. 1-2): a small value type, no I/O, no stepper.
//
//   m x'' + c_x x' + k_x x = f_x + m e w^2 cos(w t + phi)
//   m y'' + c_y y' + k_y y = f_y + m e w^2 sin(w t + phi)
//   f_x = +mu f_N sgn(w),  f_y = -f_N,  while z = y - delta > 0          (Eq. 2)
//
// Sign conventions (docs/model.md): w > 0 spins the shaft counter-clockwise, x -> y, the sense
// of the unbalance force; the protrusion is at the top (+y). The shaft surface at the top then
// moves towards -x, so the friction it receives from the stator points to +x: f_x = +mu f_N, as
// Eq. 2. A negative w is the mirror image, clockwise rotation, and the friction turns with it.
// phi is the unbalance angle at t = 0 (the paper's Eq. 1 has phi = 0).

#include <cmath>
#include <complex>
#include <numbers>
#include <optional>

#include "ref/contact_law.hpp"
#include "ref/integrate/free_flight.hpp"
#include "ref/parameters.hpp"
#include "ref/state.hpp"

namespace rubref {

// Which force law holds on the current stretch of the trajectory. The hybrid integrator fixes
// the phase between events so that every step sees a smooth right-hand side; `by_penetration`
// evaluates Eq. 2 literally (Heaviside in the RHS), for naive fixed-step use and comparison.
enum class contact_phase {
  free,            // no contact force
  contact,         // compliant law active (its smooth extension is used, even for z <= 0)
  stuck,           // impact law only: rotor held at y = delta after chatter (docs/model.md)
  by_penetration,  // Eq. 2 as written: contact force iff z > 0
};

// Models odeint's System concept: void operator()(const state_type&, state_type&, double) const.
template <contact_variant Law>
class rotor_system {
 public:
  using state_type = rubref::state_type;
  // Whether the contact is a force (else an impact map with sticking): the hybrid integrator's
  // view of the law (docs/concepts.md, "ContactSystem").
  static constexpr bool compliant = compliant_law<Law>;

  rotor_system(const parameters& p, double omega, contact_phase phase = contact_phase::by_penetration)
      : law_(Law::from(p)),
        inv_m_(1.0 / p.m),
        c_x_(p.c_x), c_y_(p.c_y), k_x_(p.k_x), k_y_(p.k_y),
        delta_(p.delta), mu_(p.mu),
        friction_sign_(omega < 0.0 ? -1.0 : 1.0),
        unbalance_acc_(p.e * omega * omega),
        unbalance_phase_(p.unbalance_phase),
        omega_(omega),
        phase_(phase) {}

  void operator()(const state_type& s, state_type& ds, double t) const {
    (*this)(s, ds, phasor_of(forcing_angle(t)));
  }

  // The same with the unbalance direction given: a stepper that advances it by rotation from
  // stage to stage (rk4, ref/steppers.hpp) evaluates no trig in its hot path.
  void operator()(const state_type& s, state_type& ds, forcing_phasor f) const {
    double fx = 0.0, fn = 0.0;
    if constexpr (compliant_law<Law>) {
      fn = contact_force(s);
      fx = friction_sign_ * mu_ * fn;
    }
    ds[idx::x] = s[idx::vx];
    ds[idx::vx] = (fx - c_x_ * s[idx::vx] - k_x_ * s[idx::x]) * inv_m_ + unbalance_acc_ * f.cos;
    if (phase_ == contact_phase::stuck) {
      // Unilateral constraint y = delta: the stator carries whatever pushes the rotor up.
      ds[idx::y] = 0.0;
      ds[idx::vy] = 0.0;
    } else {
      ds[idx::y] = s[idx::vy];
      ds[idx::vy] = (-fn - c_y_ * s[idx::vy] - k_y_ * s[idx::y]) * inv_m_ + unbalance_acc_ * f.sin;
    }
  }

  // f_N in N at (s, t) under the current phase; the stator reaction while stuck.
  double normal_force(const state_type& s, double t) const noexcept {
    if constexpr (compliant_law<Law>) {
      return contact_force(s);
    } else {
      if (phase_ == contact_phase::stuck) return free_vertical_acceleration(s, t) / inv_m_;
      return 0.0;
    }
  }

  // The compliant law's f_N in N under the current phase (Eq. 2: zero out of contact).
  double contact_force(const state_type& s) const noexcept
    requires compliant_law<Law>
  {
    const double z = penetration(s);
    if (phase_ == contact_phase::contact || (phase_ == contact_phase::by_penetration && z > 0.0))
      return law_.normal_force(z, s[idx::vy]);
    return 0.0;
  }

  // The contact's fastest rate at s, 1/s: max(sqrt(k/m), c/m) with k = df_N/dz and c = df_N/dz'
  // (central differences of the law), the scale of the rotor's eigenvalues on the stator's
  // spring and damper. A fixed step dt resolves it only while rate * dt is well below RK4's
  // stability limit 2.8 (the hybrid integrator counts the steps that are not).
  double contact_rate(const state_type& s) const noexcept
    requires compliant_law<Law>
  {
    const double z = penetration(s), v = s[idx::vy];
    const double hz = 1e-6 * std::max(std::abs(z), 1e-9), hv = 1e-6 * std::max(std::abs(v), 1e-6);
    const double k = (law_.normal_force(z + hz, v) - law_.normal_force(z - hz, v)) / (2.0 * hz);
    const double c = (law_.normal_force(z, v + hv) - law_.normal_force(z, v - hv)) / (2.0 * hv);
    return std::max(std::sqrt(std::max(k, 0.0) * inv_m_), std::abs(c) * inv_m_);
  }

  // z = y - delta in m; positive inside the stator (Eq. 2). Its rate is y'.
  double penetration(const state_type& s) const noexcept { return s[idx::y] - delta_; }
  double penetration_rate(const state_type& s) const noexcept { return s[idx::vy]; }

  // y'' the rotor would have with no contact force (m/s^2): decides sticking and release.
  double free_vertical_acceleration(const state_type& s, double t) const noexcept {
    return (-c_y_ * s[idx::vy] - k_y_ * s[idx::y]) * inv_m_ + unbalance_acc_ * phasor_of(forcing_angle(t)).sin;
  }
  // Its time derivative along a stuck trajectory (y = delta, y' = 0): only the forcing varies.
  double free_vertical_jerk_stuck(double t) const noexcept {
    return unbalance_acc_ * omega_ * phasor_of(forcing_angle(t)).cos;
  }

  // d(ds/dt)/ds under the current phase: the variational equations of the monodromy matrix
  // (ref/integrate/shooting.hpp). Row-major 4 x 4.
  std::array<double, 16> jacobian(const state_type& s) const noexcept {
    std::array<double, 16> J{};
    const auto at = [&J](int r, int c) -> double& { return J[static_cast<std::size_t>(4 * r + c)]; };
    at(idx::x, idx::vx) = 1.0;
    at(idx::vx, idx::x) = -k_x_ * inv_m_;
    at(idx::vx, idx::vx) = -c_x_ * inv_m_;
    if (phase_ == contact_phase::stuck) return J;  // y = delta held: y and y' do not move
    at(idx::y, idx::vy) = 1.0;
    at(idx::vy, idx::y) = -k_y_ * inv_m_;
    at(idx::vy, idx::vy) = -c_y_ * inv_m_;
    if constexpr (compliant_law<Law>) {
      const double z = penetration(s);
      if (phase_ == contact_phase::contact || (phase_ == contact_phase::by_penetration && z > 0.0)) {
        const auto [kz, kv] = law_.normal_force_gradient(z, s[idx::vy]);  // f_N(z = y - delta, z' = y')
        at(idx::vx, idx::y) += friction_sign_ * mu_ * kz * inv_m_;
        at(idx::vx, idx::vy) += friction_sign_ * mu_ * kv * inv_m_;
        at(idx::vy, idx::y) -= kz * inv_m_;
        at(idx::vy, idx::vy) -= kv * inv_m_;
      }
    }
    return J;
  }
  // The gradient of the penetration z = y - delta in the state.
  state_type penetration_gradient() const noexcept { return {0.0, 1.0, 0.0, 0.0}; }

  // Out of contact Eq. 1 is linear: the exact free flight's dynamics (ref/integrate/free_flight.hpp).
  std::optional<linear_dynamics<4>> free_dynamics() const {
    linear_dynamics<4> d;
    d.A(idx::x, idx::vx) = d.A(idx::y, idx::vy) = 1.0;
    d.A(idx::vx, idx::x) = -k_x_ * inv_m_;
    d.A(idx::vx, idx::vx) = -c_x_ * inv_m_;
    d.A(idx::vy, idx::y) = -k_y_ * inv_m_;
    d.A(idx::vy, idx::vy) = -c_y_ * inv_m_;
    // e w^2 (cos, sin)(w t + phi) = Re (1, -i) e w^2 e^{i phi} e^{i w t}
    const std::complex<double> u = unbalance_acc_ * std::polar(1.0, unbalance_phase_);
    d.F[0][idx::vx] = u;
    d.F[0][idx::vy] = std::complex<double>(0.0, -1.0) * u;
    d.omega = omega_;
    d.normal[idx::y] = 1.0;
    d.offset = delta_;
    return d;
  }

  // Angle of the unbalance force at t, rad: w t + phi.
  double forcing_angle(double t) const noexcept { return omega_ * t + unbalance_phase_; }

  rotor_system with_phase(contact_phase phase) const {
    rotor_system copy = *this;
    copy.phase_ = phase;
    return copy;
  }

  contact_phase phase() const noexcept { return phase_; }
  double omega() const noexcept { return omega_; }  // rad/s, signed: < 0 is clockwise
  double period() const noexcept { return 2.0 * std::numbers::pi / std::abs(omega_); }  // s
  double clearance() const noexcept { return delta_; }
  const Law& law() const noexcept { return law_; }

 private:
  Law law_;
  double inv_m_;
  double c_x_, c_y_, k_x_, k_y_;
  double delta_, mu_;
  double friction_sign_;  // +1 counter-clockwise, -1 clockwise
  double unbalance_acc_;  // e w^2, m/s^2
  double unbalance_phase_;  // rad
  double omega_;          // rad/s
  contact_phase phase_;
};

}  // namespace rubref
