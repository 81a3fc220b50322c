#pragma once
// The one nonlinear least-squares solver of rubref (docs/architecture.md, "Fit and evidence"):
// every fit of a model to data — the loop's orbits, the tables' 1X responses and rub, the
// identification's periodic orbits and output error, validate's diagnosis — is this solver on the
// wing's residuals.
//
// Levenberg-Marquardt with Marquardt's scaling (the damping on the diagonal of J'J, so the step
// does not depend on the coordinates' units) and Nielsen's damping update, inside box bounds by
// projection (a coordinate at its bound that the step pushes further is held). The Jacobian is
// taken by finite differences and carried along accepted steps by Broyden's rank-one update
// (Madsen, Nielsen & Tingleff 2004, Sec. 3.4), renewed every `steps_per_jacobian` steps, where a
// carried one misleads a step, and always before the fit is called converged.
//
// A point where the model cannot be evaluated (an orbit that cannot be computed, an integration
// that blows up) is a rejected step, like one that raises the residual: a failure never enters
// the objective as a number. Every accepted step lowers the residual, so a fit is never worse
// than its start.
//
// The covariance of the fitted coordinates (covariance_of) is (J'J)^-1 on whitened residuals,
// scaled by the residual's excess over the noise and by its correlation over neighbouring
// samples; directions the data do not constrain are reported as such (an infinite variance),
// never as a number.

#include <Eigen/Dense>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ref/model/settings.hpp"

namespace rubref {

// How the solver stops and differentiates; defaults, ranges and reasons in the settings registry
// (scope "least_squares"). A wing that needs other values takes them from rows of its own scope.
struct least_squares_options {
  int max_jacobians = default_count_of("least_squares", "max_jacobians");            // finite-difference Jacobians at most
  int steps_per_jacobian = default_count_of("least_squares", "steps_per_jacobian");  // accepted steps per Jacobian (the rest by Broyden updates)
  double difference_step = default_of("least_squares", "difference_step");           // forward difference, relative to max(1, |u|)
  double min_gain = default_of("least_squares", "min_gain");                         // chi^2: a step that gains less ends the fit
  double min_gain_share = default_of("least_squares", "min_gain_share");             // ... or less than this share of chi^2
  // input_error naming the option, its range and its reason.
  void validate() const;
};

// The model's residuals in the solver's coordinates u. Coordinates should be scaled so that a
// change of difference_step x max(1, |u|) moves the residuals measurably but linearly.
struct least_squares_problem {
  // The residuals at u, or nothing where the model cannot be evaluated there. A residual vector
  // with a non-finite entry is a failed evaluation too.
  std::function<std::optional<Eigen::VectorXd>(const Eigen::VectorXd&)> residuals;
  // The Jacobian at u, whose residuals are r (a wing with analytic columns or warm starts gives
  // its own). Empty: forward differences of `residuals` (backward where the forward point fails;
  // a coordinate with neither is held for that step).
  std::function<Eigen::MatrixXd(const Eigen::VectorXd&, const Eigen::VectorXd&)> jacobian;
  // Box bounds on u (empty: none; an infinite entry: none on that side).
  Eigen::VectorXd lower, upper;
  // The residuals' noise, the unit in which a step's gain is judged (chi^2 = |r|^2 / noise^2):
  // 1 for residuals already whitened.
  double noise = 1.0;

