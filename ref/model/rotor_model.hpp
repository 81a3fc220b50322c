#pragma once
// The rub rotor, one model (Eq. 1-2): a small odeint System value type, no I/O, no stepper.
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
//
// Two sets of terms, one Eq. 1 (`accelerations` below):
//  - paper_terms: the paper's model as printed, state (x, y, x', y'), any of the four laws.
//  - effect_terms: plus any set of the effect library's terms (ref/model/effects.hpp) and the
//    outside-library ones the virtual rig injects (`unmodelled_effects`); compliant laws only.
//    State (x, y, x', y', w, w'), w the protrusion's displacement outward along the contact
//    normal n (0 and at rest unless the stator is compliant). With n = (sin th, cos th) and the
//    tangent t = (cos th, -sin th) (th = 0: the paper's protrusion at the top):
//      z = n.(x, y) - delta - w,   z' = n.(x', y') - w'
//      f_N = law(z, z') + k_h z+^1.5 + lambda z+^p z'               (hertz, hunt_crossley)
//      f_T = sgn(w) mu(v) f_N along t,  v = R|w| - sgn(w) t.(x', y')   (velocity_dependent_friction)
//      m r'' + C r' + K r = -f_N n + f_T t + unbalance + preload + 2X + bow - (k_xy y, k_yx x)
//      m_s w'' + c_s w' + k_s w = f_N                                 (stator_compliance)
//    Measurement-only effects (runout, misorientation) act in the rig's probes
//    (ref/rig/probes.hpp), not here. With every effect off it is the paper's model, to the bit.

#include <array>
#include <algorithm>
#include <cmath>
#include <complex>
#include <concepts>
#include <limits>
#include <numbers>
#include <optional>
#include <type_traits>

#include "ref/model/contact_law.hpp"
#include "ref/model/effects.hpp"
#include "ref/model/free_flight.hpp"
#include "ref/model/parameters.hpp"
#include "ref/model/state.hpp"

namespace rubref {

namespace idx {
inline constexpr int w = 4;   // m, protrusion displacement along the normal (outward); effect_terms only
inline constexpr int vw = 5;  // m/s
}  // namespace idx

// Which force law holds on the current stretch of the trajectory. The hybrid integrator fixes
// the phase between events so that every step sees a smooth right-hand side; `by_penetration`
// evaluates Eq. 2 literally (Heaviside in the RHS), for naive fixed-step use and comparison.
enum class contact_phase {
  free,            // no contact force
  contact,         // compliant law active (its smooth extension is used, even for z <= 0)
  stuck,           // impact law only: rotor held at y = delta after chatter (docs/model.md)
  by_penetration,  // Eq. 2 as written: contact force iff z > 0
};

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

// The parameters a branch of periodic orbits is continued in (ref/orbits/continuation.hpp), and
// the shooting differentiates the n-revolution map by (ref/integrate/shooting.hpp): the speed w
// in rad/s, the clearance delta and the unbalance e in m, the friction coefficient mu.
enum class model_parameter { omega, clearance, unbalance, mu };

struct paper_terms {};   // Eq. 1-2 as printed
struct effect_terms {};  // plus the effect library's and the outside-library terms

template <contact_variant Law, class Terms = paper_terms>
  requires std::same_as<Terms, paper_terms> || (std::same_as<Terms, effect_terms> && compliant_law<Law>)
class rotor_model;

// The paper's model, and the model with effects (the rig's truth, the loop's predictor).
template <contact_variant Law>
using rotor_system = rotor_model<Law, paper_terms>;
template <compliant_law Law>
using rotor_with_effects = rotor_model<Law, effect_terms>;

// Models odeint's System concept: void operator()(const state_type&, state_type&, double) const.
template <contact_variant Law, class Terms>
  requires std::same_as<Terms, paper_terms> || (std::same_as<Terms, effect_terms> && compliant_law<Law>)
class rotor_model {
 public:
  static constexpr bool with_effects = std::same_as<Terms, effect_terms>;
  static constexpr int N = with_effects ? 6 : 4;
  using state_type = std::conditional_t<with_effects, std::array<double, 6>, rubref::state_type>;
  // Whether the contact is a force (else an impact map with sticking): the hybrid integrator's
  // view of the law (docs/concepts.md, "ContactSystem").
  static constexpr bool compliant = compliant_law<Law>;

