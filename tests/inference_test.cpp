// The fit-and-evidence floor (ref/inference/): the one least-squares solver on problems with
// known answers, its covariance against the closed form of linear least squares, and the evidence
// rules at their thresholds.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ref/base/errors.hpp"
#include "ref/inference/evidence.hpp"
#include "ref/inference/least_squares.hpp"
#include "ref/inference/verdict.hpp"

namespace rubref {
namespace {

// The solver stops on a gain below min_gain (1e-2 chi^2, in units of the problem's noise): on
// whitened residuals an estimate is then within sqrt(1e-2) = 0.1 of a standard error of the
// minimum (kWithinNoise). Problems without noise declare a tiny one (kExactNoise), so that the
// same rule asks the minimum to 1e-6 of coordinates of order 1 (kSolved).
constexpr double kWithinNoise = 0.1;
constexpr double kExactNoise = 1e-9;
constexpr double kSolved = 1e-6;
// Covariances from the same Jacobian as the closed form's, up to the finite differences' error
// (relative step 1e-6 on exactly linear residuals: rounding only).
constexpr double kCovariance = 1e-6;

least_squares_problem rosenbrock() {
  least_squares_problem p;
  p.noise = kExactNoise;
  p.residuals = [](const Eigen::VectorXd& u) -> std::optional<Eigen::VectorXd> {
    Eigen::VectorXd r(2);
    r << 10.0 * (u[1] - u[0] * u[0]), 1.0 - u[0];
    return r;
  };
  return p;
}

TEST(least_squares, rosenbrock_from_the_classic_start) {
  least_squares_options o;
  o.max_jacobians = 200;
  Eigen::VectorXd start(2);
  start << -1.2, 1.0;
  const auto f = solve_least_squares(rosenbrock(), start, o);
  ASSERT_TRUE(f.ok);
  EXPECT_TRUE(f.converged) << f.status;
  EXPECT_NEAR(f.u[0], 1.0, kSolved);
  EXPECT_NEAR(f.u[1], 1.0, kSolved);
  EXPECT_LT(f.cost, 1e-10);
}

TEST(least_squares, broyden_steps_reach_the_same_minimum_with_fewer_jacobians) {
  least_squares_options fresh, carried;
  fresh.max_jacobians = carried.max_jacobians = 200;
  carried.steps_per_jacobian = 3;
  Eigen::VectorXd start(2);
  start << -1.2, 1.0;
  const auto a = solve_least_squares(rosenbrock(), start, fresh), b = solve_least_squares(rosenbrock(), start, carried);
  EXPECT_NEAR(b.u[0], 1.0, kSolved);
  EXPECT_NEAR(b.u[1], 1.0, kSolved);
  EXPECT_LT(b.jacobians, a.jacobians);
}

TEST(least_squares, a_bound_holds_the_coordinate_the_minimum_lies_beyond) {
  least_squares_problem p = rosenbrock();
  p.upper = Eigen::Vector2d(0.5, 10.0);  // the minimum (1, 1) lies beyond u0 = 0.5
  p.lower = Eigen::Vector2d(-10.0, -10.0);
  least_squares_options o;
  o.max_jacobians = 200;
  const auto f = solve_least_squares(p, Eigen::Vector2d(-1.2, 1.0), o);
  EXPECT_DOUBLE_EQ(f.u[0], 0.5);
  // The constrained minimum, u1 = u0^2, leaves the residual 1 - u0 = 0.5: the solver then stops on
  // a gain below min_gain_share (1e-5) of that cost, within sqrt(1e-5 x 0.25 / 100) = 1.6e-4 of
  // u1 (the residual 10 (u1 - u0^2) has curvature 100).
  constexpr double kShareStop = 2e-4;
  EXPECT_NEAR(f.u[1], 0.25, kShareStop);
}

// A region where the model cannot be evaluated (an orbit that cannot be computed): the solver
// rejects every trial point there and never reads it as a number; the fit ends at a computable
// point, lower than its start. Where the region lies across the path to the minimum the solver
// cannot see around it: it stops at the region's edge (said: rejected steps).
TEST(least_squares, failed_evaluations_are_rejected_never_read) {
  least_squares_problem p;
  p.noise = kExactNoise;
  int failed = 0;
  p.residuals = [&failed](const Eigen::VectorXd& u) -> std::optional<Eigen::VectorXd> {
    if (u[0] > 0.7) {
      ++failed;
      return std::nullopt;
    }
    Eigen::VectorXd r(2);
    r << u[0] - 1.0, u[1] - 2.0;
    return r;
  };
  const auto f = solve_least_squares(p, Eigen::Vector2d(0.0, 0.0));
  ASSERT_TRUE(f.ok);
  EXPECT_GT(f.rejected, 0);
  EXPECT_LE(f.u[0], 0.7);
  EXPECT_GT(f.u[0], 0.6);  // it came close to the region's edge
  EXPECT_LT(f.cost, 5.0);  // the start's cost (1 + 4): every accepted step lowered it
  EXPECT_TRUE(f.r.allFinite());
  // Beside the path the region is never met: the minimum itself.
  p.residuals = [](const Eigen::VectorXd& u) -> std::optional<Eigen::VectorXd> {
    if (u[1] < -1.0) return std::nullopt;
    Eigen::VectorXd r(2);
    r << u[0] - 1.0, u[1] - 2.0;
    return r;
  };
  const auto g = solve_least_squares(p, Eigen::Vector2d(0.0, 0.0));
  EXPECT_NEAR(g.u[0], 1.0, kSolved);
  EXPECT_NEAR(g.u[1], 2.0, kSolved);
}

TEST(least_squares, a_non_finite_residual_is_a_failed_evaluation) {
  least_squares_problem p;
  p.residuals = [](const Eigen::VectorXd& u) -> std::optional<Eigen::VectorXd> {
    Eigen::VectorXd r(1);
    r << (u[0] > 0.5 ? std::nan("") : u[0] - 1.0);
    return r;
  };
  const auto f = solve_least_squares(p, Eigen::VectorXd::Zero(1));
  EXPECT_LE(f.u[0], 0.5);
  EXPECT_GT(f.rejected, 0);
}

TEST(least_squares, a_start_that_cannot_be_evaluated_is_said) {
  least_squares_problem p;
  p.residuals = [](const Eigen::VectorXd&) -> std::optional<Eigen::VectorXd> { return std::nullopt; };
  const auto f = solve_least_squares(p, Eigen::VectorXd::Zero(2));
  EXPECT_FALSE(f.ok);
  EXPECT_FALSE(f.converged);
  EXPECT_TRUE(std::isinf(f.cost));
}

TEST(least_squares, a_bad_option_is_named_with_its_rule) {
  least_squares_options o;
  o.max_jacobians = 0;
  try {
    o.validate();
    FAIL() << "accepted max_jacobians = 0";
  } catch (const input_error& e) {
    EXPECT_NE(std::string(e.what()).find("`max_jacobians`"), std::string::npos) << e.what();
  }
}

// Linear least squares y = a + b x + noise: the fit is the normal equations' solution and its
// covariance sigma^2 (X'X)^-1, scaled by chi^2/dof only where that exceeds 1.
TEST(least_squares, linear_regression_and_its_covariance_are_the_closed_form) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  constexpr int n = 200;
  Eigen::MatrixXd X(n, 2);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) X(i, 0) = 1.0, X(i, 1) = i / 20.0, y[i] = 3.0 - 0.5 * X(i, 1) + 2.0 * noise(rng);
  const double sigma = 2.0;
  least_squares_problem p;
  p.residuals = [&](const Eigen::VectorXd& u) -> std::optional<Eigen::VectorXd> { return (X * u - y) / sigma; };
  const auto f = solve_least_squares(p, Eigen::Vector2d::Zero());
  const Eigen::Vector2d exact = (X.transpose() * X).ldlt().solve(X.transpose() * y);
  const auto c = covariance_of(forward_difference_jacobian(p, f.u, f.r, 1e-6), f.r);
  const Eigen::Matrix2d closed = sigma * sigma * (X.transpose() * X).inverse() * std::max(1.0, f.r.squaredNorm() / (n - 2));
  EXPECT_NEAR(f.u[0], exact[0], kWithinNoise * std::sqrt(closed(0, 0)));
  EXPECT_NEAR(f.u[1], exact[1], kWithinNoise * std::sqrt(closed(1, 1)));
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) EXPECT_NEAR(c.cov(i, j), closed(i, j), kCovariance * std::abs(closed(i, i))) << i << "," << j;
  EXPECT_EQ(c.dof, static_cast<std::size_t>(n - 2));
  EXPECT_DOUBLE_EQ(c.correlation, 1.0);  // no series given: independent residuals
}

