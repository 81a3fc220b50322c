// The error reduction ratio and FROLS (Eq. 3, Fig. 4, ref/identification/frols.hpp): bounds,
// completeness on noise-free data from a law in the library, and invariance to the scale of a
// regressor and to the units of z.

#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "props/generators.hpp"
#include "ref/identification/frols.hpp"
#include "ref/identification/term_library.hpp"

namespace rubref::props {
namespace {

// ERR = (w'y)^2 / (w'w y'y) <= 1 by Cauchy-Schwarz and the ERRs of orthogonal directions add up
// to at most 1; in floating point each is good to a few ulps times the number of terms.
constexpr double kErrRounding = 1e-12;
// Noise-free data from the library: every candidate taken, the target lies in their span. The
// Eq. 4 candidates z..z^4 are strongly collinear on (0, z_max] (condition ~1e4 after unit
// scaling), so what is left unexplained is rounding amplified by that: 1e-9 of y'y.
constexpr double kCompleteness = 1e-9;
// Rescaling a column changes FROLS only through rounding: ERRs agree to 1e-9, and coefficients
// to 1e-6 of the target measured by what they contribute, |d theta_j| |p_j| <= 1e-6 |y| (a kept
// term that is not in the law has a coefficient that is rounding, relative to nothing).
constexpr double kInvarianceErr = 1e-9;
constexpr double kInvarianceCoefficient = 1e-6;

// Random regressors of wildly different scales, and a random target.
struct regression {
  Eigen::MatrixXd P;
  Eigen::VectorXd y;
};

rc::Gen<regression> random_regression() {
  return rc::gen::mapcat(rc::gen::pair(rc::gen::inRange(1, 9), rc::gen::inRange(2, 150)), [](std::pair<int, int> mn) {
    const int m = mn.first, n = m + mn.second;
    return rc::gen::map(rc::gen::container<std::vector<double>>(static_cast<std::size_t>((m + 1) * n + m), uniform(-1.0, 1.0)),
                        [m, n](const std::vector<double>& v) {
                          regression r{Eigen::MatrixXd(n, m), Eigen::VectorXd(n)};
                          std::size_t k = 0;
                          for (int j = 0; j < m; ++j) {
                            const double scale = std::pow(10.0, 6.0 * v[k++]);  // 1e-6 .. 1e6
                            for (int i = 0; i < n; ++i) r.P(i, j) = scale * v[k++];
                          }
                          for (int i = 0; i < n; ++i) r.y[i] = v[k++];
                          return r;
                        });
  });
}

// Contact samples (z > 0, z_dot either way) and a normal force made exactly of some of the
// paper's candidate terms (Eq. 4, L = 4), each contributing a comparable share.
struct library_data {
  std::vector<double> z, z_dot;        // m, m/s
  std::vector<std::size_t> true_terms;  // indices into the library
  std::vector<double> coefficients;     // N per unit of each true term
};

rc::Gen<library_data> library_law() {
  const std::size_t terms = parse_library(kPaperLibrary).size();
  return rc::gen::apply(
      [terms](double z_max, double v_max, std::vector<std::pair<double, double>> points, std::vector<bool> pick,
              std::vector<double> weights) {
        library_data d;
        for (const auto& [a, b] : points) {
          d.z.push_back(z_max * a);
          d.z_dot.push_back(v_max * b);
        }
        const auto library = parse_library(kPaperLibrary);
        for (std::size_t j = 0; j < terms; ++j) {
          if (!pick[j]) continue;
          double rms = 0.0;
          for (std::size_t i = 0; i < d.z.size(); ++i) rms += std::pow(library[j](d.z[i], d.z_dot[i]), 2);
          rms = std::sqrt(rms / static_cast<double>(d.z.size()));
          d.true_terms.push_back(j);
          d.coefficients.push_back(100.0 * weights[j] / rms);  // ~100 N from every true term
        }
        return d;
      },
      log_uniform(1e-5, 1e-3), log_uniform(0.01, 0.5),
      rc::gen::container<std::vector<std::pair<double, double>>>(
          200, rc::gen::pair(uniform(1e-3, 1.0), uniform(-1.0, 1.0))),
      rc::gen::suchThat(rc::gen::container<std::vector<bool>>(terms, rc::gen::arbitrary<bool>()),
                        [](const std::vector<bool>& b) { return std::count(b.begin(), b.end(), true) > 0; }),
      rc::gen::container<std::vector<double>>(terms, uniform(0.2, 1.0)));
}

// The candidate matrix of a term library at the samples, z and z_dot multiplied by `unit`
// (1: metres, 1e3: millimetres), and the force.
Eigen::MatrixXd candidates(const library_data& d, double unit) {
  const auto library = parse_library(kPaperLibrary);
  Eigen::MatrixXd P(static_cast<Eigen::Index>(d.z.size()), static_cast<Eigen::Index>(library.size()));
  for (std::size_t i = 0; i < d.z.size(); ++i)
    for (std::size_t j = 0; j < library.size(); ++j)
      P(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = library[j](unit * d.z[i], unit * d.z_dot[i]);
  return P;
}

Eigen::VectorXd force(const library_data& d) {
  const auto library = parse_library(kPaperLibrary);
  Eigen::VectorXd y(static_cast<Eigen::Index>(d.z.size()));
  for (std::size_t i = 0; i < d.z.size(); ++i) {
    double f = 0.0;
    for (std::size_t k = 0; k < d.true_terms.size(); ++k) f += d.coefficients[k] * library[d.true_terms[k]](d.z[i], d.z_dot[i]);
    y[static_cast<Eigen::Index>(i)] = f;
  }
  return y;
}

frols_settings keep_everything_explained() {
  frols_settings s;
  s.rho = 1e-12;  // take terms until nothing is left
  s.err_threshold = 0.0;
  return s;
}

// The same candidates in the same order with the same ERRs, as far as the ERRs mean anything:
// once y is explained, what is left of it is rounding, ERRs are ~1e-32 and their order is noise.
void assert_same_ranking(const frols_result& a, const frols_result& b) {
  RC_ASSERT(a.order.size() == b.order.size());
  for (std::size_t i = 0; i < a.order.size(); ++i) {
    if (a.order[i].err <= kErrRounding && b.order[i].err <= kErrRounding) break;
    RC_ASSERT(a.order[i].candidate == b.order[i].candidate);
    RC_ASSERT(std::abs(a.order[i].err - b.order[i].err) <= kInvarianceErr);
  }
}

RC_GTEST_PROP(err, each_in_unit_interval_and_sum_at_most_one, ()) {
  const regression r = *random_regression();
  const frols_result f = frols(r.P, r.y, frols_settings{});
  double sum = 0.0;
  for (const auto& step : f.order) {
    RC_ASSERT(step.err >= 0.0);
    RC_ASSERT(step.err <= 1.0 + kErrRounding);
    sum += step.err;
    RC_ASSERT(std::abs(step.err_sum - sum) <= kErrRounding);
  }
  RC_ASSERT(sum <= 1.0 + kErrRounding);
  // The same in any fixed order (Table 1 in the paper's order).
  std::vector<std::size_t> reversed(static_cast<std::size_t>(r.P.cols()));
  for (std::size_t j = 0; j < reversed.size(); ++j) reversed[j] = reversed.size() - 1 - j;
  double sum_fixed = 0.0;
  for (const double e : err_in_order(r.P, r.y, reversed)) {
    RC_ASSERT(e >= 0.0);
    RC_ASSERT(e <= 1.0 + kErrRounding);
    sum_fixed += e;
  }
  RC_ASSERT(sum_fixed <= 1.0 + kErrRounding);
  // However the terms are taken, the total explained by all of them is the same projection.
  RC_ASSERT(std::abs(sum_fixed - sum) <= 1e3 * kErrRounding);
}

RC_GTEST_PROP(err, sum_reaches_one_for_a_noise_free_law_from_the_library, ()) {
  const library_data d = *library_law();
  const Eigen::MatrixXd P = candidates(d, 1.0);
  const Eigen::VectorXd y = force(d);
  const frols_result f = frols(P, y, keep_everything_explained());
  RC_ASSERT(f.order.back().err_sum >= 1.0 - kCompleteness);
  RC_ASSERT(f.order.back().err_sum <= 1.0 + kErrRounding);
  // The stopping rule (1 - sum ERR <= rho) is met, and the model it keeps reproduces the force.
  RC_ASSERT(1.0 - f.order[f.steps_selected - 1].err_sum <= 1e-12 || f.steps_selected == f.order.size());
  RC_ASSERT(f.residual.norm() <= std::sqrt(kCompleteness) * y.norm());
}

RC_GTEST_PROP(err, invariant_to_the_scale_of_a_regressor, ()) {
  const regression r = *random_regression();
  const int column = *rc::gen::inRange<int>(0, static_cast<int>(r.P.cols()));
  const double factor = std::pow(10.0, *uniform(-12.0, 12.0));
  Eigen::MatrixXd scaled = r.P;
  scaled.col(column) *= factor;
  frols_settings s;
  s.rho = *uniform(1e-6, 0.5);  // > 0: terms that explain only rounding are never taken
  s.err_threshold = *uniform(0.0, 0.05);
  const frols_result a = frols(r.P, r.y, s), b = frols(scaled, r.y, s);
  assert_same_ranking(a, b);
  RC_ASSERT(a.kept == b.kept);
  for (std::size_t k = 0; k < a.kept.size(); ++k) {
    const Eigen::Index j = static_cast<Eigen::Index>(a.kept[k]), kk = static_cast<Eigen::Index>(k);
    const double undo = j == column ? factor : 1.0;
    RC_ASSERT(std::abs(b.coefficients[kk] * undo - a.coefficients[kk]) * r.P.col(j).norm() <= kInvarianceCoefficient * r.y.norm());
  }
}

// z in metres or millimetres (and z_dot in m/s or mm/s): the same terms, the same ERRs, and
// coefficients that agree once converted (k3 in N/m^3 = k3 in N/mm^3 * 1e9, c2 in kg/m = c2 in
// N s^2/mm^2 * 1e6). The conversion factor of each term is its value ratio: terms are
// homogeneous in (z, z_dot).
RC_GTEST_PROP(err, estimates_invariant_to_the_units_of_z, ()) {
  const library_data d = *library_law();
  constexpr double kMillimetresPerMetre = 1e3;
  const Eigen::MatrixXd in_m = candidates(d, 1.0), in_mm = candidates(d, kMillimetresPerMetre);
  const Eigen::VectorXd y = force(d);  // N either way
  frols_settings s;  // the paper's rule: rho = 0.01, keep terms with ERR >= 1 %
  const frols_result a = frols(in_m, y, s), b = frols(in_mm, y, s);
  assert_same_ranking(a, b);
  RC_ASSERT(a.kept == b.kept);
  for (std::size_t k = 0; k < a.kept.size(); ++k) {
    const Eigen::Index j = static_cast<Eigen::Index>(a.kept[k]), kk = static_cast<Eigen::Index>(k);
    Eigen::Index at = 0;
    in_m.col(j).cwiseAbs().maxCoeff(&at);
    const double per_metre_unit = in_mm(at, j) / in_m(at, j);  // 1e3^degree of the term
    RC_ASSERT(std::abs(b.coefficients[kk] * per_metre_unit - a.coefficients[kk]) * in_m.col(j).norm() <=
              kInvarianceCoefficient * y.norm());
  }
}

}  // namespace
}  // namespace rubref::props