  rotor_model(const parameters& p, double omega, contact_phase phase = contact_phase::by_penetration)
    requires(!with_effects)
      : rotor_model(p, omega, phase, 0) {}

  rotor_model(const parameters& p, const effect_parameters& fx, double omega, const unmodelled_effects& outside = {},
              contact_phase phase = contact_phase::by_penetration)
    requires with_effects
      : rotor_model(p, omega, phase, 0) {
    terms_.fx = fx;
    terms_.drive = outside.drive;
    terms_.cubic = outside.cubic_stiffness;
    terms_.nx = std::sin(fx.contact_angle);
    terms_.ny = std::cos(fx.contact_angle);
  }

  void operator()(const state_type& s, state_type& ds, double t) const {
    if constexpr (with_effects) {
      effect_rates(s, ds, t);
    } else {
      (*this)(s, ds, phasor_of(forcing_angle(t)));
    }
  }

  // The paper's model with the unbalance direction given: a stepper that advances it by rotation
  // from stage to stage (rk4, ref/integrate/steppers.hpp) evaluates no trig in its hot path.
  void operator()(const state_type& s, state_type& ds, forcing_phasor f) const
    requires(!with_effects)
  {
    double fn = 0.0, ft = 0.0;
    if constexpr (compliant) {
      fn = contact_force(s);
      ft = friction_sign_ * mu_ * fn;
    }
    accelerations(s, ds, ft, -fn, unbalance_acc_ * f.cos, unbalance_acc_ * f.sin);
  }

  // f_N in N at (s, t) under the current phase; the stator reaction while stuck.
  double normal_force(const state_type& s, double t) const noexcept {
    if constexpr (compliant) {
      return contact_force(s);
    } else {
      if (phase_ == contact_phase::stuck) return free_vertical_acceleration(s, t) / inv_m_;
      return 0.0;
    }
  }

  // The compliant law's f_N in N under the current phase (Eq. 2: zero out of contact), with the
  // effects' extra normal forces; the law's smooth extension in the contact phase.
  double contact_force(const state_type& s) const noexcept
    requires compliant
  {
    const double z = penetration(s);
    if (!in_contact(z)) return 0.0;
    const double zd = penetration_rate(s);
    double f = law_.normal_force(z, zd);
    if constexpr (with_effects) {
      const double zp = std::max(z, 0.0);
      if (terms_.fx.hertz_k != 0.0) f += terms_.fx.hertz_k * zp * std::sqrt(zp);
      if (terms_.fx.hc_lambda != 0.0) f += terms_.fx.hc_lambda * std::pow(zp, terms_.fx.hc_exponent) * zd;
    }
    return f;
  }

  // mu at the current sliding speed: the paper's constant mu unless friction falls with speed.
  double friction_coefficient(const state_type& s) const noexcept {
    if constexpr (with_effects) {
      const effect_parameters& fx = terms_.fx;
      if (fx.mu_static > mu_) {
        const double slip = std::abs(fx.shaft_radius * omega_ - tangential_velocity(s));
        return mu_ + (fx.mu_static - mu_) * std::exp(-slip / fx.slip_decay_speed);
      }
    }
    return mu_;
  }

  // The contact's fastest rate at s, 1/s: max(sqrt(k/m), c/m) with k = df_N/dz and c = df_N/dz'
  // (central differences of the law), the scale of the rotor's eigenvalues on the stator's
  // spring and damper. A fixed step dt resolves it only while rate * dt is well below RK4's
  // stability limit 2.8 (the hybrid integrator counts the steps that are not).
  double contact_rate(const state_type& s) const noexcept
    requires(compliant && !with_effects)
  {
    const double z = penetration(s), v = s[idx::vy];
    const double hz = 1e-6 * std::max(std::abs(z), 1e-9), hv = 1e-6 * std::max(std::abs(v), 1e-6);
    const double k = (law_.normal_force(z + hz, v) - law_.normal_force(z - hz, v)) / (2.0 * hz);
    const double c = (law_.normal_force(z, v + hv) - law_.normal_force(z, v - hv)) / (2.0 * hv);
    return std::max(std::sqrt(std::max(k, 0.0) * inv_m_), std::abs(c) * inv_m_);
  }

