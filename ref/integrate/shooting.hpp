#pragma once
// Periodic orbits by shooting (docs/orbits.md). A steady orbit of period n T (T = 2 pi / |w|) is a
// fixed point of the n-revolution map P: s(t0) -> s(t0 + n T). Newton on P(s) - s = 0 needs
// the monodromy M = dP/ds, here exact to the integrator's accuracy:
//  - free arcs: e^{A tau}, in closed form (ref/model/free_flight.hpp);
//  - contact and stuck phases: the variational equations Phi' = J(s) Phi beside the state;
//  - at each event, the saltation matrix S = R + (f+ - R f-) g^T / (g . f-), with g the gradient
//    of the event's function (z), f-/f+ the vector fields before and after, R the reset's Jacobian
//    (identity for a switch, diag(.., r') for an impact, the projection onto y = delta for a stick;
//    a release leaves Phi unchanged, as f+ = f- there). At a grazing event g . f- -> 0 and S
//    grows without bound: the multipliers jump there (docs/orbits.md).
// The Floquet multipliers are M's eigenvalues; the orbit is stable when all lie inside the unit
// circle.
//
// Continuation (ref/orbits/continuation.cpp) also needs dP/dlambda in a model parameter lambda
// (model_parameter: w, delta, e, mu), exact in the same way: one more column q = ds/dlambda beside
// Phi, q(t0) = 0, with
//  - free arcs: q(t) = p_l(t) + e^{A tau} (q(t0) - p_l(t0)), p_l = dp/dlambda the derivative of
//    the particular solution (particular_rate, below): A does not depend on lambda, so this
//    solves q' = A q + f_lambda exactly, as the state's own closed form does;
//  - contact and stuck phases: q' = J(s) q + f_lambda(s, t) (the model's parameter_rate);
//  - at each event, the saltation of a parameter. An event at z(s, lambda) = 0 (z = y - delta has
//    no explicit t) moves by dt*/dlambda = -(g . q- + z_lambda) / (g . f-), z_lambda = -1 for the
//    clearance and 0 otherwise; with a reset s+ = R(s-, lambda),
//      q+ = R q- + R_lambda + (f+ - R f-) (g . q- + z_lambda) / (g . f-)
//         = S q- + (f+ - R f-) z_lambda / (g . f-) + R_lambda.
//    R_lambda is zero but for a stick, which puts y on delta (R_lambda = e_y d delta/dlambda); the
//    impact map y' -> -r y' has no parameter in it. A release leaves q unchanged: R = I and
//    f+ = f- there, so its event function's dependence on lambda (the free acceleration's on w
//    and e) moves its time but not the state.
// The n-revolution map ends at t0 + n T(lambda): dP/dlambda = q(t1) + f(P, t1) n dT/dlambda, the
// last term nonzero for the speed only (dT/dw = -T/w).

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ref/base/errors.hpp"
#include "ref/integrate/hybrid_integrator.hpp"
#include "ref/model/free_flight.hpp"

