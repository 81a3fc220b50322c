#include "ref/tracking/two_x_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Dense>
#include <boost/math/distributions/chi_squared.hpp>

#include "ref/base/errors.hpp"

namespace rubref {

namespace {
using cplx = std::complex<double>;
constexpr double kRpmToRadS = 2.0 * std::numbers::pi / 60.0;
}  // namespace

std::vector<std::size_t> two_x_columns(const order_table& table, const response_fit& modes) {
  std::vector<std::size_t> out;
  for (const auto& probe : modes.probes) {
    const auto at = std::find_if(table.orders.begin(), table.orders.end(), [&](const tracked_order& o) { return o.order == 2 && o.probe == probe; });
    if (at == table.orders.end()) return {};
    out.push_back(static_cast<std::size_t>(at - table.orders.begin()));
  }
  return out;
}

std::vector<double> two_x_scatter_noise(const order_table& table, const response_fit& modes) {
  std::vector<double> out;
  for (const std::size_t o : two_x_columns(table, modes)) out.push_back(row_scatter_of(table.orders[o].vector));
  return out;
}

two_x_fit fit_two_x(const order_table& table, const response_fit& modes, bool misalignment, const two_x_options& options) {
  const std::vector<std::size_t> columns = two_x_columns(table, modes);
  if (columns.empty()) throw input_error(table.source + ": no 2X column (amp_2x, phase_2x) for every probe the 1X fit reads");
  two_x_fit f;
  f.misalignment = misalignment;
  f.probes = modes.probes;
  f.rows = options.rows;
  if (f.rows.empty())
    for (std::size_t i = 0; i < table.rows(); ++i) f.rows.push_back(i);
  const std::size_t probes = columns.size(), unknowns = 2 * (probes + (misalignment ? 1 : 0));
  if (!options.noise_m.empty() && options.noise_m.size() != probes) throw input_error("fit_two_x: one noise per probe");
  // Noise per probe, floored at the numbers' own precision (a noise-free table still weighs its rows).
  for (std::size_t p = 0; p < probes; ++p) {
    double largest = 0.0;
    for (const cplx& v : table.orders[columns[p]].vector) largest = std::max(largest, std::abs(v));
    f.noise_m.push_back(std::max(options.noise_m.empty() ? row_scatter_of(table.orders[columns[p]].vector) : options.noise_m[p], 1e-12 * largest));
    if (!(f.noise_m.back() > 0.0)) throw input_error(table.source + ": every 2X amplitude of " + table.orders[columns[p]].amplitude_column + " is 0: nothing to fit");
  }
  if (options.known && (options.known->size() != probes || std::any_of(options.known->begin(), options.known->end(), [&](const auto& v) { return v.size() != table.rows(); })))
    throw input_error("fit_two_x: the known 2X needs one value per probe and row");
  const auto known = [&](std::size_t p, std::size_t row) { return options.known ? (*options.known)[p][row] : cplx(0.0); };
  // The weighted real design: per probe and row, (Re, Im) of R2_p + a H_p(2w) (after the known 2X).
  const auto forced = [&](std::size_t p, std::size_t row) { return forward_force_response(modes, p, 2.0 * table.rpm[row] * kRpmToRadS); };
  const std::size_t m = 2 * probes * f.rows.size();
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(unknowns));
  Eigen::VectorXd b(static_cast<Eigen::Index>(m));
  for (std::size_t p = 0; p < probes; ++p)
    for (std::size_t i = 0; i < f.rows.size(); ++i) {
      const auto re = static_cast<Eigen::Index>(2 * (p * f.rows.size() + i)), im = re + 1;
      const double w = 1.0 / f.noise_m[p];
      const cplx d = table.orders[columns[p]].vector[f.rows[i]] - known(p, f.rows[i]);
      b(re) = w * d.real(), b(im) = w * d.imag();
      a(re, static_cast<Eigen::Index>(2 * p)) = w, a(im, static_cast<Eigen::Index>(2 * p + 1)) = w;
      if (misalignment) {
        const cplx h = forced(p, f.rows[i]);
        const auto c = static_cast<Eigen::Index>(2 * probes);
        a(re, c) = w * h.real(), a(re, c + 1) = -w * h.imag();
        a(im, c) = w * h.imag(), a(im, c + 1) = w * h.real();
      }
    }
  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> solver(a);
  const Eigen::VectorXd u = solver.solve(b);
  f.chi2 = (b - a * u).squaredNorm();
  f.parameters = unknowns;
  f.dof = m > unknowns ? m - unknowns : 1;
  const double ratio = f.chi2 / static_cast<double>(f.dof);
  // The covariance of the linear solve, scaled by chi^2/dof where the residual exceeds the noise;
  // a direction the rows do not constrain (rank deficient) gets an infinite variance.
  Eigen::MatrixXd cov = Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(unknowns), static_cast<Eigen::Index>(unknowns), std::numeric_limits<double>::infinity());
  if (solver.rank() == static_cast<Eigen::Index>(unknowns)) cov = (a.transpose() * a).inverse() * std::max(1.0, ratio);
  const auto amplitude = [&](std::size_t k) { return cplx(u(static_cast<Eigen::Index>(2 * k)), u(static_cast<Eigen::Index>(2 * k + 1))); };
  const auto polar = [&](std::size_t k) {
    const auto i = static_cast<Eigen::Index>(2 * k);
    return polar_estimate(amplitude(k), cov(i, i), cov(i + 1, i + 1), cov(i, i + 1));
  };
  for (std::size_t p = 0; p < probes; ++p) {
    const auto [r, phase] = polar(p);
    f.runout_m.push_back(r), f.runout_phase_deg.push_back(phase);
  }
  if (misalignment) std::tie(f.force_over_m, f.force_phase_deg) = polar(probes);
  const double chi2_bound = boost::math::quantile(boost::math::chi_squared(static_cast<double>(f.dof)), 0.999) / static_cast<double>(f.dof) - 1.0;
  f.chi2_bound = 1.0 + std::hypot(chi2_bound, 3.29 * 2.0 * options.noise_relative_error);
  f.consistent_with_noise = ratio <= f.chi2_bound;

  // The model and residual at every row; the parts' cancellation over the fitted rows.
  double parts_sq = 0.0, sum_sq = 0.0, sum2 = 0.0;
  f.model.assign(probes, {}), f.residual.assign(probes, {});
  for (std::size_t p = 0; p < probes; ++p)
    for (std::size_t i = 0; i < table.rows(); ++i) {
      const cplx runout = amplitude(p), response = misalignment ? amplitude(probes) * forced(p, i) : cplx(0.0);
      f.model[p].push_back(runout + response + known(p, i));
      f.residual[p].push_back(table.orders[columns[p]].vector[i] - f.model[p].back());
    }
  for (std::size_t p = 0; p < probes; ++p)
    for (const std::size_t i : f.rows) {
      const double size = std::abs(amplitude(p)) + (misalignment ? std::abs(amplitude(probes) * forced(p, i)) : 0.0) + std::abs(known(p, i));
      parts_sq += size * size, sum_sq += std::norm(f.model[p][i]), sum2 += std::norm(f.residual[p][i]);
    }
  f.cancellation = sum_sq > 0.0 ? std::sqrt(parts_sq / sum_sq) : 1.0;
  f.rms_residual_m = std::sqrt(sum2 / static_cast<double>(2 * probes * f.rows.size()));
  return f;
}

std::vector<double> two_x_residual_noise(const two_x_fit& fit) { return residual_noise(fit.residual, fit.rows, fit.parameters); }

}  // namespace rubref