  // z in m, positive inside the stator (Eq. 2: y - delta), and its rate.
  double penetration(const state_type& s) const noexcept {
    if constexpr (with_effects) {
      return terms_.nx * s[idx::x] + terms_.ny * s[idx::y] - delta_ - s[idx::w];
    } else {
      return s[idx::y] - delta_;
    }
  }
  double penetration_rate(const state_type& s) const noexcept {
    if constexpr (with_effects) {
      return terms_.nx * s[idx::vx] + terms_.ny * s[idx::vy] - s[idx::vw];
    } else {
      return s[idx::vy];
    }
  }
  // The gradient of the penetration in the state.
  state_type penetration_gradient() const noexcept {
    if constexpr (with_effects) {
      return {terms_.nx, terms_.ny, 0.0, 0.0, -1.0, 0.0};
    } else {
      return {0.0, 1.0, 0.0, 0.0};
    }
  }
  // The states that move: a rigid stator's (w, w') never do (the shooting's unknowns).
  int moving_states() const noexcept {
    if constexpr (with_effects) return terms_.fx.stator_k > 0.0 ? 6 : 4;
    return 4;
  }

  // y'' the rotor would have with no contact force (m/s^2): decides sticking and release.
  double free_vertical_acceleration(const state_type& s, double t) const noexcept
    requires(!with_effects)
  {
    return (-c_y_ * s[idx::vy] - k_y_ * s[idx::y]) * inv_m_ + unbalance_acc_ * phasor_of(forcing_angle(t)).sin;
  }
  // A bound on |y''| over [t, t + span] of the free flight from s (m/s^2). The vertical amplitude
  // A = sqrt(y^2 + (y'/w_y)^2) grows at most at U / w_y under the unbalance's acceleration U
  // (damping only takes energy away), so |y| <= A_max, |y'| <= w_y A_max on the span, and
  // |y''| <= (c_y w_y + k_y) A_max / m + U. It lets a stepped free flight be searched for a
  // contact as safely as the closed-form one (ref/integrate/hybrid_integrator.hpp).
  double free_vertical_acceleration_bound(const state_type& s, double span) const noexcept
    requires(!with_effects)
  {
    const double wy = std::sqrt(k_y_ * inv_m_), u = std::abs(unbalance_acc_);
    const double amplitude = std::hypot(s[idx::y], s[idx::vy] / wy) + span * u / wy;
    return ((c_y_ * wy + k_y_) * amplitude * inv_m_ + u) * (1.0 + 1e-9);  // (a margin for its own rounding)
  }
  // How well that acceleration is known (m/s^2): kRoundingUlps ulps of its terms, the forcing's
  // phase rounded to an ulp of w t. A rotor whose free acceleration at the face is within this
  // of zero is neither pressed on the face nor pulled off it.
  double free_vertical_acceleration_rounding(const state_type& s, double t) const noexcept
    requires(!with_effects)
  {
    const double terms = (std::abs(c_y_ * s[idx::vy]) + std::abs(k_y_ * s[idx::y])) * inv_m_ +
                         std::abs(unbalance_acc_) * (1.0 + std::abs(forcing_angle(t)));
    return kRoundingUlps * std::numeric_limits<double>::epsilon() * terms;
  }
  // Its time derivative along a stuck trajectory (y = delta, y' = 0): only the forcing varies.
  double free_vertical_jerk_stuck(double t) const noexcept
    requires(!with_effects)
  {
    return unbalance_acc_ * omega_ * phasor_of(forcing_angle(t)).cos;
  }

