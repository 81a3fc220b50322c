#include "ref/tracking/least_squares.hpp"

#include <algorithm>
#include <cmath>

namespace rubref {

std::vector<double> levenberg_marquardt(const least_squares_problem& problem, std::vector<double> th, int max_iterations) {
  th = problem.clamp(std::move(th));
  Eigen::VectorXd r = problem.residuals(th);
  double c = r.squaredNorm();
  if (!std::isfinite(c)) return th;
  double lambda = 1e-3;
  for (int it = 0; it < max_iterations; ++it) {
    const Eigen::MatrixXd j = problem.jacobian(th, r);
    const Eigen::MatrixXd jtj = j.transpose() * j;
    const Eigen::VectorXd g = j.transpose() * r;
    bool accepted = false;
    while (lambda < 1e12) {
      Eigen::MatrixXd a = jtj;
      for (Eigen::Index d = 0; d < a.rows(); ++d) a(d, d) += lambda * std::max(jtj(d, d), 1e-12);
      const Eigen::VectorXd step = a.ldlt().solve(-g);
      std::vector<double> next = th;
      for (std::size_t k = 0; k < th.size(); ++k) next[k] += step(static_cast<Eigen::Index>(k));
      next = problem.clamp(next);
      const Eigen::VectorXd rn = problem.residuals(next);
      const double cn = rn.squaredNorm();
      if (std::isfinite(cn) && cn < c) {
        const double gain = (c - cn) / c;
        th = next, r = rn;
        lambda = std::max(lambda / 3.0, 1e-9);
        accepted = true;
        c = cn;
        if (gain < 1e-12) return th;
        break;
      }
      lambda *= 4.0;
    }
    if (!accepted) break;
  }
  return th;
}

coordinate_covariance covariance_of(const Eigen::MatrixXd& jf, double scale) {
  const auto parameters = jf.cols();
  Eigen::VectorXd norm = jf.colwise().norm().transpose();
  for (Eigen::Index k = 0; k < norm.size(); ++k)
    if (!(norm(k) > 0.0)) norm(k) = 1.0;
  const Eigen::MatrixXd js = jf * norm.cwiseInverse().asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(js.transpose() * js);
  const double largest = eig.eigenvalues().maxCoeff();
  const Eigen::MatrixXd& v = eig.eigenvectors();
  coordinate_covariance out{Eigen::MatrixXd::Zero(parameters, parameters), std::vector<bool>(static_cast<std::size_t>(parameters), false)};
  for (Eigen::Index i = 0; i < eig.eigenvalues().size(); ++i) {
    if (!(eig.eigenvalues()(i) > 1e-12 * largest)) {
      for (Eigen::Index k = 0; k < parameters; ++k)
        if (std::abs(v(k, i)) > 1e-6) out.unbounded[static_cast<std::size_t>(k)] = true;
      continue;
    }
    out.cov += scale / eig.eigenvalues()(i) * v.col(i) * v.col(i).transpose();
  }
  out.cov = norm.cwiseInverse().asDiagonal() * out.cov * norm.cwiseInverse().asDiagonal();
  return out;
}

}  // namespace rubref
