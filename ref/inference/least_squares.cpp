#include "ref/inference/least_squares.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "ref/base/errors.hpp"

namespace rubref {

namespace {
// Marquardt's damping: the first value (relative to the diagonal of J'J), and where it is so
// large that no step of useful size is left.
constexpr double kFirstDamping = 1e-3;
constexpr double kMaxDamping = 1e12;
// A diagonal entry of J'J below this share of the largest is floored there: a coordinate the
// residuals do not feel would otherwise get an undamped (infinite) step.
constexpr double kDiagonalFloor = 1e-12;
// A step this small against the coordinates (relative) cannot change the residual at all.
constexpr double kSmallestStep = 1e-14;
// Eigen-directions of the column-normalised J'J below this share of the largest carry no
// information at double precision (the squared condition number's limit, 1e-16, with margin
// for the Jacobian's own finite-difference error); a column with a component above
// kUnconstrainedShare in one is unconstrained.
constexpr double kUnconstrainedEigenvalue = 1e-12;
constexpr double kUnconstrainedShare = 1e-6;

bool finite(const std::optional<Eigen::VectorXd>& r) { return r && r->allFinite(); }

// The decrease of |r|^2 that the next Levenberg-Marquardt step from u predicts (Jacobian J, the
// fit's last damping), over the coordinates the bounds leave free (one at a bound whose descent
// points out of the box is held): -(2 g's + s'As) for s = -(A + damping D)^-1 g, A = J'J, g = J'r,
// D = diag(A) (floored as the steps'). The damping is where the solver trusts its linear model: an
// undamped Gauss-Newton prediction on a strongly nonlinear residual promises gains no step reaches.
double predicted_decrease(const least_squares_problem& problem, const Eigen::MatrixXd& J, const Eigen::VectorXd& r, const Eigen::VectorXd& u,
                          double damping) {
  if (J.cols() == 0 || J.rows() != r.size()) return 0.0;
  const Eigen::VectorXd g = J.transpose() * r;
  std::vector<Eigen::Index> free;
  for (Eigen::Index j = 0; j < u.size(); ++j) {
    const bool held_low = problem.lower.size() == u.size() && u[j] <= problem.lower[j] && g[j] > 0.0;
    const bool held_high = problem.upper.size() == u.size() && u[j] >= problem.upper[j] && g[j] < 0.0;
    if (!held_low && !held_high) free.push_back(j);
  }
  if (free.empty()) return 0.0;
  const auto k = static_cast<Eigen::Index>(free.size());
  const Eigen::MatrixXd JtJ = J.transpose() * J;
  Eigen::MatrixXd A(k, k);
  Eigen::VectorXd gf(k);
  for (Eigen::Index a = 0; a < k; ++a) {
    gf[a] = g[free[static_cast<std::size_t>(a)]];
    for (Eigen::Index b = 0; b < k; ++b) A(a, b) = JtJ(free[static_cast<std::size_t>(a)], free[static_cast<std::size_t>(b)]);
  }
  const Eigen::VectorXd d = A.diagonal().cwiseMax(kDiagonalFloor * std::max(A.diagonal().maxCoeff(), 1e-300));
  Eigen::MatrixXd M = A;
  // At least kUnconstrainedEigenvalue of damping: a direction the residuals do not feel predicts nothing.
  M.diagonal() += std::max(damping, kUnconstrainedEigenvalue) * d;
  const Eigen::VectorXd step = -M.ldlt().solve(gf);
  const double decrease = -(2.0 * gf.dot(step) + step.dot(A * step));
  return std::isfinite(decrease) ? std::max(decrease, 0.0) : std::numeric_limits<double>::infinity();
}
}  // namespace

void least_squares_options::validate() const {
  check({"least_squares", "max_jacobians"}, max_jacobians);
  check({"least_squares", "steps_per_jacobian"}, steps_per_jacobian);
  check({"least_squares", "difference_step"}, difference_step);
  check({"least_squares", "min_gain"}, min_gain);
  check({"least_squares", "min_gain_share"}, min_gain_share);
}

Eigen::VectorXd least_squares_problem::feasible(Eigen::VectorXd u) const {
  if (lower.size() == u.size()) u = u.cwiseMax(lower);
  if (upper.size() == u.size()) u = u.cwiseMin(upper);
  return u;
}

Eigen::MatrixXd forward_difference_jacobian(const least_squares_problem& problem, const Eigen::VectorXd& u, const Eigen::VectorXd& r0,
                                            double step, int* evaluations) {
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(r0.size(), u.size());
  for (Eigen::Index j = 0; j < u.size(); ++j) {
    const double h = step * std::max(1.0, std::abs(u[j]));
    for (const double signed_h : {h, -h}) {
      Eigen::VectorXd v = u;
      v[j] += signed_h;
      const auto r = problem.residuals(v);
      if (evaluations) ++*evaluations;
      if (finite(r) && r->size() == r0.size()) {
        J.col(j) = (*r - r0) / signed_h;
        break;
      }
    }
  }
  return J;
}

least_squares_result solve_least_squares(const least_squares_problem& problem, const Eigen::VectorXd& start, const least_squares_options& o) {
  o.validate();
  if (!problem.residuals) throw input_error("least squares: the problem has no residuals");
  least_squares_result out;
  Eigen::VectorXd u = problem.feasible(start);
  out.u = u;
  auto r = problem.residuals(u);
  ++out.evaluations;
  if (!finite(r)) {
    out.status = "the start could not be evaluated";
    return out;
  }
  out.ok = true;
  out.cost = r->squaredNorm();
  const double chi2_unit = std::max(problem.noise * problem.noise, 1e-300);
  double damping = kFirstDamping, growth = 2.0;
  Eigen::MatrixXd J;
  bool fresh = false;
  int steps = 0;
  const auto refresh = [&] {
    J = problem.jacobian ? problem.jacobian(u, *r) : forward_difference_jacobian(problem, u, *r, o.difference_step, &out.evaluations);
    fresh = true;
    ++out.jacobians;
  };
  refresh();
  out.status = "stopped: the step budget is spent";
  while (steps < o.steps_per_jacobian * o.max_jacobians) {
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * *r;
    const Eigen::VectorXd d = A.diagonal().cwiseMax(kDiagonalFloor * std::max(A.diagonal().maxCoeff(), 1e-300));
    bool accepted = false;
    double gain = 0.0;
    while (damping < kMaxDamping) {
      Eigen::MatrixXd M = A;
      M.diagonal() += damping * d;
      const Eigen::VectorXd free_step = -M.ldlt().solve(g);
      if (!free_step.allFinite()) {
        damping *= growth, growth *= 2.0;
        continue;
      }
      // Projected onto the bounds: a coordinate at its bound that the step pushes further is held.
      const Eigen::VectorXd trial = problem.feasible(u + free_step);
      const Eigen::VectorXd step = trial - u;
      const auto rt = problem.residuals(trial);
      ++out.evaluations;
      const double predicted = step.dot(A * step) + 2.0 * damping * step.dot(d.cwiseProduct(step));
      if (!finite(rt) || rt->size() != r->size()) {
        ++out.rejected;
        damping *= growth, growth *= 2.0;
        if (!fresh) break;  // the carried Jacobian may have misled the step: a true one first
        continue;
      }
      const double cost = rt->squaredNorm();
      if (cost < out.cost) {
        const double rho = predicted > 0.0 ? (out.cost - cost) / predicted : 1.0;
        damping *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
        growth = 2.0;
        gain = (out.cost - cost) / chi2_unit;
        if (const double h = step.squaredNorm(); h > 0.0) J += ((*rt - *r) - J * step) * (step.transpose() / h);
        u = trial;
        r = rt;
        out.cost = cost;
        accepted = true;
        break;
      }
      damping *= growth, growth *= 2.0;
      if (!fresh) break;
      if (step.cwiseAbs().maxCoeff() < kSmallestStep * std::max(1.0, u.cwiseAbs().maxCoeff())) break;  // nothing left to gain
    }
    const bool settled = !accepted || gain < std::max(o.min_gain, o.min_gain_share * out.cost / chi2_unit);
    const bool from_fresh = fresh;  // the step (or its failure) came from a finite-difference Jacobian
    if (accepted) ++steps, fresh = false;
    if (settled) {
      if (from_fresh) {  // a true Jacobian agrees: done
        out.converged = true;
        out.status = accepted ? "converged: a step gains less than the tolerance" : "converged: no step lowers the residual";
        break;
      }
      if (out.jacobians >= o.max_jacobians) {
        out.status = "stopped: the Jacobian budget is spent";
        break;
      }
      refresh();
    } else if (!fresh && steps % o.steps_per_jacobian == 0) {
      if (out.jacobians >= o.max_jacobians) {
        out.status = "stopped: the Jacobian budget is spent";
        break;
      }
      refresh();  // the carried Jacobian drifts from the true one: renewed every few steps
    }
  }
  out.u = u;
  out.remaining = std::max(predicted_decrease(problem, J, *r, u, damping), std::max(o.min_gain * chi2_unit, o.min_gain_share * out.cost));
  out.r = std::move(*r);
  return out;
}

double cost_uncertainty(const Eigen::VectorXd& r, double remaining, double residual_error) {
  const double e = std::sqrt(static_cast<double>(r.size())) * residual_error;
  return remaining + 2.0 * r.norm() * e + e * e;
}

double correlation_factor(const Eigen::VectorXd& r, const std::vector<residual_series>& series, int lags) {
  if (series.empty() || lags < 1) return 1.0;
  std::vector<double> c(static_cast<std::size_t>(lags) + 1, 0.0);
  for (const auto& s : series)
    for (int k = 0; k <= lags; ++k)
      for (Eigen::Index i = 0; i + k < s.count; ++i) c[static_cast<std::size_t>(k)] += r[s.start + s.stride * i] * r[s.start + s.stride * (i + k)];
  double f = 1.0;
  for (int k = 1; k <= lags && c[0] > 0.0; ++k) f += 2.0 * c[static_cast<std::size_t>(k)] / c[0];
  return std::max(1.0, f);
}

double fit_covariance::standard_deviation(Eigen::Index k) const {
  const double v = cov(k, k);
  return unconstrained[static_cast<std::size_t>(k)] || !(v >= 0.0) || !std::isfinite(v) ? std::numeric_limits<double>::infinity() : std::sqrt(v);
}

double fit_covariance::standard_deviation_along(const Eigen::VectorXd& g) const {
  for (Eigen::Index k = 0; k < g.size(); ++k)
    if (g[k] != 0.0 && unconstrained[static_cast<std::size_t>(k)]) return std::numeric_limits<double>::infinity();
  const double v = g.dot(cov * g);
  return std::isfinite(v) ? std::sqrt(std::max(0.0, v)) : std::numeric_limits<double>::infinity();
}

fit_covariance covariance_of(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, double noise, const std::vector<residual_series>& series) {
  const auto columns = J.cols();
  fit_covariance out;
  out.cov = Eigen::MatrixXd::Zero(columns, columns);
  out.unconstrained.assign(static_cast<std::size_t>(columns), false);
  const double unit = std::max(noise, 1e-300);
  out.chi2 = r.squaredNorm() / (unit * unit);
  out.dof = static_cast<std::size_t>(std::max<Eigen::Index>(1, r.size() - columns));
  out.excess = std::max(1.0, out.chi2 / static_cast<double>(out.dof));
  out.correlation = correlation_factor(r, series, default_count_of("least_squares", "covariance_lags"));
  if (columns == 0) return out;
  Eigen::VectorXd norm = (J / unit).colwise().norm().transpose();
  for (Eigen::Index k = 0; k < norm.size(); ++k)
    if (!(norm(k) > 0.0) || !std::isfinite(norm(k))) norm(k) = 1.0;
  const Eigen::MatrixXd js = (J / unit) * norm.cwiseInverse().asDiagonal();
  if (!js.allFinite()) {
    out.unconstrained.assign(static_cast<std::size_t>(columns), true);
    return out;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(js.transpose() * js);
  const double largest = eig.eigenvalues().maxCoeff();
  const Eigen::MatrixXd& v = eig.eigenvectors();
  const double scale = out.excess * out.correlation;
  for (Eigen::Index i = 0; i < eig.eigenvalues().size(); ++i) {
    if (!(eig.eigenvalues()(i) > kUnconstrainedEigenvalue * largest)) {
      for (Eigen::Index k = 0; k < columns; ++k)
        if (std::abs(v(k, i)) > kUnconstrainedShare) out.unconstrained[static_cast<std::size_t>(k)] = true;
      continue;
    }
    out.cov += scale / eig.eigenvalues()(i) * v.col(i) * v.col(i).transpose();
  }
  out.cov = norm.cwiseInverse().asDiagonal() * out.cov * norm.cwiseInverse().asDiagonal();
  return out;
}

}  // namespace rubref