  // d(ds/dt)/ds under the current phase (row-major N x N): the variational equations of the
  // monodromy matrix (ref/integrate/shooting.hpp). Exact for every term of operator().
  std::array<double, N * N> jacobian(const state_type& s) const noexcept {
    std::array<double, N * N> J{};
    const auto at = [&J](int r, int c) -> double& { return J[static_cast<std::size_t>(N * r + c)]; };
    at(idx::x, idx::vx) = 1.0;
    at(idx::vx, idx::x) = -k_x_ * inv_m_;
    at(idx::vx, idx::vx) = -c_x_ * inv_m_;
    if (phase_ == contact_phase::stuck) return J;  // y = delta held: y and y' do not move
    at(idx::y, idx::vy) = 1.0;
    at(idx::vy, idx::y) = -k_y_ * inv_m_;
    at(idx::vy, idx::vy) = -c_y_ * inv_m_;
    if constexpr (with_effects) {
      const effect_parameters& fx = terms_.fx;
      at(idx::vx, idx::y) = -fx.k_xy * inv_m_;
      at(idx::vy, idx::x) = -fx.k_yx * inv_m_;
      if (terms_.cubic != 0.0) {
        at(idx::vx, idx::x) -= 3.0 * terms_.cubic * s[idx::x] * s[idx::x] * inv_m_;
        at(idx::vy, idx::y) -= 3.0 * terms_.cubic * s[idx::y] * s[idx::y] * inv_m_;
      }
      if (fx.stator_k > 0.0) {
        at(idx::w, idx::vw) = 1.0;
        at(idx::vw, idx::w) = -fx.stator_k / fx.stator_m;
        at(idx::vw, idx::vw) = -fx.stator_c / fx.stator_m;
      }
    }
    if constexpr (compliant) {
      const double z = penetration(s);
      if (!in_contact(z)) return J;
      // f_N(z, z') and its gradient in the state, grad z = n_z and grad z' = n_z' (rotor part n,
      // stator part -1); f_T = sgn mu(v) f_N, grad f_T = sgn (mu grad f_N + f_N grad mu).
      const double zd = penetration_rate(s);
      auto [fz, fzd] = law_.normal_force_gradient(z, zd);
      const state_type g = penetration_gradient();
      state_type gn{};
      if constexpr (with_effects) {
        const effect_parameters& fx = terms_.fx;
        const double zp = std::max(z, 0.0);
        if (fx.hertz_k != 0.0) fz += 1.5 * fx.hertz_k * std::sqrt(zp);
        if (fx.hc_lambda != 0.0) {
          const double zp_p = std::pow(zp, fx.hc_exponent);
          fzd += fx.hc_lambda * zp_p;
          if (zp > 0.0) fz += fx.hc_lambda * fx.hc_exponent * zp_p / zp * zd;
        }
        for (int c = 0; c < 2; ++c) {
          gn[static_cast<std::size_t>(idx::x + c)] = fz * g[static_cast<std::size_t>(idx::x + c)];
          gn[static_cast<std::size_t>(idx::vx + c)] = fzd * g[static_cast<std::size_t>(idx::x + c)];
        }
        gn[idx::w] = -fz;
        gn[idx::vw] = -fzd;
      } else {
        gn[idx::y] = fz;
        gn[idx::vy] = fzd;
      }
      const double mu = friction_coefficient(s);
      state_type gt{};
      for (std::size_t i = 0; i < gt.size(); ++i) gt[i] = friction_sign_ * mu * gn[i];
      if constexpr (with_effects) {
        const effect_parameters& fx = terms_.fx;
        if (fx.mu_static > mu_) {
          const double fn = contact_force(s);
          const double rel = fx.shaft_radius * omega_ - tangential_velocity(s);
          const double dmu_dslip = -(fx.mu_static - mu_) / fx.slip_decay_speed * std::exp(-std::abs(rel) / fx.slip_decay_speed);
          const double sgn_rel = rel > 0.0 ? 1.0 : (rel < 0.0 ? -1.0 : 0.0);
          gt[idx::vx] += friction_sign_ * fn * dmu_dslip * sgn_rel * -terms_.ny;
          gt[idx::vy] += friction_sign_ * fn * dmu_dslip * sgn_rel * terms_.nx;
        }
      }
      // Eq. 1's contact forces, -f_N n + f_T t, n = (nx, ny) and t = (ny, -nx).
      const double nx = g[idx::x], ny = g[idx::y];
      for (int c = 0; c < N; ++c) {
        const auto k = static_cast<std::size_t>(c);
        if constexpr (with_effects) {
          at(idx::vx, c) += (-gn[k] * nx + gt[k] * ny) * inv_m_;
          at(idx::vy, c) += (-gn[k] * ny - gt[k] * nx) * inv_m_;
          if (terms_.fx.stator_k > 0.0) at(idx::vw, c) += gn[k] / terms_.fx.stator_m;
        } else {
          at(idx::vx, c) += gt[k] * inv_m_;
          at(idx::vy, c) -= gn[k] * inv_m_;
        }
      }
    }
    return J;
  }