  // u moved into the bounds.
  Eigen::VectorXd feasible(Eigen::VectorXd u) const;
};

struct least_squares_result {
  Eigen::VectorXd u;        // the end (the start, clamped, where nothing was accepted)
  Eigen::VectorXd r;        // the residuals there
  double cost = std::numeric_limits<double>::infinity();  // |r|^2 (inf: the start could not be evaluated)
  // How much lower the minimum near u may lie than `cost` (|r|^2 units): the decrease the next
  // step (the last Jacobian, the fit's damping, within the bounds) still predicts, and at least the
  // gain the stop tolerates. A fit stopped by its budget, or one whose path a last-digit change of the
  // model would have moved, ends anywhere within this of its minimum: the numerical uncertainty
  // of `cost` that the evidence rules weigh (ref/inference/evidence.hpp).
  double remaining = 0.0;
  int jacobians = 0;        // finite-difference (or the wing's) Jacobians taken
  int evaluations = 0;      // residual evaluations by the solver (a wing's Jacobian's own are its to count)
  int rejected = 0;         // trial points the model could not be evaluated at
  bool ok = false;          // false: the start itself could not be evaluated
  bool converged = false;   // a step from a fresh Jacobian gained less than the tolerance, or none lowered the residual
  std::string status;       // why it stopped, one line
};

// Levenberg-Marquardt from `start` (moved into the bounds).
least_squares_result solve_least_squares(const least_squares_problem& problem, const Eigen::VectorXd& start,
                                         const least_squares_options& options = {});

// The numerical uncertainty of a fit's |r|^2 (in |r|^2's unit): its `remaining`, and an error of
// at most `residual_error` in each residual (the model's own accuracy, in the residuals' unit),
// which moves |r|^2 by at most 2 |r| |e| + |e|^2 with |e| = sqrt(n) residual_error (Cauchy-Schwarz:
// a bound that holds however the error lines up with the residual).
double cost_uncertainty(const Eigen::VectorXd& r, double remaining, double residual_error);

// Forward differences of problem.residuals at u (residuals r0 there), step h_j = step max(1, |u_j|),
// backward where the forward point fails; a column with neither is zero. `evaluations` counts them.
Eigen::MatrixXd forward_difference_jacobian(const least_squares_problem& problem, const Eigen::VectorXd& u, const Eigen::VectorXd& r0,
                                            double step, int* evaluations = nullptr);

// A run of residuals that are samples of one series in time (or speed) order: entries start,
// start + stride, ... (count of them). Neighbours within a series may be correlated; different
// series are taken as independent.
struct residual_series {
  Eigen::Index start = 0, count = 0, stride = 1;
};

// The residuals' long-run variance over their variance, 1 + 2 sum_{k=1..lags} rho_k, pooled over
// the series, at least 1 (1 with no series): residuals correlated over neighbouring samples carry
// fewer independent values than their count, and (J'J)^-1 alone understates the covariance of
// coordinates that move the model smoothly.
double correlation_factor(const Eigen::VectorXd& r, const std::vector<residual_series>& series, int lags);

struct fit_covariance {
  Eigen::MatrixXd cov;                 // of the Jacobian's columns, scaled (below)
  std::vector<bool> unconstrained;     // a column with a share in a direction the data do not constrain
  double chi2 = 0.0;                   // |r|^2 / noise^2
  std::size_t dof = 1;                 // residuals - columns (at least 1)
  double excess = 1.0;                 // max(1, chi^2 / dof): a residual above the noise widens every interval by it
  double correlation = 1.0;            // correlation_factor
  // The standard deviation of column k (infinite where unconstrained or not positive).
  double standard_deviation(Eigen::Index k) const;
  // The standard deviation of g . u (infinite where g has a share in an unconstrained column).
  double standard_deviation_along(const Eigen::VectorXd& g) const;
};

// The covariance of a fit's coordinates from its Jacobian J and residuals r (both in the same
// units; `noise` their noise, 1 when whitened): excess x correlation x (J'J)^-1, from the columns
// scaled to unit norm first (coordinates of different units differ by ~1e6 in their columns'
// sizes, which would hide every direction's scale); eigen-directions below
// kUnconstrainedEigenvalue of the largest are unconstrained, and every column with a share in one
// is unconstrained. The correlation is measured over `series` with the registry's lags.
fit_covariance covariance_of(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, double noise = 1.0,
                             const std::vector<residual_series>& series = {});

}  // namespace rubref
