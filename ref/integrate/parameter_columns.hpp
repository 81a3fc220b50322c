#pragma once
// A periodic orbit's sensitivities to several parameters at once (docs/loop.md, "Exact
// sensitivities"): what a fit's Jacobian needs, from one flow instead of one shooting per
// coordinate.
//
// The orbit s*(lambda) is a fixed point of the n-revolution map P at t0, s* = P(s*, lambda). The
// implicit-function theorem gives (I - M) ds*/dlambda = dP/dlambda, M the monodromy; along the
// orbit, ds(t)/dlambda = Phi(t) ds*/dlambda + q(t), with Phi(t) = ds(t)/ds(t0) and q(t) = ds(t)/dlambda
// from s(t0) held, q(t0) = 0. Both come from one flow of s, Phi and P parameter columns q_j:
//  - Phi' = J(s) Phi and q_j' = J(s) q_j + df/dlambda_j (s, t), the variational equations;
//  - at each event, the saltation of ref/integrate/shooting.hpp: Phi+ = S Phi, and for a column
//    q+ = S q- + (f+ - f-) z_lambda / (g . f-), z_lambda the penetration's own derivative at s (the
//    contact angle turns the normal); compliant laws only (no reset map).
// df/dlambda_j and z_lambda are differences of the model's own vector field and penetration at
// the same state and time, between copies of the model moved to either side in the parameter
// (central differences; one-sided at a bound): no orbit is shot at the moved points, so the
// difference carries no integration error, only the vector field's curvature in the parameter
// (~1e-8 of the column at the loop's steps) and its rounding. Free arcs are in closed form
// (columns_free_flight, below).

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "ref/base/errors.hpp"
#include "ref/integrate/shooting.hpp"

namespace rubref {

// The closed-form free flight of s, Phi and the columns (ref/model/free_flight.hpp). Out of contact
// q_j' = A q_j + dA/dlambda_j s + db/dlambda_j + dF/dlambda_j(t), whose solution from q_j(t0) is
// e^{A tau} q_j(t0) plus the derivative of the free flight from s(t0) held: that derivative is the
// difference of the moved models' own free flights from the same state, each in closed form (no
// integration error: the difference's own, as the vector field's above; and the arc's events are
// the base's, as the shooting's).
template <int N, int P>
class columns_free_flight {
 public:
  static constexpr int C = N + P;
  using state = std::array<double, N + N * C>;
  using columns = Eigen::Matrix<double, N, C>;
  columns_free_flight(const linear_dynamics<N>& d, const std::vector<linear_dynamics<N>>& up, const std::vector<linear_dynamics<N>>& down,
                      std::vector<double> span)
      : ff_(d), span_(std::move(span)) {
    // A parameter that does not enter the free flight (the law's, friction, the contact's angle:
    // they move the normal, not the flow) has no free-flight source: its two flights would be the
    // same bits, and their difference exactly 0, so they are not made.
    const auto same_flow = [](const linear_dynamics<N>& a, const linear_dynamics<N>& b) {
      return a.A == b.A && a.b == b.b && a.F[0] == b.F[0] && a.F[1] == b.F[1] && a.omega == b.omega;
    };
    up_.reserve(up.size());
    down_.reserve(down.size());
    for (std::size_t j = 0; j < up.size(); ++j)
      if (!same_flow(up[j], down[j])) {
        sourced_.push_back(j);
        up_.emplace_back(up[j]);
        down_.emplace_back(down[j]);
      }
  }

