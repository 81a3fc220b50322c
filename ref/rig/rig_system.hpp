#pragma once
// The rotor with effects (ref/rig/effects.hpp): Eq. 1-2 of the paper plus any set of the
// library's effects on the rotor, as an odeint System and a ContactSystem (docs/concepts.md), so
// the hybrid integrator locates its contact events exactly as it does the paper's model's.
//
// State (x, y, x', y', w, w'): the rotor, and the protrusion's displacement w outward along the
// contact normal n (0 and at rest unless the stator is compliant). With n = (sin th, cos th) and
// the tangent t = (cos th, -sin th) (th = 0: the paper's protrusion at the top):
//   z = n.(x, y) - delta - w,   z' = n.(x', y') - w'
//   f_N = law(z, z') + k_h z+^1.5 + lambda z+^p z'              (hertz, hunt_crossley)
//   f_T = sgn(w) mu(v) f_N along t,  v = R|w| - sgn(w) t.(x', y')  (velocity_dependent_friction)
//   m r'' + C r' + K r = -f_N n + f_T t + unbalance + preload + 2X + bow - (k_xy y, k_yx x)
//   m_s w'' + c_s w' + k_s w = f_N                                (stator_compliance)
// Measurement-only effects (runout, misorientation) act in the rig's probes, not here.

#include <array>
#include <cmath>
#include <complex>
#include <numbers>
#include <optional>

#include "ref/contact_law.hpp"
#include "ref/parameters.hpp"
#include "ref/rig/effects.hpp"
#include "ref/rotor_system.hpp"

namespace rubref {

namespace rig_idx {
inline constexpr int w = 4;   // m, protrusion displacement along the normal (outward)
inline constexpr int vw = 5;  // m/s
}  // namespace rig_idx

// A drive that does not hold the speed: w(t) = w (1 + eps sin(2 pi f t)). Not in the effect
// library (the loop is not told of it); for testing that the loop admits what it cannot explain.
struct speed_fluctuation {
  double amplitude = 0.0;  // -, eps
  double frequency = 0.0;  // Hz

  // Shaft angle w t + eps w (1 - cos 2 pi f t) / (2 pi f) and speed w (1 + eps sin 2 pi f t).
  double angle(double omega, double t) const noexcept {
    if (amplitude == 0.0) return omega * t;
    const double wf = 2.0 * std::numbers::pi * frequency;
    return omega * t + amplitude * omega * (1.0 - std::cos(wf * t)) / wf;
  }
  double speed(double omega, double t) const noexcept {
    return amplitude == 0.0 ? omega : omega * (1.0 + amplitude * std::sin(2.0 * std::numbers::pi * frequency * t));
  }
};

// Effects outside the library: the loop is never told of them, and its campaign uses them to
// test that it admits what it cannot explain (docs/loop.md).
struct unmodelled_effects {
  speed_fluctuation drive;       // a drive that does not hold its speed
  double cubic_stiffness = 0.0;  // N/m^3: hardening shaft supports, adding -k (x^3, y^3) to Eq. 1
  double probe_gain_x = 0.0;     // -: the x probe's sensitivity error, it reads (1 + g) x (measurement only)

  bool any() const noexcept { return drive.amplitude != 0.0 || cubic_stiffness != 0.0 || probe_gain_x != 0.0; }
};

// What the two probes read (x at 0, y at 90 deg) of a rotor at (x, y) with the shaft at angle psi:
// the position in axes turned by the misorientation alpha, plus the shaft surface's runout
// a1 cos(psi' + phi1) + a2 cos(2 psi' + phi2), psi' = psi minus the probe's angle.
inline std::array<double, 2> probe_reading(const effect_parameters& fx, double x, double y, double psi) {
  const double ca = std::cos(fx.misorientation), sa = std::sin(fx.misorientation);
  const auto runout = [&](double a) {
    return fx.runout_1x * std::cos(a + fx.runout_1x_phase) + fx.runout_2x * std::cos(2.0 * a + fx.runout_2x_phase);
  };
  return {ca * x + sa * y + runout(psi), -sa * x + ca * y + runout(psi - 0.5 * std::numbers::pi)};
}

template <compliant_law Law>
class rig_system {
 public:
  using state_type = std::array<double, 6>;
  static constexpr bool compliant = true;

