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

// The closed-form free flight of the state and of Phi: Phi(t) = e^{A (t - t0)} Phi(t0).
template <int N>
class sensitivity_free_flight {
 public:
  using state = std::array<double, N + N * N>;
  explicit sensitivity_free_flight(const linear_dynamics<N>& d) : ff_(d) {}

  class arc {
   public:
    arc(const sensitivity_free_flight& owner, double t0, const state& a)
        : owner_(&owner), base_(owner.ff_.from(t0, head(a))), t0_(t0) {
      for (int c = 0; c < N; ++c)
        for (int r = 0; r < N; ++r) phi0_(r, c) = a[static_cast<std::size_t>(N + c * N + r)];
    }
    state at(double t) const {
      const auto s = base_.at(t);
      const square_matrix<N> phi = owner_->ff_.transition(t - t0_) * phi0_;
      state a{};
      std::copy(s.begin(), s.end(), a.begin());
      for (int c = 0; c < N; ++c)
        for (int r = 0; r < N; ++r) a[static_cast<std::size_t>(N + c * N + r)] = phi(r, c);
      return a;
    }
    std::optional<std::pair<double, double>> first_onset(double from, double t_end, double min_depth, double time_tol,
                                                         double window, std::size_t* steps = nullptr) const {
      return base_.first_onset(from, t_end, min_depth, time_tol, window, steps);
    }

   private:
    static std::array<double, N> head(const state& a) {
      std::array<double, N> s{};
      std::copy(a.begin(), a.begin() + N, s.begin());
      return s;
    }
    const sensitivity_free_flight* owner_;
    typename free_flight<N>::arc base_;
    double t0_;
    square_matrix<N> phi0_;
  };

  arc from(double t0, const state& a) const { return arc(*this, t0, a); }

 private:
  free_flight<N> ff_;
};

// The system's flow and its sensitivity Phi = ds(t)/ds(t0) as one ContactSystem of N + N^2 states
// (Phi column-major after s), so the hybrid integrator locates its events as it does the model's.
template <differentiable_system System>
class sensitivity_system {
 public:
  static constexpr int N = static_cast<int>(std::tuple_size_v<state_of<System>>);
  using base_state = state_of<System>;
  using state_type = std::array<double, N + N * N>;
  static constexpr bool compliant = System::compliant;

  explicit sensitivity_system(const System& sys) : sys_(sys) {}

  void operator()(const state_type& a, state_type& da, double t) const {
    const base_state s = head(a);
    base_state ds{};
    sys_(s, ds, t);
    std::copy(ds.begin(), ds.end(), da.begin());
    const auto J = sys_.jacobian(s);  // row-major
    const Eigen::Map<const Eigen::Matrix<double, N, N, Eigen::RowMajor>> Jm(J.data());
    const Eigen::Map<const square_matrix<N>> phi(a.data() + N);  // column-major after s
    Eigen::Map<square_matrix<N>>(da.data() + N).noalias() = Jm * phi;
  }

  contact_phase phase() const noexcept { return sys_.phase(); }
  sensitivity_system with_phase(contact_phase ph) const { return sensitivity_system(sys_.with_phase(ph)); }
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
  double free_vertical_jerk_stuck(double t) const noexcept
    requires requires(const System& s) { s.free_vertical_jerk_stuck(t); }
  {
    return sys_.free_vertical_jerk_stuck(t);
  }

  // The closed-form free flight of both parts, where the model's is linear.
  std::optional<sensitivity_free_flight<N>> free_flight_propagator() const {
    if constexpr (linear_free_flight<System>) {
      if (auto d = sys_.free_dynamics()) return sensitivity_free_flight<N>(*d);
    }
    return std::nullopt;
  }

  // Phi across an event: S Phi, S the saltation matrix (top of this file). `before` is the
  // system of the phase that ended, `pre` the state there before any reset, `post` after it.
  state_type after_event(const sensitivity_system& before, event_kind kind, double t, const state_type& pre,
                         const state_type& post) const {
    if (kind == event_kind::release) return post;  // f+ = f- at a release: S = I
    square_matrix<N> R = square_matrix<N>::Identity();
    if constexpr (!System::compliant) {
      if (kind == event_kind::impact) R(idx::vy, idx::vy) = sys_.law().rebound_slope(pre[idx::vy]);
      if (kind == event_kind::stick) R(idx::y, idx::y) = R(idx::vy, idx::vy) = 0.0;
    }
    base_state fm{}, fp{};
    before.sys_(head(pre), fm, t);
    sys_(head(post), fp, t);
    const base_state g = sys_.penetration_gradient();
    double denom = 0.0;
    for (int i = 0; i < N; ++i) denom += g[static_cast<std::size_t>(i)] * fm[static_cast<std::size_t>(i)];
    if (!(std::abs(denom) > 0.0))
      throw numerical_error("a grazing contact event (zero normal velocity) at t = " + std::to_string(t) +
                            " s: the saltation matrix is unbounded there");
    Eigen::Map<const Eigen::Matrix<double, N, 1>> fmv(fm.data()), fpv(fp.data()), gv(g.data());
    const square_matrix<N> S = R + (fpv - R * fmv) * gv.transpose() / denom;
    square_matrix<N> phi;
    for (int c = 0; c < N; ++c)
      for (int r = 0; r < N; ++r) phi(r, c) = pre[static_cast<std::size_t>(N + c * N + r)];
    const square_matrix<N> out = S * phi;
    state_type a = post;
    for (int c = 0; c < N; ++c)
      for (int r = 0; r < N; ++r) a[static_cast<std::size_t>(N + c * N + r)] = out(r, c);
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
  double tolerance = 1e-12;
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

// The rotor models' sensitivities and shooting are compiled once, in
// ref/integrate/instances_shooting.cpp (see RUBREF_INTEGRATOR_INSTANCE).
#define RUBREF_SHOOTING_INSTANCE(PREFIX, SYSTEM)                                                                             \
  RUBREF_INTEGRATOR_INSTANCE(PREFIX, sensitivity_system<SYSTEM>)                                                            \
  PREFIX template flow_with_monodromy<SYSTEM::N> flow_and_monodromy<SYSTEM>(const SYSTEM&, const state_of<SYSTEM>&, double,   \
                                                                            double, const integration_options&);           \
  PREFIX template periodic_orbit<SYSTEM::N> shoot_periodic_orbit<SYSTEM>(const SYSTEM&, const state_of<SYSTEM>&, double, int, \
                                                                         const shooting_settings&);
#define RUBREF_EXTERN_MODEL_SHOOTING(LAW) RUBREF_SHOOTING_INSTANCE(extern, rotor_system<LAW>)
#define RUBREF_EXTERN_EFFECTS_SHOOTING(LAW) RUBREF_SHOOTING_INSTANCE(extern, rotor_with_effects<LAW>)
RUBREF_FOR_EACH_VARIANT(RUBREF_EXTERN_MODEL_SHOOTING)
RUBREF_FOR_EACH_COMPLIANT_VARIANT(RUBREF_EXTERN_EFFECTS_SHOOTING)
#undef RUBREF_EXTERN_MODEL_SHOOTING
#undef RUBREF_EXTERN_EFFECTS_SHOOTING

}  // namespace rubref