namespace rubref {

// A ContactSystem with its Jacobian (row-major N x N, under its current phase) and the gradient of
// its penetration: what the variational equations and the saltation matrices need.
template <class S>
concept differentiable_system = contact_system<S> && requires(const S sys, const state_of<S>& x) {
  { sys.jacobian(x) } -> std::same_as<std::array<double, std::tuple_size_v<state_of<S>> * std::tuple_size_v<state_of<S>>>>;
  { sys.penetration_gradient() } -> std::same_as<state_of<S>>;
};

// A differentiable_system that also gives its vector field's, face's, period's and free flight's
// derivatives in a model_parameter (ref/model/rotor_model.hpp): the parameter column's sources.
template <class S>
concept parameter_differentiable_system =
    differentiable_system<S> && requires(const S sys, const state_of<S>& x, double t, model_parameter p) {
      { sys.parameter_rate(p, x, t) } -> std::same_as<state_of<S>>;
      { sys.clearance_rate(p) } -> std::convertible_to<double>;
      { sys.period_rate(p) } -> std::convertible_to<double>;
    } && (!linear_free_flight<S> || requires(const S sys, model_parameter p) {
      { sys.free_dynamics_rate(p) } -> std::same_as<linear_dynamics<static_cast<int>(std::tuple_size_v<state_of<S>>)>>;
    });

template <int N>
using square_matrix = Eigen::Matrix<double, N, N>;

// The states of a system that move (a rigid stator's do not): the shooting's unknowns.
template <class System>
int moving_states(const System& sys) {
  if constexpr (requires { sys.moving_states(); }) {
    return sys.moving_states();
  } else {
    return static_cast<int>(std::tuple_size_v<state_of<System>>);
  }
}

// d p / d lambda of the free flight's particular solution (ref/model/free_flight.hpp)
//   p(t) = -A^-1 b + Re sum_h P_h e^{i h w t},  P_h = (i h w - A)^-1 F_h,
// when b, F_h and w depend on lambda and A does not (`rate` holds their derivatives):
//   dp/dlambda = -A^-1 b' + Re sum_h (P_h' + i h w' t P_h) e^{i h w t},  P_h' = (i h w - A)^-1 (F_h' - i h w' P_h).
// Differentiating p' = A p + b + forcing shows it solves q' = A q + f_lambda(t): the particular
// solution of the parameter column's free flight, in closed form and exact, like the state's (a
// numerically integrated column would cost the free arcs their closed form). The t in the
// secular term is absolute time, as the forcing's angle w t is.
template <int N>
class particular_rate {
 public:
  using vector = Eigen::Matrix<double, N, 1>;
  particular_rate(const linear_dynamics<N>& d, const linear_dynamics<N>& rate) : omega_(d.omega), domega_(rate.omega) {
    using cscalar = std::complex<double>;
    using cmatrix = Eigen::Matrix<cscalar, N, N>;
    if (!rate.A.isZero(0.0)) throw numerical_error("free flight: a parameter that enters A has no closed-form sensitivity");
    if (!rate.b.isZero(0.0)) {
      const Eigen::FullPivLU<square_matrix<N>> lu(d.A);
      p0_ = lu.solve(-rate.b);
      if (!(d.A * p0_ + rate.b).isZero(1e-9 * rate.b.norm()))
        throw numerical_error("free flight: no static equilibrium for the parameter's sensitivity");
    }
    for (int h = 0; h < linear_dynamics<N>::kMaxHarmonics; ++h) {
      const auto k = static_cast<std::size_t>(h);
      const auto& F = d.F[k];
      const auto& dF = rate.F[k];
      if (F.isZero(0.0) && dF.isZero(0.0)) continue;
      const cmatrix m = cscalar(0.0, (h + 1) * d.omega) * cmatrix::Identity() - d.A.template cast<cscalar>();
      const Eigen::PartialPivLU<cmatrix> lu(m);
      P_[k] = lu.solve(F);
      dP_[k] = lu.solve(dF - cscalar(0.0, (h + 1) * domega_) * P_[k]);
      if (!P_[k].allFinite() || !dP_[k].allFinite())
        throw numerical_error("free flight: the forcing is at an undamped resonance");
    }
  }

  vector at(double t) const {
    using cscalar = std::complex<double>;
    const forcing_phasor u = phasor_of(omega_ * t);
    const cscalar z1(u.cos, u.sin);
    cscalar z = 1.0;
    vector v = p0_;
    for (int h = 0; h < linear_dynamics<N>::kMaxHarmonics; ++h) {
      const auto k = static_cast<std::size_t>(h);
      z *= z1;
      v += ((dP_[k] + cscalar(0.0, (h + 1) * domega_ * t) * P_[k]) * z).real();
    }
    return v;
  }

 private:
  using cvector = typename linear_dynamics<N>::complex_vector;
  double omega_, domega_;
  vector p0_ = vector::Zero();
  std::array<cvector, linear_dynamics<N>::kMaxHarmonics> P_{cvector::Zero(), cvector::Zero()}, dP_{cvector::Zero(), cvector::Zero()};
};

// What an augmented state's closed-form free arc shares (sensitivity_free_flight here,
// columns_free_flight in ref/integrate/parameter_columns.hpp): the model's own arc from the head
// of the state, whose events and rounding are the arc's.
template <int N>
class augmented_arc_base {
 public:
  std::optional<std::pair<double, double>> first_onset(double from, double t_end, double min_depth, double time_tol, double window,
                                                       std::size_t* steps = nullptr) const {
    return base_.first_onset(from, t_end, min_depth, time_tol, window, steps);
  }
  std::pair<double, double> rounding(double t) const { return base_.rounding(t); }