TEST(least_squares, a_direction_the_data_do_not_constrain_is_said_never_a_number) {
  Eigen::MatrixXd J(4, 3);
  J << 1, 1, 0, 2, 2, 1, 3, 3, 0, 4, 4, 1;  // columns 0 and 1 move the residuals alike
  const auto c = covariance_of(J, Eigen::VectorXd::Zero(4));
  EXPECT_TRUE(c.unconstrained[0]);
  EXPECT_TRUE(c.unconstrained[1]);
  EXPECT_FALSE(c.unconstrained[2]);
  EXPECT_TRUE(std::isinf(c.standard_deviation(0)));
  EXPECT_TRUE(std::isfinite(c.standard_deviation(2)));
  EXPECT_TRUE(std::isinf(c.standard_deviation_along(Eigen::Vector3d(1.0, -1.0, 0.0))));
}

// AR(1) residuals e_i = rho e_{i-1} + w_i: 1 + 2 sum_{k=1..4} rho^k = 2.875 at rho = 0.5; white
// residuals give 1 (clipped from below). Tolerance: the sample autocorrelations' standard error
// ~1/sqrt(N) = 0.003 each at N = 1e5, times the sum's ~4 terms and their correlation.
TEST(least_squares, the_correlation_factor_of_correlated_residuals) {
  constexpr double kCorrelationTolerance = 0.05;
  std::mt19937 rng(11);
  std::normal_distribution<double> w(0.0, 1.0);
  constexpr Eigen::Index n = 100000;
  Eigen::VectorXd ar(n), white(n);
  double e = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) e = 0.5 * e + w(rng), ar[i] = e, white[i] = w(rng);
  EXPECT_NEAR(correlation_factor(ar, {{0, n, 1}}, 4), 2.875, kCorrelationTolerance);
  EXPECT_NEAR(correlation_factor(white, {{0, n, 1}}, 4), 1.0, kCorrelationTolerance);
  // Two interleaved series (x, y of each sample): each measured along its own stride, pooled by
  // variance (the AR(1) series' is 1 / (1 - 0.25) = 4/3, the white one's 1).
  Eigen::VectorXd both(2 * n);
  for (Eigen::Index i = 0; i < n; ++i) both[2 * i] = ar[i], both[2 * i + 1] = white[i];
  EXPECT_NEAR(correlation_factor(both, {{0, n, 2}, {1, n, 2}}, 4), 1.0 + (2.875 - 1.0) * (4.0 / 3.0) / (4.0 / 3.0 + 1.0), kCorrelationTolerance);
}