  class arc : public augmented_arc_base<N> {
   public:
    arc(const columns_free_flight& owner, double t0, const state& a)
        : augmented_arc_base<N>(owner.ff_, t0, a), owner_(&owner), t0_(t0), cols0_(Eigen::Map<const columns>(a.data() + N)) {
      const std::array<double, N> s0 = this->head(a);
      up_.reserve(owner.up_.size());
      down_.reserve(owner.down_.size());
      for (const auto& f : owner.up_) up_.push_back(f.from(t0, s0));
      for (const auto& f : owner.down_) down_.push_back(f.from(t0, s0));
    }
    state at(double t) const {
      const auto s = this->base_.at(t);
      state a{};
      std::copy(s.begin(), s.end(), a.begin());
      Eigen::Map<columns> cols(a.data() + N);
      cols.noalias() = owner_->ff_.transition(t - t0_) * cols0_;
      for (std::size_t k = 0; k < up_.size(); ++k) {
        const std::size_t j = owner_->sourced_[k];
        const auto su = up_[k].at(t), sd = down_[k].at(t);
        for (int i = 0; i < N; ++i)
          cols(i, N + static_cast<Eigen::Index>(j)) += (su[static_cast<std::size_t>(i)] - sd[static_cast<std::size_t>(i)]) / owner_->span_[j];
      }
      return a;
    }

   private:
    const columns_free_flight* owner_;
    std::vector<typename free_flight<N>::arc> up_, down_;
    double t0_;
    columns cols0_;
  };

  arc from(double t0, const state& a) const { return arc(*this, t0, a); }

 private:
  free_flight<N> ff_;
  std::vector<std::size_t> sourced_;       // the columns whose parameter enters the free flight
  std::vector<free_flight<N>> up_, down_;  // theirs (reserved: the arcs point at them)
  std::vector<double> span_;
};

// The flow of s, Phi (N x N) and P parameter columns (N x P) as one ContactSystem of
// N + N (N + P) states (Phi, then the columns, column-major after s). Columns past `up`'s size
// stay zero.
template <differentiable_system System, int P>
  requires(System::compliant)
class parameter_columns_system {
 public:
  static constexpr int N = static_cast<int>(std::tuple_size_v<state_of<System>>);
  static constexpr int C = N + P;
  using base_state = state_of<System>;
  using state_type = std::array<double, N + N * C>;
  static constexpr bool compliant = true;

  // `up[j]` and `down[j]` are `sys` with parameter j moved to either side of it (or one of them
  // `sys` itself) by `span[j]` in all: column j's source is their difference over it.
  parameter_columns_system(const System& sys, std::vector<System> up, std::vector<System> down, std::vector<double> span)
      : sys_(sys), up_(std::move(up)), down_(std::move(down)), span_(std::move(span)) {
    if (up_.size() > static_cast<std::size_t>(P) || up_.size() != down_.size() || up_.size() != span_.size())
      throw numerical_error("parameter columns: " + std::to_string(up_.size()) + " moved models for " + std::to_string(P) + " columns");
    for (const double h : span_)
      if (!(std::isfinite(h) && h > 0.0)) throw numerical_error("parameter columns: a span of " + format_digits(h, 3));
  }

  void operator()(const state_type& a, state_type& da, double t) const {
    const base_state s = head(a);
    base_state ds{};
    sys_(s, ds, t);
    std::copy(ds.begin(), ds.end(), da.begin());
    const auto J = sys_.jacobian(s);  // row-major
    const Eigen::Map<const Eigen::Matrix<double, N, N, Eigen::RowMajor>> Jm(J.data());
    const Eigen::Map<const Eigen::Matrix<double, N, C>> cols(a.data() + N);
    Eigen::Map<Eigen::Matrix<double, N, C>> dcols(da.data() + N);
    dcols.noalias() = Jm * cols;
    for (std::size_t j = 0; j < up_.size(); ++j) {
      base_state fu{}, fd{};
      up_[j](s, fu, t);
      down_[j](s, fd, t);
      dcols.col(N + static_cast<Eigen::Index>(j)) +=
          (Eigen::Map<const Eigen::Matrix<double, N, 1>>(fu.data()) - Eigen::Map<const Eigen::Matrix<double, N, 1>>(fd.data())) / span_[j];
    }
  }

  contact_phase phase() const noexcept { return sys_.phase(); }
  parameter_columns_system with_phase(contact_phase ph) const {
    parameter_columns_system copy = *this;
    copy.sys_ = sys_.with_phase(ph);
    for (auto& m : copy.up_) m = m.with_phase(ph);
    for (auto& m : copy.down_) m = m.with_phase(ph);
    return copy;
  }
  double penetration(const state_type& a) const noexcept { return sys_.penetration(head(a)); }
  double penetration_rate(const state_type& a) const noexcept { return sys_.penetration_rate(head(a)); }
  double period() const noexcept { return sys_.period(); }
  double clearance() const noexcept { return sys_.clearance(); }
  double omega() const noexcept { return sys_.omega(); }