 protected:
  template <std::size_t K>
  augmented_arc_base(const free_flight<N>& ff, double t0, const std::array<double, K>& a) : base_(ff.from(t0, head(a))) {}
  template <std::size_t K>
  static std::array<double, N> head(const std::array<double, K>& a) {
    std::array<double, N> s{};
    std::copy(a.begin(), a.begin() + N, s.begin());
    return s;
  }
  typename free_flight<N>::arc base_;
};

// The saltation across an event at t (top of this file): S = R + (f+ - R f-) g^T / (g . f-), with
// its parts f+ - R f- and g . f-, which also carry a parameter's move of the event
// ((f+ - R f-) dz/dlambda / (g . f-)). numerical_error at a grazing event (g . f- = 0), where S is
// unbounded.
template <int N>
struct saltation {
  square_matrix<N> S;
  Eigen::Matrix<double, N, 1> difference;  // f+ - R f-
  double denominator = 0.0;               // g . f-
};
template <int N>
saltation<N> saltation_at(const std::array<double, N>& f_before, const std::array<double, N>& f_after, const std::array<double, N>& g,
                          const square_matrix<N>& R, double t) {
  const Eigen::Map<const Eigen::Matrix<double, N, 1>> fm(f_before.data()), fp(f_after.data()), gv(g.data());
  saltation<N> out;
  for (int i = 0; i < N; ++i) out.denominator += g[static_cast<std::size_t>(i)] * f_before[static_cast<std::size_t>(i)];
  if (!(std::abs(out.denominator) > 0.0))
    throw numerical_error("a grazing contact event (zero normal velocity) at t = " + std::to_string(t) +
                          " s: the saltation matrix is unbounded there");
  out.difference = fp - R * fm;
  out.S = R + out.difference * gv.transpose() / out.denominator;
  return out;
}

// The closed-form free flight of the state, of Phi (Phi(t) = e^{A (t - t0)} Phi(t0)) and, with
// P = 1, of the parameter column (q(t) = p_l(t) + e^{A (t - t0)} (q(t0) - p_l(t0))).
template <int N, int P = 0>
class sensitivity_free_flight {
 public:
  static constexpr int C = N + P;  // columns: Phi's, then the parameter's
  using state = std::array<double, N + N * C>;
  using columns = Eigen::Matrix<double, N, C>;
  explicit sensitivity_free_flight(const linear_dynamics<N>& d)
    requires(P == 0)
      : ff_(d) {}
  sensitivity_free_flight(const linear_dynamics<N>& d, const linear_dynamics<N>& rate)
    requires(P == 1)
      : ff_(d), rate_(std::in_place, d, rate) {}

  class arc : public augmented_arc_base<N> {
   public:
    arc(const sensitivity_free_flight& owner, double t0, const state& a)
        : augmented_arc_base<N>(owner.ff_, t0, a), owner_(&owner), t0_(t0), cols0_(Eigen::Map<const columns>(a.data() + N)) {
      if constexpr (P == 1) cols0_.col(N) -= owner.rate_->at(t0);  // q(t0) - p_l(t0)
    }
    state at(double t) const {
      const auto s = this->base_.at(t);
      state a{};
      std::copy(s.begin(), s.end(), a.begin());
      Eigen::Map<columns> cols(a.data() + N);
      cols.noalias() = owner_->ff_.transition(t - t0_) * cols0_;
      if constexpr (P == 1) cols.col(N) += owner_->rate_->at(t);
      return a;
    }

   private:
    const sensitivity_free_flight* owner_;
    double t0_;
    columns cols0_;
  };

  arc from(double t0, const state& a) const { return arc(*this, t0, a); }

 private:
  free_flight<N> ff_;
  std::optional<particular_rate<N>> rate_;
};

// The system's flow and its sensitivity Phi = ds(t)/ds(t0) as one ContactSystem of N + N^2 states
// (Phi column-major after s), so the hybrid integrator locates its events as it does the model's;
// with P = 1, also the parameter column q = ds(t)/dlambda after Phi (N + N (N + 1) states).
template <differentiable_system System, int P = 0>
  requires(P == 0 || (P == 1 && parameter_differentiable_system<System>))
class sensitivity_system {
 public:
  static constexpr int N = static_cast<int>(std::tuple_size_v<state_of<System>>);
  static constexpr int C = N + P;  // columns after s: Phi's, then the parameter's
  using base_state = state_of<System>;
  using state_type = std::array<double, N + N * C>;
  static constexpr bool compliant = System::compliant;

  explicit sensitivity_system(const System& sys)
    requires(P == 0)
      : sys_(sys) {}
  sensitivity_system(const System& sys, model_parameter p)
    requires(P == 1)
      : sys_(sys), parameter_(p) {}