  rig_system(const parameters& p, const effect_parameters& fx, double omega, const unmodelled_effects& outside = {},
             contact_phase phase = contact_phase::by_penetration)
      : law_(Law::from(p)),
        p_(p),
        fx_(fx),
        drive_(outside.drive),
        cubic_(outside.cubic_stiffness),
        nx_(std::sin(fx.contact_angle)),
        ny_(std::cos(fx.contact_angle)),
        sign_(omega < 0.0 ? -1.0 : 1.0),
        omega_(omega),
        phase_(phase) {}

  void operator()(const state_type& s, state_type& ds, double t) const {
    const double fn = normal_force(s);
    const double ft = sign_ * friction_coefficient(s) * fn;
    const double shaft = drive_.angle(omega_, t), speed = drive_.speed(omega_, t);
    const double a = shaft + p_.unbalance_phase;
    const double unbalance = p_.m * p_.e * speed * speed;
    const forcing_phasor f = phasor_of(a);  // as rotor_system: without effects, the same bits
    double fx = -fn * nx_ + ft * ny_ + unbalance * f.cos + fx_.preload_x - fx_.k_xy * s[idx::y];
    double fy = -fn * ny_ - ft * nx_ + unbalance * f.sin + fx_.preload_y - fx_.k_yx * s[idx::x];
    if (fx_.misalignment_force != 0.0) {  // (trig only for the effects present: it dominates the cost)
      const double a2 = 2.0 * shaft + fx_.misalignment_phase;
      fx += fx_.misalignment_force * std::cos(a2);
      fy += fx_.misalignment_force * std::sin(a2);
    }
    if (fx_.bow != 0.0) {
      const double ab = shaft + fx_.bow_phase;
      fx += p_.k_x * fx_.bow * std::cos(ab);
      fy += p_.k_y * fx_.bow * std::sin(ab);
    }
    if (cubic_ != 0.0) {
      fx -= cubic_ * s[idx::x] * s[idx::x] * s[idx::x];
      fy -= cubic_ * s[idx::y] * s[idx::y] * s[idx::y];
    }
    ds[idx::x] = s[idx::vx];
    ds[idx::y] = s[idx::vy];
    ds[idx::vx] = (fx - p_.c_x * s[idx::vx] - p_.k_x * s[idx::x]) / p_.m;
    ds[idx::vy] = (fy - p_.c_y * s[idx::vy] - p_.k_y * s[idx::y]) / p_.m;
    if (fx_.stator_k > 0.0) {
      ds[rig_idx::w] = s[rig_idx::vw];
      ds[rig_idx::vw] = (fn - fx_.stator_c * s[rig_idx::vw] - fx_.stator_k * s[rig_idx::w]) / fx_.stator_m;
    } else {
      ds[rig_idx::w] = ds[rig_idx::vw] = 0.0;  // a rigid stator does not move
    }
  }

  // f_N in N under the current phase (the contact phase uses the laws' smooth extension).
  double normal_force(const state_type& s) const noexcept {
    const double z = penetration(s);
    if (!(phase_ == contact_phase::contact || (phase_ == contact_phase::by_penetration && z > 0.0))) return 0.0;
    const double zd = penetration_rate(s), zp = std::max(z, 0.0);
    double f = law_.normal_force(z, zd);
    if (fx_.hertz_k != 0.0) f += fx_.hertz_k * zp * std::sqrt(zp);
    if (fx_.hc_lambda != 0.0) f += fx_.hc_lambda * std::pow(zp, fx_.hc_exponent) * zd;
    return f;
  }

  // mu at the current sliding speed (the paper's constant mu unless friction falls with speed).
  double friction_coefficient(const state_type& s) const noexcept {
    if (!(fx_.mu_static > p_.mu)) return p_.mu;
    const double tangential = ny_ * s[idx::vx] - nx_ * s[idx::vy];
    const double slip = std::abs(fx_.shaft_radius * omega_ - tangential);
    return p_.mu + (fx_.mu_static - p_.mu) * std::exp(-slip / fx_.slip_decay_speed);
  }

