#pragma once
// Forward Regression with Orthogonal Least Squares (Billings; the paper's Eq. 3 and Fig. 4).
//
// Candidates are selected one at a time. At each step every remaining regressor is
// orthogonalised (modified Gram-Schmidt, twice) against those already chosen, and the one with
// the largest error reduction ratio ERR = (w'y)^2 / ((w'w)(y'y)) is taken. ERR is invariant to the
// scale of a regressor, and the ERRs of all steps sum to the share of y'y explained.
// Selection stops when 1 - sum ERR <= rho (paper: 0.01) or, if chosen, where AIC / BIC is least;
// the model keeps the selected terms whose ERR reaches err_threshold (paper: 1 %), and their
// coefficients come from ordinary least squares on those terms alone.

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "ref/model/settings.hpp"

namespace rubref {

// err_sum: the paper's rule. significance: a step is taken while its term (a) explains at least
// `err_floor` of y'y and (b) passes an F-test at 99.9 %: the sum of squares it removes exceeds the
// F(1, N - k) quantile times the larger of the rows' known noise variance and the residual
// variance after it (N rows, k terms). (b) stops at the noise on noisy rows, (a) at the
// structured, non-random residual of noise-free ones; every step taken is kept.
enum class frols_stop { err_sum, aic, bic, significance };

struct frols_settings {
  // Defaults, ranges and reasons: the settings registry (scope "frols").
  double rho = default_of("frols", "rho");                      // stop when 1 - sum ERR <= rho
  double err_threshold = default_of("frols", "err_threshold");  // keep terms whose ERR >= this
  frols_stop stop = frols_stop::err_sum;
  double noise_variance = 0.0;                                  // significance: the rows' known noise variance (0: unknown; set by the weak form)
  double err_floor = default_of("frols", "err_floor");          // significance: the least share of y'y a kept term explains
  void validate() const;  // input_error naming the setting
};

struct frols_step {
  std::size_t candidate;  // column index in the candidate matrix
  double err;             // its error reduction ratio at this step
  double err_sum;         // cumulative
  double aic, bic;        // of the model made of steps 1..this one
};

struct frols_result {
  std::vector<frols_step> order;     // every candidate, in the order FROLS ranks them (Table 1)
  std::size_t steps_selected = 0;    // steps taken before the stopping rule held
  std::vector<std::size_t> kept;     // candidate indices in the final model (ERR >= threshold)
  Eigen::VectorXd coefficients;      // least squares on `kept`, in the units of the candidates
  Eigen::VectorXd standard_errors;   // from the residual variance (assumes uncorrelated residuals)
  Eigen::VectorXd residual;          // y - P_kept coefficients
  double err_sum_kept = 0.0;         // share of y'y explained by the kept terms (their ERRs)
};

// P: N x M candidates (columns), y: N targets. Throws input_error if N <= M or y is zero.
frols_result frols(const Eigen::MatrixXd& P, const Eigen::VectorXd& y, const frols_settings& s);

// ERR of the candidates taken in a fixed order (not greedily): what Table 1 shows when the
// selection order is given, e.g. the paper's apparent one.
std::vector<double> err_in_order(const Eigen::MatrixXd& P, const Eigen::VectorXd& y, const std::vector<std::size_t>& order);

// Ordinary least squares of y on the columns `cols` of P, with standard errors.
struct least_squares_fit {
  Eigen::VectorXd coefficients, standard_errors, residual;
};
least_squares_fit least_squares(const Eigen::MatrixXd& P, const Eigen::VectorXd& y, const std::vector<std::size_t>& cols);

}  // namespace rubref
