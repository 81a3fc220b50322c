#include "ref/identification/frols.hpp"

#include <boost/math/distributions/fisher_f.hpp>
#include <cmath>
#include <limits>

#include "ref/base/errors.hpp"
#include "ref/inference/evidence.hpp"

namespace rubref {

least_squares_fit least_squares(const Eigen::MatrixXd& P, const Eigen::VectorXd& y, const std::vector<std::size_t>& cols) {
  const Eigen::Index n = P.rows(), p = static_cast<Eigen::Index>(cols.size());
  least_squares_fit out;
  out.coefficients = Eigen::VectorXd::Zero(p);
  out.standard_errors = Eigen::VectorXd::Zero(p);
  out.residual = y;
  if (p == 0) return out;
  // Scale columns to unit norm: the candidates span many decades (z^4 ~ 1e-20, z_dot ~ 0.1).
  Eigen::MatrixXd A(n, p);
  Eigen::VectorXd scale(p);
  for (Eigen::Index j = 0; j < p; ++j) {
    scale[j] = P.col(static_cast<Eigen::Index>(cols[j])).norm();
    if (!(scale[j] > 0.0)) scale[j] = 1.0;
    A.col(j) = P.col(static_cast<Eigen::Index>(cols[j])) / scale[j];
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  const Eigen::VectorXd b = qr.solve(y);
  out.residual = y - A * b;
  const double dof = std::max<double>(1.0, static_cast<double>(n - p));
  const double sigma2 = out.residual.squaredNorm() / dof;
  // Cov(b) = sigma^2 (A'A)^-1, from the triangular factor: (A'A)^-1 = P R^-1 R^-T P'.
  const Eigen::MatrixXd R = qr.matrixR().topLeftCorner(p, p).triangularView<Eigen::Upper>();
  const Eigen::MatrixXd Rinv = R.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(p, p));
  const Eigen::MatrixXd cov_perm = Rinv * Rinv.transpose();
  const auto& perm = qr.colsPermutation();
  const Eigen::MatrixXd cov = perm * cov_perm * perm.transpose();
  for (Eigen::Index j = 0; j < p; ++j) {
    out.coefficients[j] = b[j] / scale[j];
    out.standard_errors[j] = std::sqrt(sigma2 * cov(j, j)) / scale[j];
  }
  return out;
}

std::vector<double> err_in_order(const Eigen::MatrixXd& P, const Eigen::VectorXd& y, const std::vector<std::size_t>& order) {
  const double yy = y.squaredNorm();
  std::vector<Eigen::VectorXd> basis;
  std::vector<double> out;
  for (const std::size_t j : order) {
    Eigen::VectorXd w = P.col(static_cast<Eigen::Index>(j));
    const double norm0 = w.norm();
    if (norm0 > 0.0) w /= norm0;
    for (int pass = 0; pass < 2; ++pass)
      for (const auto& q : basis) w -= q.dot(w) * q;
    const double ww = w.squaredNorm();
    out.push_back(ww > 1e-20 && yy > 0.0 ? std::pow(w.dot(y), 2) / (ww * yy) : 0.0);
    if (ww > 1e-20) basis.push_back(w / std::sqrt(ww));
  }
  return out;
}

frols_result frols(const Eigen::MatrixXd& P, const Eigen::VectorXd& y, const frols_settings& s) {
  const Eigen::Index n = P.rows(), m = P.cols();
  if (n <= m) throw input_error("FROLS needs more samples (" + std::to_string(n) + ") than candidate terms (" + std::to_string(m) + ")");
  const double yy = y.squaredNorm();
  if (!(yy > 0.0)) throw input_error("FROLS: the target (contact force) is zero at every sample");

  // Working copies with unit-norm columns; W holds each remaining candidate orthogonalised
  // against every selected one.
  Eigen::MatrixXd W(n, m);
  for (Eigen::Index j = 0; j < m; ++j) {
    const double norm = P.col(j).norm();
    W.col(j) = norm > 0.0 ? Eigen::VectorXd(P.col(j) / norm) : Eigen::VectorXd::Zero(n);
  }
  std::vector<bool> used(m, false);
  frols_result out;
  double err_sum = 0.0;
  // A remaining column shorter than this (of its unit original) lies in the span already chosen.
  constexpr double kDependentNorm = 1e-10;

  for (Eigen::Index step = 0; step < m; ++step) {
    Eigen::Index best = -1;
    double best_err = -1.0;
    for (Eigen::Index j = 0; j < m; ++j) {
      if (used[j]) continue;
      const double ww = W.col(j).squaredNorm();
      const double err = ww > kDependentNorm * kDependentNorm ? std::pow(W.col(j).dot(y), 2) / (ww * yy) : 0.0;
      if (err > best_err) {
        best_err = err;
        best = j;
      }
    }
    used[best] = true;
    err_sum += best_err;
    const double sse = std::max(yy * (1.0 - err_sum), std::numeric_limits<double>::min());
    const double k = static_cast<double>(step + 1);
    // Akaike's criterion (the user's choice, --stop aic) and the information criterion every wing
    // uses (ref/inference/evidence.hpp: BIC for Gaussian noise of estimated scale).
    out.order.push_back({static_cast<std::size_t>(best), best_err, err_sum, n * std::log(sse / n) + 2.0 * k,
                         information_criterion(sse, static_cast<double>(n), static_cast<std::size_t>(step + 1))});
    const double norm = W.col(best).norm();
    if (norm > kDependentNorm) {
      const Eigen::VectorXd q = W.col(best) / norm;
      for (Eigen::Index j = 0; j < m; ++j)
        if (!used[j])
          for (int pass = 0; pass < 2; ++pass) W.col(j) -= q.dot(W.col(j)) * q;  // MGS, twice
    }
  }

  // How many steps the stopping rule takes.
  std::size_t steps = out.order.size();
  if (s.stop == frols_stop::significance) {
    steps = 0;
    const double yy = y.squaredNorm();
    for (std::size_t i = 0; i < out.order.size(); ++i) {
      const double k = static_cast<double>(i + 1), dof = static_cast<double>(n) - k;
      if (!(dof >= 1.0) || out.order[i].err < s.err_floor) break;
      const double residual_variance = std::max(0.0, 1.0 - out.order[i].err_sum) * yy / dof;
      const double f = boost::math::quantile(boost::math::fisher_f(1.0, dof), 0.999);
      if (!(out.order[i].err * yy > f * std::max(s.noise_variance, residual_variance))) break;
      steps = i + 1;
    }
  } else if (s.stop == frols_stop::err_sum) {
    for (std::size_t i = 0; i < out.order.size(); ++i)
      if (1.0 - out.order[i].err_sum <= s.rho) {
        steps = i + 1;
        break;
      }
  } else {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < out.order.size(); ++i) {
      const double c = s.stop == frols_stop::aic ? out.order[i].aic : out.order[i].bic;
      if (c < best) {
        best = c;
        steps = i + 1;
      }
    }
  }
  out.steps_selected = steps;
  for (std::size_t i = 0; i < steps; ++i)
    if (s.stop == frols_stop::significance || out.order[i].err >= s.err_threshold) {
      out.kept.push_back(out.order[i].candidate);
      out.err_sum_kept += out.order[i].err;
    }
  const least_squares_fit fit = least_squares(P, y, out.kept);
  out.coefficients = fit.coefficients;
  out.standard_errors = fit.standard_errors;
  out.residual = fit.residual;
  return out;
}

void frols_settings::validate() const {
  check({"frols", "rho"}, rho);
  check({"frols", "err_threshold"}, err_threshold);
  check({"frols", "err_floor"}, err_floor);
}

}  // namespace rubref