  // Out of contact Eq. 1 is linear unless an outside-library term acts (a fluctuating drive,
  // hardening supports): the exact free flight's dynamics (ref/model/free_flight.hpp).
  std::optional<linear_dynamics<N>> free_dynamics() const {
    if constexpr (with_effects) {
      if (terms_.drive.amplitude != 0.0 || terms_.cubic != 0.0) return std::nullopt;
    }
    linear_dynamics<N> d;
    d.A(idx::x, idx::vx) = d.A(idx::y, idx::vy) = 1.0;
    d.A(idx::vx, idx::x) = -k_x_ * inv_m_;
    d.A(idx::vx, idx::vx) = -c_x_ * inv_m_;
    d.A(idx::vy, idx::y) = -k_y_ * inv_m_;
    d.A(idx::vy, idx::vy) = -c_y_ * inv_m_;
    // a (cos, sin)(h w t + phi) = Re (1, -i) a e^{i phi} e^{i h w t}
    const std::complex<double> minus_i(0.0, -1.0);
    const auto add = [&](int order, double ax, double ay, double phase) {
      const std::complex<double> u = std::polar(1.0, phase);
      d.F[static_cast<std::size_t>(order - 1)][idx::vx] += ax * u;
      d.F[static_cast<std::size_t>(order - 1)][idx::vy] += minus_i * (ay * u);
    };
    add(1, unbalance_acc_, unbalance_acc_, unbalance_phase_);
    d.omega = omega_;
    const state_type g = penetration_gradient();
    for (int i = 0; i < N; ++i) d.normal[i] = g[static_cast<std::size_t>(i)];
    d.offset = delta_;
    if constexpr (with_effects) {
      const effect_parameters& fx = terms_.fx;
      d.A(idx::vx, idx::y) = -fx.k_xy * inv_m_;
      d.A(idx::vy, idx::x) = -fx.k_yx * inv_m_;
      if (fx.stator_k > 0.0) {
        d.A(idx::w, idx::vw) = 1.0;
        d.A(idx::vw, idx::w) = -fx.stator_k / fx.stator_m;
        d.A(idx::vw, idx::vw) = -fx.stator_c / fx.stator_m;
      }
      d.b[idx::vx] = fx.preload_x * inv_m_;
      d.b[idx::vy] = fx.preload_y * inv_m_;
      if (fx.bow != 0.0) add(1, k_x_ * fx.bow * inv_m_, k_y_ * fx.bow * inv_m_, fx.bow_phase);
      if (fx.misalignment_force != 0.0)
        add(2, fx.misalignment_force * inv_m_, fx.misalignment_force * inv_m_, fx.misalignment_phase);
    }
    return d;
  }