  void operator()(const state_type& a, state_type& da, double t) const {
    const base_state s = head(a);
    base_state ds{};
    sys_(s, ds, t);
    std::copy(ds.begin(), ds.end(), da.begin());
    const auto J = sys_.jacobian(s);  // row-major
    const Eigen::Map<const Eigen::Matrix<double, N, N, Eigen::RowMajor>> Jm(J.data());
    const Eigen::Map<const Eigen::Matrix<double, N, C>> cols(a.data() + N);  // column-major after s
    Eigen::Map<Eigen::Matrix<double, N, C>> dcols(da.data() + N);
    dcols.noalias() = Jm * cols;
    if constexpr (P == 1) {
      const base_state r = sys_.parameter_rate(parameter_, s, t);
      dcols.col(N) += Eigen::Map<const Eigen::Matrix<double, N, 1>>(r.data());
    }
  }

  contact_phase phase() const noexcept { return sys_.phase(); }
  sensitivity_system with_phase(contact_phase ph) const {
    sensitivity_system copy = *this;
    copy.sys_ = sys_.with_phase(ph);
    return copy;
  }
  double penetration(const state_type& a) const noexcept { return sys_.penetration(head(a)); }
  double penetration_rate(const state_type& a) const noexcept { return sys_.penetration_rate(head(a)); }
  double period() const noexcept { return sys_.period(); }
  double clearance() const noexcept { return sys_.clearance(); }
  double omega() const noexcept { return sys_.omega(); }
  decltype(auto) law() const noexcept
    requires requires(const System& s) { s.law(); }
  {
    return sys_.law();
  }
  double free_vertical_acceleration(const state_type& a, double t) const noexcept
    requires requires(const System& s, const base_state& x) { s.free_vertical_acceleration(x, t); }
  {
    return sys_.free_vertical_acceleration(head(a), t);
  }
  double free_vertical_acceleration_rounding(const state_type& a, double t) const noexcept
    requires requires(const System& s, const base_state& x) { s.free_vertical_acceleration_rounding(x, t); }
  {
    return sys_.free_vertical_acceleration_rounding(head(a), t);
  }
  double free_vertical_jerk_stuck(double t) const noexcept
    requires requires(const System& s) { s.free_vertical_jerk_stuck(t); }
  {
    return sys_.free_vertical_jerk_stuck(t);
  }

  // The closed-form free flight of every part, where the model's is linear.
  std::optional<sensitivity_free_flight<N, P>> free_flight_propagator() const {
    if constexpr (linear_free_flight<System>) {
      if (auto d = sys_.free_dynamics()) {
        if constexpr (P == 1) {
          return sensitivity_free_flight<N, P>(*d, sys_.free_dynamics_rate(parameter_));
        } else {
          return sensitivity_free_flight<N, P>(*d);
        }
      }
    }
    return std::nullopt;
  }

  // Phi (and q) across an event: S Phi, S q + (f+ - R f-) g_lambda / (g . f-) + R_lambda, S the
  // saltation matrix (top of this file). `before` is the system of the phase that ended, `pre`
  // the state there before any reset, `post` after it.
  state_type after_event(const sensitivity_system& before, event_kind kind, double t, const state_type& pre,
                         const state_type& post) const {
    if (kind == event_kind::release) return post;  // f+ = f- at a release: S = I, and q+ = q-
    square_matrix<N> R = square_matrix<N>::Identity();
    if constexpr (!System::compliant) {
      if (kind == event_kind::impact) R(idx::vy, idx::vy) = sys_.law().rebound_slope(pre[idx::vy]);
      if (kind == event_kind::stick) R(idx::y, idx::y) = R(idx::vy, idx::vy) = 0.0;
    }
    base_state fm{}, fp{};
    before.sys_(head(pre), fm, t);
    sys_(head(post), fp, t);
    const saltation<N> sal = saltation_at<N>(fm, fp, sys_.penetration_gradient(), R, t);
    state_type a = post;
    Eigen::Map<Eigen::Matrix<double, N, C>> cols(a.data() + N);
    cols.noalias() = sal.S * Eigen::Map<const Eigen::Matrix<double, N, C>>(pre.data() + N);
    if constexpr (P == 1) {
      // z = y - delta: z_lambda = -d delta/dlambda; a stick puts y on delta (R_lambda = e_y d delta/dlambda).
      const double ddelta = sys_.clearance_rate(parameter_);
      cols.col(N) += sal.difference * (-ddelta / sal.denominator);
      if constexpr (!System::compliant)
        if (kind == event_kind::stick) cols(idx::y, N) += ddelta;
    }
    return a;
  }