// ---------------------------------------------------------------------------------------------
// The evidence rules.

TEST(evidence, the_criterion_is_scale_free_and_charges_each_coordinate_ln_n) {
  const double a = information_criterion(120.0, 100.0, 3), b = information_criterion(100.0, 100.0, 4);
  EXPECT_NEAR(a - b, 100.0 * std::log(1.2) - std::log(100.0), 1e-12);
  // The same data in other units (chi^2 times s^2): the same difference.
  EXPECT_NEAR(information_criterion(120.0 * 7.0, 100.0, 3) - information_criterion(100.0 * 7.0, 100.0, 4), a - b, 1e-10);
  EXPECT_TRUE(std::isfinite(information_criterion(0.0, 100.0, 3)));  // a perfect fit
}

TEST(evidence, a_part_is_needed_only_beyond_every_threshold) {
  const evidence_rules rules;
  part_comparison c;
  c.criterion_rise = 25.0, c.excess_share = 0.5, c.change = 2.0, c.resolution = 1.0;
  c.holdout_gain = 20.0, c.in_sample_gain = 40.0;
  EXPECT_TRUE(judge_need(c, rules).needed);
  part_comparison at = c;
  at.criterion_rise = rules.min_criterion_rise;  // "more than": the threshold itself is not enough
  EXPECT_FALSE(judge_need(at, rules).significant);
  at = c, at.excess_share = 0.2;
  EXPECT_FALSE(judge_need(at, rules).significant);
  at = c, at.change = 0.5;  // within the noise test's resolution
  EXPECT_FALSE(judge_need(at, rules).significant);
  at = c, at.change = 0.0, at.resolution = 0.0;  // a wing whose noise test resolves nothing finer than the criterion
  EXPECT_TRUE(judge_need(at, rules).significant);
  at = c, at.holdout_gain = 10.0;
  EXPECT_TRUE(judge_need(at, rules).significant);
  EXPECT_FALSE(judge_need(at, rules).needed);
  at = c, at.holdout_gain = 12.0, at.in_sample_gain = 100.0;  // above 10 but below a third of its gain
  EXPECT_FALSE(judge_need(at, rules).needed);
  at = c, at.holdout_gain.reset();
  EXPECT_FALSE(judge_need(at, rules).needed);
}