  // The closed-form free flight of every part, where the model's and every moved model's is linear.
  std::optional<columns_free_flight<N, P>> free_flight_propagator() const {
    if constexpr (linear_free_flight<System>) {
      const auto d = sys_.free_dynamics();
      if (!d) return std::nullopt;
      std::vector<linear_dynamics<N>> up, down;
      for (std::size_t j = 0; j < up_.size(); ++j) {
        auto u = up_[j].free_dynamics(), v = down_[j].free_dynamics();
        if (!u || !v) return std::nullopt;
        up.push_back(std::move(*u));
        down.push_back(std::move(*v));
      }
      return columns_free_flight<N, P>(*d, up, down, span_);
    }
    return std::nullopt;
  }

  // Phi and the columns across an event (top of this file); `before` is the system of the phase
  // that ended, `pre` == `post` (no reset for a compliant law).
  state_type after_event(const parameter_columns_system& before, event_kind, double t, const state_type& pre, const state_type& post) const {
    const base_state s = head(pre);
    base_state fm{}, fp{};
    before.sys_(s, fm, t);
    sys_(head(post), fp, t);
    const base_state g = sys_.penetration_gradient();
    const saltation<N> sal = saltation_at<N>(fm, fp, g, square_matrix<N>::Identity(), t);
    // S as I + jump g^T (the form these columns were measured with; the same S to rounding).
    const Eigen::Matrix<double, N, 1> jump = sal.difference / sal.denominator;
    const square_matrix<N> S = square_matrix<N>::Identity() + jump * Eigen::Map<const Eigen::Matrix<double, N, 1>>(g.data()).transpose();
    state_type a = post;
    Eigen::Map<Eigen::Matrix<double, N, C>> cols(a.data() + N);
    cols.noalias() = S * Eigen::Map<const Eigen::Matrix<double, N, C>>(pre.data() + N);
    for (std::size_t j = 0; j < up_.size(); ++j)
      cols.col(N + static_cast<Eigen::Index>(j)) += jump * ((up_[j].penetration(s) - down_[j].penetration(s)) / span_[j]);
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
  std::vector<System> up_, down_;
  std::vector<double> span_;
};

// ds(t_i)/dlambda_j on a periodic orbit, at each time of a grid over one period, and at t0.
template <int N, int P>
struct orbit_columns {
  Eigen::Matrix<double, N, P> start = Eigen::Matrix<double, N, P>::Zero();  // ds*(t0)/dlambda
  std::vector<Eigen::Matrix<double, N, P>> at;                              // per grid time
  double condition = 0.0;  // reciprocal condition estimate of I - M on the moving states
};

namespace detail {
template <class State>
struct augmented_recorder {
  std::vector<State>* out;
  template <class System>
  void on_sample(double, const State& s, const System&) {
    out->push_back(s);
  }
  template <class Event>
  void on_event(const Event&) {}
};
}  // namespace detail

// The columns of the periodic orbit through s_star at t0 (converged by the shooting: `tolerance`
// is its closure, m) over `periods` revolutions, read on `grid` (times in [t0, t0 + n T)).
// numerical_error where the flow does not close on s_star within kClosure tolerances (the
// stepped flow took another event sequence than the shooting's, a grazing contact between
// them), where I - M is singular (a multiplier at 1: no smooth sensitivity), or where the grid
// was not all read.
template <differentiable_system System, int P>
orbit_columns<static_cast<int>(std::tuple_size_v<state_of<System>>), P> periodic_orbit_columns(
    const parameter_columns_system<System, P>& aug, const state_of<System>& s_star, double t0, int periods, const integration_options& opt,
    const sample_grid& grid, double tolerance) {
  constexpr int N = static_cast<int>(std::tuple_size_v<state_of<System>>);
  // A closure within a thousand of the shooting's tolerance (1e-9 m at its 1e-12 m) is the same
  // orbit to ~1e-5 of a 0.1 mm orbit: the sensitivities are then as good as the Jacobian needs.
  constexpr double kClosure = 1e3;
  // Below this reciprocal condition of I - M a multiplier lies at 1 to the monodromy's accuracy
  // (periodic_orbit_sensitivity's bound, shooting.hpp).
  constexpr double kMinCondition = 1e-8;
  using augmented = parameter_columns_system<System, P>;
  using dyn_matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, N, N>;
  const System& sys = aug.model();
  typename augmented::state_type a{};
  std::copy(s_star.begin(), s_star.end(), a.begin());
  for (int i = 0; i < N; ++i) a[static_cast<std::size_t>(N + i * N + i)] = 1.0;  // Phi(t0) = I, q(t0) = 0
  std::vector<typename augmented::state_type> samples;
  samples.reserve(grid.count);
  detail::augmented_recorder<typename augmented::state_type> rec{&samples};
  const double t1 = t0 + periods * sys.period();
  const auto start = start_state(sys, s_star, t0);
  const auto end = integrate_hybrid(aug, basic_hybrid_state<typename augmented::state_type>{a, t0, start.phase, start.episode_peak}, t1, opt,
                                    grid, rec);
  if (samples.size() != grid.count) throw numerical_error("orbit columns: the flow read " + std::to_string(samples.size()) + " of " + std::to_string(grid.count) + " grid times");
  const int n = moving_states(sys);
  // The closure, scaled as the shooting's: velocities over a radian of the shaft.
  double closure = 0.0;
  for (int i = 0; i < n; ++i) {
    const double scale = i == idx::vx || i == idx::vy || i == N - 1 ? 1.0 / std::abs(sys.omega()) : 1.0;
    closure = std::max(closure, std::abs(end.s[static_cast<std::size_t>(i)] - s_star[static_cast<std::size_t>(i)]) * scale);
  }
  if (!(closure <= kClosure * tolerance))
    throw numerical_error("orbit columns: the flow closes " + format_digits(closure, 3) + " m from the shot orbit");
  const Eigen::Map<const Eigen::Matrix<double, N, N + P>> cols(end.s.data() + N);
  const dyn_matrix A = dyn_matrix::Identity(n, n) - cols.topLeftCorner(n, n);
  const Eigen::PartialPivLU<dyn_matrix> lu(A);
  orbit_columns<N, P> out;
  out.condition = lu.rcond();
  if (!(out.condition > kMinCondition))
    throw numerical_error("orbit columns: I - M is singular (reciprocal condition " + format_digits(out.condition, 3) + ")");
  out.start.topRows(n) = lu.solve(cols.block(0, N, n, P));
  out.at.reserve(samples.size());
  for (const auto& s : samples) {
    const Eigen::Map<const Eigen::Matrix<double, N, N + P>> c(s.data() + N);
    out.at.push_back(c.template leftCols<N>() * out.start + c.template rightCols<P>());
  }
  return out;
}

// The fits' flows: a model with effects under a compliant law, eight columns a flow (the loop's
// predictor and the tables' rub fit), compiled once in ref/integrate/instances_parameter_columns.cpp.
inline constexpr int kFitColumnsPerFlow = 8;
template <compliant_law Law>
using fit_columns_system = parameter_columns_system<rotor_with_effects<Law>, kFitColumnsPerFlow>;
#define RUBREF_PARAMETER_COLUMNS_INSTANCE(PREFIX, LAW) RUBREF_INTEGRATOR_INSTANCE(PREFIX, fit_columns_system<LAW>)
#define RUBREF_EXTERN_PARAMETER_COLUMNS(LAW) RUBREF_PARAMETER_COLUMNS_INSTANCE(extern, LAW)
RUBREF_FOR_EACH_COMPLIANT_VARIANT(RUBREF_EXTERN_PARAMETER_COLUMNS)
#undef RUBREF_EXTERN_PARAMETER_COLUMNS

}  // namespace rubref