  // d(ds/dt)/d lambda at (s, t) under the current phase: the forcing of the parameter's
  // variational equation q' = J q + f_lambda (ref/integrate/shooting.hpp), Eq. 1-2 differentiated.
  // The unbalance e w^2 (cos, sin)(w t + phi) in e, and in w through its amplitude and its angle
  // (hence the t); the contact force f_N(y - delta, y') in delta (d/d delta = -df_N/dz) and its
  // friction mu f_N in mu. The friction's direction sgn(w) is constant away from w = 0. Stuck,
  // y = delta is held and only x moves. (The impact law's map and stick have no parameter in
  // them but delta: clearance_rate.)
  state_type parameter_rate(model_parameter p, const state_type& s, double t) const noexcept
    requires(!with_effects)
  {
    state_type d{};
    const bool stuck = phase_ == contact_phase::stuck;
    switch (p) {
      case model_parameter::omega:
      case model_parameter::unbalance: {
        const forcing_phasor f = phasor_of(forcing_angle(t));
        // d(a cos th)/dlambda = a' cos th - a th' sin th, d(a sin th)/dlambda = a' sin th + a th' cos th
        const bool w = p == model_parameter::omega;
        const double amp = w ? 2.0 * e_ * omega_ : omega_ * omega_;  // d(e w^2)/dlambda
        const double turn = w ? unbalance_acc_ * t : 0.0;            // e w^2 d(w t + phi)/dlambda
        d[idx::vx] = amp * f.cos - turn * f.sin;
        if (!stuck) d[idx::vy] = amp * f.sin + turn * f.cos;
        break;
      }
      case model_parameter::clearance:
        if constexpr (compliant) {
          const double z = penetration(s);
          if (in_contact(z)) {
            const double dfn = -law_.normal_force_gradient(z, penetration_rate(s))[0];  // d f_N / d delta
            d[idx::vx] = friction_sign_ * mu_ * dfn * inv_m_;
            d[idx::vy] = -dfn * inv_m_;
          }
        }
        break;
      case model_parameter::mu:
        if constexpr (compliant) d[idx::vx] = friction_sign_ * contact_force(s) * inv_m_;
        break;
    }
    return d;
  }
  // d delta / d lambda: how the stator's face moves with the parameter (z = y - delta, and the
  // stuck phase's y = delta).
  static double clearance_rate(model_parameter p) noexcept { return p == model_parameter::clearance ? 1.0 : 0.0; }
  // d T / d lambda, T = 2 pi / |w|: -T / w in w, else 0.
  double period_rate(model_parameter p) const noexcept { return p == model_parameter::omega ? -period() / omega_ : 0.0; }
  // The free dynamics' derivative in lambda, as a linear_dynamics of its members' derivatives
  // (A, b, normal: zero; F: the 1X unbalance's, through e w^2; omega: dw/dlambda; offset:
  // d delta/dlambda). None of the four parameters enters A: the parameter column's free flight
  // is then in closed form (ref/integrate/shooting.hpp, particular_rate).
  linear_dynamics<N> free_dynamics_rate(model_parameter p) const
    requires(!with_effects)
  {
    linear_dynamics<N> d;
    double amp = 0.0;  // d(e w^2)/dlambda
    if (p == model_parameter::omega) amp = 2.0 * e_ * omega_, d.omega = 1.0;
    if (p == model_parameter::unbalance) amp = omega_ * omega_;
    const std::complex<double> u = std::polar(1.0, unbalance_phase_);
    d.F[0][idx::vx] = amp * u;  // as free_dynamics: a (cos, sin)(w t + phi) = Re (1, -i) a e^{i phi} e^{i w t}
    d.F[0][idx::vy] = std::complex<double>(0.0, -1.0) * (amp * u);
    d.offset = clearance_rate(p);
    return d;
  }

  // Angle of the unbalance force at t, rad: w t + phi (the drive's angle if it fluctuates).
  double forcing_angle(double t) const noexcept { return shaft_angle(t) + unbalance_phase_; }
  // The shaft's angle at t, rad: w t unless the drive fluctuates.
  double shaft_angle(double t) const noexcept {
    if constexpr (with_effects) return terms_.drive.angle(omega_, t);
    return omega_ * t;
  }

  rotor_model with_phase(contact_phase phase) const {
    rotor_model copy = *this;
    copy.phase_ = phase;
    return copy;
  }

  contact_phase phase() const noexcept { return phase_; }
  double omega() const noexcept { return omega_; }  // rad/s, signed: < 0 is clockwise
  double period() const noexcept { return 2.0 * std::numbers::pi / std::abs(omega_); }  // s
  double clearance() const noexcept { return delta_; }
  const Law& law() const noexcept { return law_; }

 private:
  rotor_model(const parameters& p, double omega, contact_phase phase, int)
      : law_(Law::from(p)),
        inv_m_(1.0 / p.m),
        c_x_(p.c_x), c_y_(p.c_y), k_x_(p.k_x), k_y_(p.k_y),
        delta_(p.clearance), mu_(p.mu),
        friction_sign_(omega < 0.0 ? -1.0 : 1.0),
        unbalance_acc_(p.e * omega * omega),
        e_(p.e),
        unbalance_phase_(p.unbalance_phase),
        omega_(omega),
        phase_(phase) {}

  bool in_contact(double z) const noexcept {
    return phase_ == contact_phase::contact || (phase_ == contact_phase::by_penetration && z > 0.0);
  }