  const System& model() const noexcept { return sys_; }

  static base_state head(const state_type& a) {
    base_state s{};
    std::copy(a.begin(), a.begin() + N, s.begin());
    return s;
  }

 private:
  System sys_;
  model_parameter parameter_ = model_parameter::omega;  // the parameter column's (P = 1)
};

// The state after n T from (t0, s0) and the monodromy d s(t0 + n T) / d s0.
template <int N>
struct flow_with_monodromy {
  std::array<double, N> end{};
  square_matrix<N> monodromy;
  integration_counts counts;
};

template <differentiable_system System>
flow_with_monodromy<static_cast<int>(std::tuple_size_v<state_of<System>>)> flow_and_monodromy(
    const System& sys, const state_of<System>& s0, double t0, double t1, const integration_options& opt) {
  constexpr int N = static_cast<int>(std::tuple_size_v<state_of<System>>);
  const sensitivity_system<System> aug(sys);
  typename sensitivity_system<System>::state_type a{};
  std::copy(s0.begin(), s0.end(), a.begin());
  for (int i = 0; i < N; ++i) a[static_cast<std::size_t>(N + i * N + i)] = 1.0;
  flow_with_monodromy<N> out;
  null_observer none;
  const auto start = start_state(sys, s0, t0);
  const auto end = integrate_hybrid(aug, basic_hybrid_state<typename sensitivity_system<System>::state_type>{a, t0, start.phase, start.episode_peak},
                                    t1, opt, sample_grid{}, none, &out.counts);
  out.end = sensitivity_system<System>::head(end.s);
  for (int c = 0; c < N; ++c)
    for (int r = 0; r < N; ++r) out.monodromy(r, c) = end.s[static_cast<std::size_t>(N + c * N + r)];
  return out;
}

// The flow with its parameter column (one type per model, the parameter a run-time value).
template <parameter_differentiable_system System>
using parameter_sensitivity_system = sensitivity_system<System, 1>;

// The n-revolution map P from (t0, s0), its monodromy dP/ds0 and its derivative in a model
// parameter: dP/dlambda = q(t1) + f(P, t1) n dT/dlambda (top of this file).
template <int N>
struct map_with_sensitivities {
  std::array<double, N> end{};
  square_matrix<N> monodromy;
  Eigen::Matrix<double, N, 1> parameter_at_fixed_end;  // q(t1): ds(t1)/dlambda with t1 held
  Eigen::Matrix<double, N, 1> parameter;               // dP/dlambda: with the end moving as n T(lambda)
  integration_counts counts;
};

template <parameter_differentiable_system System>
map_with_sensitivities<static_cast<int>(std::tuple_size_v<state_of<System>>)> map_and_sensitivities(
    const System& sys, const state_of<System>& s0, double t0, int periods, model_parameter parameter,
    const integration_options& opt) {
  constexpr int N = static_cast<int>(std::tuple_size_v<state_of<System>>);
  using augmented = parameter_sensitivity_system<System>;
  const augmented aug(sys, parameter);
  typename augmented::state_type a{};
  std::copy(s0.begin(), s0.end(), a.begin());
  for (int i = 0; i < N; ++i) a[static_cast<std::size_t>(N + i * N + i)] = 1.0;  // Phi(t0) = I, q(t0) = 0
  map_with_sensitivities<N> out;
  null_observer none;
  const double t1 = t0 + periods * sys.period();
  const auto start = start_state(sys, s0, t0);
  const auto end = integrate_hybrid(aug, basic_hybrid_state<typename augmented::state_type>{a, t0, start.phase, start.episode_peak}, t1, opt,
                                    sample_grid{}, none, &out.counts);
  out.end = augmented::head(end.s);
  const Eigen::Map<const Eigen::Matrix<double, N, N + 1>> cols(end.s.data() + N);
  out.monodromy = cols.template leftCols<N>();
  out.parameter_at_fixed_end = cols.col(N);
  state_of<System> rate{};
  sys.with_phase(end.phase)(out.end, rate, t1);  // the phase the map ends in
  out.parameter = out.parameter_at_fixed_end + Eigen::Map<const Eigen::Matrix<double, N, 1>>(rate.data()) * (periods * sys.period_rate(parameter));
  return out;
}

struct shooting_settings {
  integration_options integration = [] {
    integration_options o;
    o.stepper.kind = stepper_kind::rkf78;  // 8th order: a tight tolerance at a fraction of dopri5's steps
    o.stepper.rtol = 1e-12;  // the flow to ~1e-16 m per step on a 0.3 mm orbit: below the tolerance
    o.stepper.atol = 1e-16;
    return o;
  }();
  int max_iterations = 30;
  // Converged when the map moves the state by less than this (positions in m, velocities / |w|).
  double tolerance = kShootingTolerance;
  // Inexact Newton, for a guess far from the orbit (a contact-free response): an evaluation far
  // from the orbit needs only a small share of the residual that Newton's step will leave, not
  // the tolerance. The first evaluation is then coarse, and each next one at the stepper rtol
  // kInexactRtolFactor (r / R)^2 (r the residual, R the orbit's size; Newton leaves ~ r^2 / R),
  // clamped to [integration's rtol, kCoarsestRtol]. Only an evaluation at integration's own
  // tolerance can converge. Off for a guess already near the orbit (a coarse first evaluation
  // would be wasted there).
  bool coarse_while_far = false;
  static constexpr double kCoarsestRtol = 1e-6;        // rkf78 errs by ~1e-8 of the orbit there (2e-12 m of 3e-4 m at 1600 rpm)
  static constexpr double kInexactRtolFactor = 1e-3;  // the flow's error ~1e-2 rtol R: 1e-5 of what the step leaves
};

template <int N>
struct periodic_orbit {
  bool converged = false;
  std::array<double, N> state{};  // on the orbit at t0
  double t0 = 0.0;                // s
  int periods = 1;                // revolutions per period
  square_matrix<N> monodromy = square_matrix<N>::Zero();
  std::vector<std::complex<double>> multipliers;  // of the moving states, largest modulus first
  double residual = std::numeric_limits<double>::infinity();  // scaled |P(s) - s|, m
  int iterations = 0;
  std::size_t events_per_period = 0;
  std::string failure;  // why Newton stopped, when it did not converge