  // d(ds/dt)/ds under the current phase (row-major 6 x 6): the variational equations of the
  // monodromy matrix (ref/integrate/shooting.hpp). Exact for every term of operator().
  std::array<double, 36> jacobian(const state_type& s) const noexcept {
    std::array<double, 36> J{};
    const auto at = [&J](int r, int c) -> double& { return J[static_cast<std::size_t>(6 * r + c)]; };
    const double im = 1.0 / p_.m;
    at(idx::x, idx::vx) = at(idx::y, idx::vy) = 1.0;
    at(idx::vx, idx::x) = -p_.k_x * im;
    at(idx::vx, idx::vx) = -p_.c_x * im;
    at(idx::vx, idx::y) = -fx_.k_xy * im;
    at(idx::vy, idx::y) = -p_.k_y * im;
    at(idx::vy, idx::vy) = -p_.c_y * im;
    at(idx::vy, idx::x) = -fx_.k_yx * im;
    if (cubic_ != 0.0) {
      at(idx::vx, idx::x) -= 3.0 * cubic_ * s[idx::x] * s[idx::x] * im;
      at(idx::vy, idx::y) -= 3.0 * cubic_ * s[idx::y] * s[idx::y] * im;
    }
    if (fx_.stator_k > 0.0) {
      at(rig_idx::w, rig_idx::vw) = 1.0;
      at(rig_idx::vw, rig_idx::w) = -fx_.stator_k / fx_.stator_m;
      at(rig_idx::vw, rig_idx::vw) = -fx_.stator_c / fx_.stator_m;
    }
    const double z = penetration(s);
    if (!(phase_ == contact_phase::contact || (phase_ == contact_phase::by_penetration && z > 0.0))) return J;
    // f_N(z, z') and its gradient in the state: grad z = (nx, ny, 0, 0, -1, 0), grad z' = (0, 0, nx, ny, 0, -1).
    const double zd = penetration_rate(s), zp = std::max(z, 0.0);
    auto [fz, fzd] = law_.normal_force_gradient(z, zd);
    if (fx_.hertz_k != 0.0) fz += 1.5 * fx_.hertz_k * std::sqrt(zp);
    if (fx_.hc_lambda != 0.0) {
      const double zp_p = std::pow(zp, fx_.hc_exponent);
      fzd += fx_.hc_lambda * zp_p;
      if (zp > 0.0) fz += fx_.hc_lambda * fx_.hc_exponent * zp_p / zp * zd;
    }
    std::array<double, 6> gn{};  // grad f_N
    gn[idx::x] = fz * nx_;
    gn[idx::y] = fz * ny_;
    gn[rig_idx::w] = -fz;
    gn[idx::vx] = fzd * nx_;
    gn[idx::vy] = fzd * ny_;
    gn[rig_idx::vw] = -fzd;
    // f_T = sgn mu(v) f_N: grad f_T = sgn (mu grad f_N + f_N grad mu).
    const double fn = normal_force(s), mu = friction_coefficient(s);
    std::array<double, 6> gt{};
    for (std::size_t i = 0; i < 6; ++i) gt[i] = sign_ * mu * gn[i];
    if (fx_.mu_static > p_.mu) {
      const double tangential = ny_ * s[idx::vx] - nx_ * s[idx::vy];
      const double rel = fx_.shaft_radius * omega_ - tangential;
      const double dmu_dslip = -(fx_.mu_static - p_.mu) / fx_.slip_decay_speed *
                               std::exp(-std::abs(rel) / fx_.slip_decay_speed);
      const double sgn_rel = rel > 0.0 ? 1.0 : (rel < 0.0 ? -1.0 : 0.0);
      gt[idx::vx] += sign_ * fn * dmu_dslip * sgn_rel * -ny_;
      gt[idx::vy] += sign_ * fn * dmu_dslip * sgn_rel * nx_;
    }
    for (int c = 0; c < 6; ++c) {
      const auto k = static_cast<std::size_t>(c);
      at(idx::vx, c) += (-gn[k] * nx_ + gt[k] * ny_) * im;
      at(idx::vy, c) += (-gn[k] * ny_ - gt[k] * nx_) * im;
      if (fx_.stator_k > 0.0) at(rig_idx::vw, c) += gn[k] / fx_.stator_m;
    }
    return J;
  }
  // The gradient of the penetration z in the state.
  state_type penetration_gradient() const noexcept { return {nx_, ny_, 0.0, 0.0, -1.0, 0.0}; }
  // The states that move: a rigid stator's (w, w') never do.
  int moving_states() const noexcept { return fx_.stator_k > 0.0 ? 6 : 4; }