  // Eq. 1, the one place it is written: the rotor's accelerations under the forces (f_x, f_y) N
  // besides the shaft's springs, dampers and unbalance, whose acceleration is (u_x, u_y).
  void accelerations(const state_type& s, state_type& ds, double f_x, double f_y, double u_x, double u_y) const {
    ds[idx::x] = s[idx::vx];
    ds[idx::vx] = (f_x - c_x_ * s[idx::vx] - k_x_ * s[idx::x]) * inv_m_ + u_x;
    if (phase_ == contact_phase::stuck) {
      // Unilateral constraint y = delta: the stator carries whatever pushes the rotor up.
      ds[idx::y] = 0.0;
      ds[idx::vy] = 0.0;
    } else {
      ds[idx::y] = s[idx::vy];
      ds[idx::vy] = (f_y - c_y_ * s[idx::vy] - k_y_ * s[idx::y]) * inv_m_ + u_y;
    }
  }

  // The terms of effect_terms, then Eq. 1 and the stator's own equation.
  void effect_rates(const state_type& s, state_type& ds, double t) const
    requires with_effects
  {
    const effect_parameters& fx = terms_.fx;
    const double fn = contact_force(s);
    const double ft = friction_sign_ * friction_coefficient(s) * fn;
    const double nx = terms_.nx, ny = terms_.ny;
    const double shaft = shaft_angle(t);
    const double speed = terms_.drive.speed(omega_, t);
    const double unbalance = terms_.drive.amplitude == 0.0 ? unbalance_acc_ : e_ * speed * speed;
    const forcing_phasor f = phasor_of(shaft + unbalance_phase_);  // as the paper's: without effects, the same bits
    double f_x = -fn * nx + ft * ny + fx.preload_x - fx.k_xy * s[idx::y];
    double f_y = -fn * ny - ft * nx + fx.preload_y - fx.k_yx * s[idx::x];
    // (Trig only for the effects present, by the fast phasor: libm's cos and sin were a tenth of
    // a loop's time where its candidates carried a misalignment or a bow.)
    if (fx.misalignment_force != 0.0) {
      const forcing_phasor a2 = phasor_of(2.0 * shaft + fx.misalignment_phase);
      f_x += fx.misalignment_force * a2.cos;
      f_y += fx.misalignment_force * a2.sin;
    }
    if (fx.bow != 0.0) {
      const forcing_phasor ab = phasor_of(shaft + fx.bow_phase);
      f_x += k_x_ * fx.bow * ab.cos;
      f_y += k_y_ * fx.bow * ab.sin;
    }
    if (terms_.cubic != 0.0) {
      f_x -= terms_.cubic * s[idx::x] * s[idx::x] * s[idx::x];
      f_y -= terms_.cubic * s[idx::y] * s[idx::y] * s[idx::y];
    }
    accelerations(s, ds, f_x, f_y, unbalance * f.cos, unbalance * f.sin);
    if (fx.stator_k > 0.0) {
      ds[idx::w] = s[idx::vw];
      ds[idx::vw] = (fn - fx.stator_c * s[idx::vw] - fx.stator_k * s[idx::w]) / fx.stator_m;
    } else {
      ds[idx::w] = ds[idx::vw] = 0.0;  // a rigid stator does not move
    }
  }

  // The rotor's velocity along the contact tangent t = (ny, -nx).
  double tangential_velocity(const state_type& s) const noexcept
    requires with_effects
  {
    return terms_.ny * s[idx::vx] - terms_.nx * s[idx::vy];
  }

  struct effect_data {
    effect_parameters fx;
    speed_fluctuation drive;
    double cubic = 0.0;        // N/m^3, outside the library
    double nx = 0.0, ny = 1.0; // contact normal
  };
  struct no_effect_data {};

  Law law_;
  double inv_m_;
  double c_x_, c_y_, k_x_, k_y_;
  double delta_, mu_;
  double friction_sign_;    // +1 counter-clockwise, -1 clockwise
  double unbalance_acc_;    // e w^2, m/s^2
  double e_;                // m
  double unbalance_phase_;  // rad
  double omega_;            // rad/s
  contact_phase phase_;
  [[no_unique_address]] std::conditional_t<with_effects, effect_data, no_effect_data> terms_;
};

}  // namespace rubref