TEST(evidence, claims) {
  const evidence_rules rules;
  claim_inputs in;
  EXPECT_EQ(claim_of(in, rules), "none");
  in.anything_named = true, in.residual_is_noise = true;
  EXPECT_EQ(claim_of(in, rules), "full");
  in.residual_is_noise = false, in.explained_share = 0.97;
  EXPECT_EQ(claim_of(in, rules), "partial");
  in.explained_share = 0.9;
  EXPECT_EQ(claim_of(in, rules), "tentative");
  in.explained_share = 1.0, in.residual_is_noise = true, in.decisive = false;
  EXPECT_EQ(claim_of(in, rules), "tentative");
  in.decisive = true, in.plausible = false;
  EXPECT_EQ(claim_of(in, rules), "tentative");
  EXPECT_TRUE(decisive(100.0, 111.0, rules).yes);
  EXPECT_FALSE(decisive(100.0, 110.0, rules).yes);
  EXPECT_TRUE(interval_determined(1.0, 3.9, rules));
  EXPECT_FALSE(interval_determined(1.0, 4.0, rules));
  EXPECT_FALSE(interval_determined(0.0, 1.0, rules));
  EXPECT_DOUBLE_EQ(explained_share(10.0, 1.0), 0.9);
  EXPECT_DOUBLE_EQ(explained_share(10.0, -1.0), 1.0);
  EXPECT_DOUBLE_EQ(explained_share(0.0, 1.0), 1.0);
  EXPECT_DOUBLE_EQ(explained_share(10.0, 20.0), 0.0);
}