  // Out of contact the rotor and the stator are linear unless an effect outside the library
  // acts (a fluctuating drive, hardening supports): the exact free flight's dynamics then.
  std::optional<linear_dynamics<6>> free_dynamics() const {
    if (drive_.amplitude != 0.0 || cubic_ != 0.0) return std::nullopt;
    linear_dynamics<6> d;
    const double im = 1.0 / p_.m;
    d.A(idx::x, idx::vx) = d.A(idx::y, idx::vy) = 1.0;
    d.A(idx::vx, idx::x) = -p_.k_x * im;
    d.A(idx::vx, idx::vx) = -p_.c_x * im;
    d.A(idx::vx, idx::y) = -fx_.k_xy * im;
    d.A(idx::vy, idx::y) = -p_.k_y * im;
    d.A(idx::vy, idx::vy) = -p_.c_y * im;
    d.A(idx::vy, idx::x) = -fx_.k_yx * im;
    if (fx_.stator_k > 0.0) {
      d.A(rig_idx::w, rig_idx::vw) = 1.0;
      d.A(rig_idx::vw, rig_idx::w) = -fx_.stator_k / fx_.stator_m;
      d.A(rig_idx::vw, rig_idx::vw) = -fx_.stator_c / fx_.stator_m;
    }
    d.b[idx::vx] = fx_.preload_x * im;
    d.b[idx::vy] = fx_.preload_y * im;
    // a (cos, sin)(h w t + phi) = Re (1, -i) a e^{i phi} e^{i h w t}; bow at 1X scaled by each axis's stiffness.
    const std::complex<double> minus_i(0.0, -1.0);
    const auto add = [&](int order, double ax, double ay, double phase) {
      const std::complex<double> u = std::polar(1.0, phase);
      d.F[static_cast<std::size_t>(order - 1)][idx::vx] += ax * u;
      d.F[static_cast<std::size_t>(order - 1)][idx::vy] += minus_i * ay * u;
    };
    add(1, p_.e * omega_ * omega_, p_.e * omega_ * omega_, p_.unbalance_phase);
    if (fx_.bow != 0.0) add(1, p_.k_x * fx_.bow * im, p_.k_y * fx_.bow * im, fx_.bow_phase);
    if (fx_.misalignment_force != 0.0) add(2, fx_.misalignment_force * im, fx_.misalignment_force * im, fx_.misalignment_phase);
    d.omega = omega_;
    d.normal[idx::x] = nx_;
    d.normal[idx::y] = ny_;
    d.normal[rig_idx::w] = -1.0;
    d.offset = p_.delta;
    return d;
  }

  double penetration(const state_type& s) const noexcept {
    return nx_ * s[idx::x] + ny_ * s[idx::y] - p_.delta - s[rig_idx::w];
  }
  double penetration_rate(const state_type& s) const noexcept {
    return nx_ * s[idx::vx] + ny_ * s[idx::vy] - s[rig_idx::vw];
  }

  rig_system with_phase(contact_phase phase) const {
    rig_system copy = *this;
    copy.phase_ = phase;
    return copy;
  }
  contact_phase phase() const noexcept { return phase_; }
  double omega() const noexcept { return omega_; }
  double shaft_angle(double t) const noexcept { return drive_.angle(omega_, t); }
  double period() const noexcept { return 2.0 * std::numbers::pi / std::abs(omega_); }
  double clearance() const noexcept { return p_.delta; }

 private:
  Law law_;
  parameters p_;
  effect_parameters fx_;
  speed_fluctuation drive_;
  double cubic_;    // N/m^3, outside the library
  double nx_, ny_;  // contact normal
  double sign_;     // +1 counter-clockwise, -1 clockwise
  double omega_;
  contact_phase phase_;
};

}  // namespace rubref
