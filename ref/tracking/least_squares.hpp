#pragma once
// The nonlinear least squares the table fits share (the 1X response fit, the rub fit):
// Levenberg-Marquardt inside box bounds, and the covariance of the coordinates from the weighted
// Jacobian at the fit, with the directions the data do not constrain reported as unbounded.

#include <functional>
#include <vector>

#include <Eigen/Dense>

namespace rubref {

struct least_squares_problem {
  // Weighted residuals at q (a non-finite sum of squares rejects the step).
  std::function<Eigen::VectorXd(const std::vector<double>&)> residuals;
  // Their Jacobian at q, given the residuals there.
  std::function<Eigen::MatrixXd(const std::vector<double>&, const Eigen::VectorXd&)> jacobian;
  // q moved into the coordinates' bounds.
  std::function<std::vector<double>(std::vector<double>)> clamp;
};

// Levenberg-Marquardt from `start` (clamped), damping the normal equations' diagonal; stops when
// a step gains less than 1e-12 of the sum of squares, no step gains, or after max_iterations.
std::vector<double> levenberg_marquardt(const least_squares_problem& problem, std::vector<double> start, int max_iterations);

struct coordinate_covariance {
  Eigen::MatrixXd cov;          // of the Jacobian's columns
  std::vector<bool> unbounded;  // a column the data do not constrain: its variance is infinite
};

// (J^T J)^-1 times `scale` (chi^2/dof where the residual exceeds the noise), from the columns
// scaled to unit norm first (coordinates of different units differ by ~1e6 in their columns'
// sizes, which would hide every direction's scale); eigen-directions below 1e-12 of the largest
// are unconstrained, and every column with a share in one is unbounded.
coordinate_covariance covariance_of(const Eigen::MatrixXd& weighted_jacobian, double scale);

}  // namespace rubref