// A decision at its threshold is tentative, never decided by the last digit: a statistic within
// its numerical uncertainty of a threshold is on the margin (either way), one beyond it is not.
TEST(evidence, a_decision_within_its_statistics_uncertainty_of_the_threshold_is_tentative) {
  const evidence_rules rules;
  const double t = rules.min_criterion_rise;
  EXPECT_FALSE(exceeds({t + 1.0, 0.5}, t).on_margin);
  EXPECT_TRUE(exceeds({t + 1.0, 0.5}, t).yes);
  EXPECT_TRUE(exceeds({t + 0.4, 0.5}, t).on_margin);
  EXPECT_TRUE(exceeds({t + 0.4, 0.5}, t).yes);
  EXPECT_TRUE(exceeds({t - 0.4, 0.5}, t).on_margin);
  EXPECT_FALSE(exceeds({t - 0.4, 0.5}, t).yes);
  EXPECT_FALSE(exceeds({t - 1.0, 0.5}, t).on_margin);
  EXPECT_TRUE(exceeds({t, 0.0}, t).yes == false && !exceeds({t, 0.0}, t).on_margin);  // exact: no margin
  // Both: certain where one fails for certain, on the margin where none fails and one is on it.
  EXPECT_FALSE(both({false, false}, {true, true}).on_margin);
  EXPECT_TRUE(both({true, false}, {false, true}).on_margin);
  EXPECT_FALSE(both({true, false}, {false, true}).yes);

  // The criterion rise one ulp-scale change from the threshold: the same need, whichever side.
  part_comparison c;
  c.criterion_rise = t + 1e-9, c.criterion_rise_uncertainty = 0.7, c.excess_share = 0.5, c.change = 2.0, c.resolution = 1.0;
  c.holdout_gain = 20.0, c.in_sample_gain = 40.0;
  const need above = judge_need(c, rules);
  c.criterion_rise = t - 1e-9;
  const need below = judge_need(c, rules);
  EXPECT_TRUE(above.needed);
  EXPECT_FALSE(below.needed);
  EXPECT_TRUE(above.on_margin);
  EXPECT_TRUE(below.on_margin);
  EXPECT_NE(below.reason.find("on the margin"), std::string::npos) << below.reason;
  // Far from every threshold: decided.
  c.criterion_rise = 25.0;
  EXPECT_FALSE(judge_need(c, rules).on_margin);
  // Failing one rule for certain decides, whatever the others' margins.
  c.excess_share = 0.1;
  EXPECT_FALSE(judge_need(c, rules).on_margin);
  // Out of sample at its threshold: the held-out gain against a third of the in-sample gain.
  c.excess_share = 0.5, c.holdout_gain = 40.0 / 3.0 + 1e-9, c.holdout_gain_uncertainty = 0.5;
  EXPECT_TRUE(judge_need(c, rules).on_margin);

  // The decisive-choice rule at its margin, and the claim it leaves.
  EXPECT_TRUE(decisive(100.0, 100.0 + t + 1e-9, rules, 0.7).on_margin);
  EXPECT_FALSE(decisive(100.0, 100.0 + t + 1.0, rules, 0.7).on_margin);
  claim_inputs in;
  in.anything_named = true, in.residual_is_noise = true, in.explained_share = 1.0;
  EXPECT_EQ(claim_of(in, rules), "full");
  in.on_margin = true;
  EXPECT_EQ(claim_of(in, rules), "tentative");
  const verdict v = decide("effects", {"shaft_bow"}, in, rules);
  EXPECT_TRUE(v.named.empty());
  EXPECT_EQ(v.tentative, std::vector<std::string>{"shaft_bow"});
  // A partial claim whose share lies within its uncertainty of claim_share: tentative.
  in.on_margin = false, in.residual_is_noise = false, in.explained_share = rules.claim_share + 1e-9, in.explained_share_uncertainty = 1e-3;
  EXPECT_EQ(claim_of(in, rules), "tentative");
  in.explained_share_uncertainty = 0.0;
  EXPECT_EQ(claim_of(in, rules), "partial");

  // The criterion change's uncertainty to first order: n (u_a / chi2_a + u_b / chi2_b).
  EXPECT_NEAR(criterion_change_uncertainty(1000.0, 200.0, 2.0, 100.0, 0.5), 1000.0 * (0.01 + 0.005), 1e-12);
}