  double max_multiplier_modulus() const {
    double m = 0.0;
    for (const auto& mu : multipliers) m = std::max(m, std::abs(mu));
    return m;
  }
  bool stable() const { return converged && max_multiplier_modulus() < 1.0; }
};

// Newton on P(s) - s = 0 from `guess` at t0, with backtracking when a step does not reduce the
// residual (a contact that the step creates or removes makes P non-smooth). Never throws for a
// failed iteration: the result says why (`failure`).
template <differentiable_system System>
periodic_orbit<static_cast<int>(std::tuple_size_v<state_of<System>>)> shoot_periodic_orbit(const System& sys, const state_of<System>& guess,
                                                                                            double t0, int periods,
                                                                                            const shooting_settings& set = {}) {
  constexpr int N = static_cast<int>(std::tuple_size_v<state_of<System>>);
  using dyn_matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, N, N>;
  using dyn_vector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1>;
  periodic_orbit<N> out;
  out.t0 = t0;
  out.periods = periods;
  const int n = moving_states(sys);
  const double t1 = t0 + periods * sys.period();
  // Velocities weigh as positions over a radian of the shaft.
  std::array<double, N> scale{};
  for (int i = 0; i < N; ++i) scale[static_cast<std::size_t>(i)] = (i % 4 < 2 && i < 4) || i == 4 ? 1.0 : 1.0 / std::abs(sys.omega());
  const auto residual_of = [&](const std::array<double, N>& s, const std::array<double, N>& p) {
    double r = 0.0;
    for (int i = 0; i < n; ++i) r = std::max(r, std::abs(p[static_cast<std::size_t>(i)] - s[static_cast<std::size_t>(i)]) * scale[static_cast<std::size_t>(i)]);
    return r;
  };

  // An impact law's states live at z <= 0: a guess or a step beyond the stator's face is put on it
  // (an orbit is never inside, so this only shortens a step that overshot).
  const auto admissible = [&](std::array<double, N>& x) {
    if constexpr (!System::compliant) {
      const double z = sys.penetration(x);
      if (z > 0.0) x[idx::y] -= z;
      while (sys.penetration(x) > 0.0) x[idx::y] = std::nextafter(x[idx::y], -1.0);  // (y - z rounds up)
    }
  };
  std::array<double, N> s = guess;
  admissible(s);
  std::array<double, N> best = s;
  std::optional<flow_with_monodromy<N>> at_best;
  double best_res = std::numeric_limits<double>::infinity();
  dyn_vector step;
  double damping = 1.0;
  // The stepper's rtol for the next evaluation (set.coarse_while_far); R, the orbit's size, is
  // at least the clearance.
  const double final_rtol = set.integration.stepper.rtol;
  double rtol = set.coarse_while_far ? std::max(final_rtol, shooting_settings::kCoarsestRtol) : final_rtol;
  const auto orbit_size = [&](const std::array<double, N>& x) {
    double r = sys.clearance();
    for (int i = 0; i < n; ++i) r = std::max(r, std::abs(x[static_cast<std::size_t>(i)]) * scale[static_cast<std::size_t>(i)]);
    return r;
  };
  for (int it = 0; it < set.max_iterations; ++it) {
    out.iterations = it + 1;
    std::optional<flow_with_monodromy<N>> f;
    double res = std::numeric_limits<double>::infinity();
    const bool coarse = rtol > final_rtol;
    integration_options opt = set.integration;
    opt.stepper.rtol = rtol;
    opt.stepper.atol = set.integration.stepper.atol * (rtol / final_rtol);
    try {
      f = flow_and_monodromy(sys, s, t0, t1, opt);
      res = residual_of(s, f->end);
      if (!std::isfinite(res)) f.reset();
    } catch (const numerical_error& e) {
      out.failure = e.what();
    }
    if (!f || !(res < best_res)) {
      // Worse than the best point: a shorter step from it.
      if (!at_best || damping < 1.0 / 64.0) {
        if (out.failure.empty()) out.failure = "Newton's steps stopped reducing the residual (" + (format_digits(best_res, 3) + " m") + ")";
        break;
      }
      damping *= 0.5;
      for (int i = 0; i < n; ++i) s[static_cast<std::size_t>(i)] = best[static_cast<std::size_t>(i)] + damping * step[i];
      admissible(s);
      continue;
    }
    best = s;
    best_res = res;
    at_best = f;
    out.failure.clear();
    if (coarse) {
      const double relative = res / orbit_size(s);
      rtol = std::clamp(shooting_settings::kInexactRtolFactor * relative * relative, final_rtol, rtol);
      if (res <= set.tolerance) {
        // Converged to a coarse evaluation's accuracy: the same point again, at the tolerance.
        rtol = final_rtol;
        best_res = std::numeric_limits<double>::infinity();
        continue;
      }
    }
    if (res <= set.tolerance) {
      out.converged = true;
      break;
    }
    // (M - I) step = -(P(s) - s) on the moving states.
    dyn_matrix A = f->monodromy.topLeftCorner(n, n) - dyn_matrix::Identity(n, n);
    dyn_vector r(n);
    for (int i = 0; i < n; ++i) r[i] = f->end[static_cast<std::size_t>(i)] - s[static_cast<std::size_t>(i)];
    const Eigen::FullPivLU<dyn_matrix> lu(A);
    if (!lu.isInvertible()) {
      out.failure = "a Floquet multiplier is 1: the periodic orbit is not isolated";
      break;
    }
    step = lu.solve(-r);
    damping = 1.0;
    for (int i = 0; i < n; ++i) s[static_cast<std::size_t>(i)] += step[i];
    admissible(s);
  }
  out.state = best;
  out.residual = best_res;
  if (at_best) {
    out.monodromy = at_best->monodromy;
    out.events_per_period = at_best->counts.events;
    const Eigen::EigenSolver<dyn_matrix> eig(at_best->monodromy.topLeftCorner(n, n), false);
    for (int i = 0; i < n; ++i) out.multipliers.push_back(eig.eigenvalues()[i]);
    std::sort(out.multipliers.begin(), out.multipliers.end(),
              [](const auto& a, const auto& b) { return std::abs(a) > std::abs(b); });
  }
  if (!out.converged && out.failure.empty())
    out.failure = "no convergence in " + std::to_string(set.max_iterations) + " Newton iterations (residual " + (format_digits(best_res, 3) + " m") + ")";
  return out;
}

// The exact sensitivity of a periodic orbit to a model parameter, by the implicit-function theorem
// on its fixed point s* = P(s*, lambda) at t0: (I - M) ds*/dlambda = dP/dlambda, with M the
// monodromy and dP/dlambda from the parameter's variational equations (saltation at every event,
// the map's end moving with n T(lambda): map_and_sensitivities). One flow per parameter, in place
// of a shooting per finite-difference step, and exact to the integrator's accuracy. The rows of
// states the flow holds fixed (a rigid stator's) are zero. At a fold or a period-doubling's
// neighbour (a multiplier at 1: I - M singular) the orbit has no sensitivity: numerical_error.
template <int N>
struct orbit_sensitivity {
  Eigen::Matrix<double, N, 1> state = Eigen::Matrix<double, N, 1>::Zero();  // d s*(t0) / d lambda
  double condition = 0.0;  // reciprocal condition estimate of (I - M) on the moving states
};

template <parameter_differentiable_system System>
orbit_sensitivity<static_cast<int>(std::tuple_size_v<state_of<System>>)> periodic_orbit_sensitivity(
    const System& sys, const periodic_orbit<static_cast<int>(std::tuple_size_v<state_of<System>>)>& orbit, model_parameter parameter,
    const integration_options& opt) {
  constexpr int N = static_cast<int>(std::tuple_size_v<state_of<System>>);
  // Below this reciprocal condition of I - M a multiplier lies at 1 to the monodromy's own accuracy
  // (~1e-9, steppers.hpp): the fixed point does not move smoothly with the parameter there.
  constexpr double kMinCondition = 1e-8;
  using dyn_matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, N, N>;
  using dyn_vector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, N, 1>;
  if (!orbit.converged) throw numerical_error("orbit sensitivity: the orbit did not converge (" + orbit.failure + ")");
  const auto map = map_and_sensitivities(sys, orbit.state, orbit.t0, orbit.periods, parameter, opt);
  const int n = moving_states(sys);
  const dyn_matrix A = dyn_matrix::Identity(n, n) - map.monodromy.topLeftCorner(n, n);
  const Eigen::PartialPivLU<dyn_matrix> lu(A);
  orbit_sensitivity<N> out;
  out.condition = lu.rcond();
  if (!(out.condition > kMinCondition))
    throw numerical_error("orbit sensitivity: I - M is singular (reciprocal condition " + format_digits(out.condition, 3) +
                          "): a multiplier at 1, where the orbit does not move smoothly with the parameter");
  const dyn_vector x = lu.solve(dyn_vector(map.parameter.head(n)));
  out.state.head(n) = x;
  return out;
}

// The rotor models' sensitivities and shooting are compiled once, in
// ref/integrate/instances_shooting.cpp (see RUBREF_INTEGRATOR_INSTANCE).
#define RUBREF_SHOOTING_INSTANCE(PREFIX, SYSTEM)                                                                             \
  RUBREF_INTEGRATOR_INSTANCE(PREFIX, sensitivity_system<SYSTEM>)                                                            \
  PREFIX template flow_with_monodromy<SYSTEM::N> flow_and_monodromy<SYSTEM>(const SYSTEM&, const state_of<SYSTEM>&, double,   \
                                                                            double, const integration_options&);           \
  PREFIX template periodic_orbit<SYSTEM::N> shoot_periodic_orbit<SYSTEM>(const SYSTEM&, const state_of<SYSTEM>&, double, int, \
                                                                         const shooting_settings&);
// The paper's models' parameter sensitivities (continuation), in
// ref/integrate/instances_parameter_sensitivity.cpp.
#define RUBREF_PARAMETER_SENSITIVITY_INSTANCE(PREFIX, SYSTEM)                                                                  \
  RUBREF_INTEGRATOR_INSTANCE(PREFIX, parameter_sensitivity_system<SYSTEM>)                                                    \
  PREFIX template map_with_sensitivities<SYSTEM::N> map_and_sensitivities<SYSTEM>(const SYSTEM&, const state_of<SYSTEM>&, double, int, \
                                                                                  model_parameter, const integration_options&);
#define RUBREF_EXTERN_MODEL_SHOOTING(LAW) RUBREF_SHOOTING_INSTANCE(extern, rotor_system<LAW>)
#define RUBREF_EXTERN_EFFECTS_SHOOTING(LAW) RUBREF_SHOOTING_INSTANCE(extern, rotor_with_effects<LAW>)
#define RUBREF_EXTERN_PARAMETER_SENSITIVITY(LAW) RUBREF_PARAMETER_SENSITIVITY_INSTANCE(extern, rotor_system<LAW>)
RUBREF_FOR_EACH_VARIANT(RUBREF_EXTERN_MODEL_SHOOTING)
RUBREF_FOR_EACH_COMPLIANT_VARIANT(RUBREF_EXTERN_EFFECTS_SHOOTING)
RUBREF_FOR_EACH_VARIANT(RUBREF_EXTERN_PARAMETER_SENSITIVITY)
#undef RUBREF_EXTERN_MODEL_SHOOTING
#undef RUBREF_EXTERN_EFFECTS_SHOOTING
#undef RUBREF_EXTERN_PARAMETER_SENSITIVITY

}  // namespace rubref