// The solver's `remaining`: what the next step still predicts at the end, at least the tolerance
// a converged stop leaves. On linear least squares the quadratic model is exact: a fit stopped by
// its budget after one step is `remaining` (to the damped step's share of the gap, 1 - O(damping)
// ~ 1e-3, kDampedShare) above the minimum, and a converged fit leaves the tolerance.
constexpr double kDampedShare = 1e-2;
TEST(least_squares, remaining_is_the_decrease_the_end_still_predicts) {
  const int n = 50;
  Eigen::MatrixXd A(n, 2);
  Eigen::VectorXd b(n);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (int i = 0; i < n; ++i) A(i, 0) = 1.0, A(i, 1) = 0.1 * i, b[i] = 2.0 + 0.3 * 0.1 * i + noise(rng);
  least_squares_problem p;
  p.noise = 0.1;
  p.residuals = [&](const Eigen::VectorXd& u) -> std::optional<Eigen::VectorXd> { return Eigen::VectorXd(A * u - b); };
  const Eigen::VectorXd start = Eigen::VectorXd::Zero(2);
  const Eigen::VectorXd best = A.colPivHouseholderQr().solve(b);
  const double min_cost = (A * best - b).squaredNorm();
  least_squares_options o;
  const auto f = solve_least_squares(p, start, o);
  ASSERT_TRUE(f.converged) << f.status;
  EXPECT_LE(f.cost - min_cost, f.remaining);
  EXPECT_NEAR(f.remaining, std::max(o.min_gain * p.noise * p.noise, o.min_gain_share * f.cost), 1e-12);
  // Stopped by the budget after one step, far from a tolerance that would hide the gap.
  least_squares_options one = o;
  one.max_jacobians = 1, one.steps_per_jacobian = 1, one.min_gain = 1e-30, one.min_gain_share = 0.0;
  const auto g = solve_least_squares(p, start, one);
  ASSERT_FALSE(g.converged) << g.status;
  const double gap = g.cost - min_cost;
  ASSERT_GT(gap, 0.0);
  EXPECT_NEAR(g.remaining, gap, kDampedShare * gap);
}

// The cost's uncertainty bounds |r + e|^2 - |r|^2 for every error of at most eps per residual, and
// is reached by the error lined up with r (Cauchy-Schwarz's equality): 1e-12 relative is rounding.
TEST(least_squares, cost_uncertainty_bounds_every_error_and_is_reached) {
  Eigen::VectorXd r(4);
  r << 1.0, -2.0, 0.5, 3.0;
  const double eps = 0.01, u = cost_uncertainty(r, 0.25, eps);
  const Eigen::VectorXd aligned = r.normalized() * (std::sqrt(4.0) * eps);  // |e| = sqrt(n) eps, along r
  EXPECT_NEAR(u - 0.25, (r + aligned).squaredNorm() - r.squaredNorm(), 1e-12 * u);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> within(-eps, eps);
  for (int k = 0; k < 100; ++k) {
    Eigen::VectorXd e(4);
    for (auto& x : e) x = within(rng);
    EXPECT_LE(std::abs((r + e).squaredNorm() - r.squaredNorm()), u - 0.25);
  }
}

TEST(evidence, a_verdict_splits_the_chosen_names_by_its_claim) {
  const evidence_rules rules;
  claim_inputs in;
  in.residual_is_noise = false, in.explained_share = 0.5;
  const verdict v = decide("effects", {"shaft_bow"}, in, rules);
  EXPECT_EQ(v.claim, "tentative");
  EXPECT_TRUE(v.named.empty());
  EXPECT_EQ(v.tentative, std::vector<std::string>{"shaft_bow"});
  EXPECT_TRUE(v.unexplained);
  in.residual_is_noise = true;
  const verdict rivalled = decide("effects", {"shaft_bow"}, in, rules, "anisotropy");
  EXPECT_EQ(rivalled.claim, "tentative");
  EXPECT_EQ(to_json(rivalled)["rival"], "anisotropy");
  const verdict full = decide("effects", {"shaft_bow"}, in, rules);
  EXPECT_EQ(full.claim, "full");
  EXPECT_EQ(full.named, std::vector<std::string>{"shaft_bow"});
  EXPECT_EQ(summary_line(full), "effects: shaft_bow; residual is noise");
  EXPECT_NE(to_markdown(full).find("claim: **full**"), std::string::npos);
}

}  // namespace
}  // namespace rubref
