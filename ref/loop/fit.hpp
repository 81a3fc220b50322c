#pragma once
// Stage 3 of `rubref loop` (docs/loop.md): least squares of the model's orbits against the
// measured samples, by the one solver (ref/inference/least_squares.hpp), over some coordinates of
// the model (the rest held) plus one timing shift per dwell with a keyphasor; and fits from
// several starts, keeping the best. A trial point where the model's orbit cannot be computed is a
// rejected step, never a number.

#include <Eigen/Dense>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ref/loop/coordinates.hpp"
#include "ref/loop/predictor.hpp"

namespace rubref {

struct fit_problem {
  orbit_predictor* predictor;
  std::vector<fit_coordinate> coords;  // model coordinates (shifts follow them in u)
  std::vector<std::size_t> shifted;    // dwells whose shift is fitted
  model_point base;                    // every other coordinate
  std::vector<double> shift_scale;     // s, per fitted dwell
  double noise = 0.0;                  // m, the convergence test's unit
  // The harmonic Jacobian's model columns from the orbits' exact sensitivities
  // (orbit_predictor::harmonic_columns) where they can be had; false: all by differences (the
  // sensitivities' test).
  bool exact_columns = true;

  Eigen::Index size() const { return static_cast<Eigen::Index>(coords.size() + shifted.size()); }
  model_point at(const Eigen::VectorXd& u) const;
  Eigen::VectorXd of(const model_point& m) const;
  // u with every coordinate within its bounds.
  Eigen::VectorXd feasible(Eigen::VectorXd u) const;
  // The Jacobian at u (residual r0 there): model coordinates by forward differences (backward
  // where the forward point cannot be computed; a coordinate with neither is held for the step),
  // shifts analytically. (In harmonics, the model coordinates from the exact sensitivities where
  // they can be had: exact_columns.)
  Eigen::MatrixXd jacobian(const Eigen::VectorXd& u, const Eigen::VectorXd& r0) const;
  // The same for the residuals in harmonics (orbit_predictor::harmonic_residuals), as fit() searches.
  Eigen::MatrixXd harmonic_jacobian(const Eigen::VectorXd& u, const Eigen::VectorXd& r0) const;

 private:
  Eigen::MatrixXd columns(const Eigen::VectorXd& u, const Eigen::VectorXd& r0, bool harmonics) const;
};

// The problem over `coords` around `base`, with the shift of every dwell that has a keyphasor.
fit_problem make_problem(orbit_predictor& predictor, const std::vector<loop_dwell>& dwells, const model_point& base,
                         std::vector<fit_coordinate> coords, double noise);

struct fit_result {
  model_point at;
  double rss = std::numeric_limits<double>::infinity();  // m^2, on the orbits followed from the start
  Eigen::VectorXd r;                                      // the residual there
  double remaining = 0.0;                                 // m^2: how much lower its minimum may lie (least_squares_result::remaining)
  orbit_anchors orbits;                                   // and those orbits
  int iterations = 0;     // Jacobians
  int evaluations = 0;    // residual evaluations, the start's and the Jacobians' differenced columns included
  int rejected = 0;       // trial points the model could not be computed at
  bool ok = false;        // false: the start itself could not be computed (at = the start)
};

// The solver from u = start, at most `max_iterations` Jacobians, each carrying
// steps_per_jacobian Broyden steps (registry, scope "loop"); it stops when a step gains less than
// min_gain in chi^2 = rss / noise^2. Every accepted step lowers the residual, so the result is
// never worse than its start. The start's orbits are `from` (else found from the data).
fit_result fit(const fit_problem& problem, const Eigen::VectorXd& start, int max_iterations, const orbit_anchors* from = nullptr);

// The residual of m on its own periodic orbits (anchored at m), as every comparison of fits uses;
// nothing if the model's orbit cannot be computed in some dwell.
std::optional<Eigen::VectorXd> residual_at(orbit_predictor& predictor, const model_point& m);

// Fits from several starts (named for the report): every start is evaluated, the best is fitted,
// and unless the best fit so far is `good_enough` (called right after that fit, so the predictor
// holds its states) the next best start is fitted too, `max_fits` in all. The lowest fit wins.
struct named_start {
  std::string name;
  model_point at;
  std::optional<orbit_anchors> orbits = {};  // a fitted model's orbits (else from the data)
};
struct start_outcome {
  std::string name;
  double rss_start = std::numeric_limits<double>::infinity();  // m^2 (inf: not computable)
  double rss_fit = std::numeric_limits<double>::quiet_NaN();   // m^2 (NaN: not fitted)
};
struct multistart_result {
  fit_result best;
  std::string winner;
  std::vector<start_outcome> starts;
  bool tie = false;  // fits alike within their numerical uncertainty: the first start in order won (fit_from_starts)
};
multistart_result fit_from_starts(const fit_problem& problem, const std::vector<named_start>& starts, int max_iterations,
                                  const std::function<bool(const fit_result&)>& good_enough, int max_fits);

// A race of the starts: each fitted for `lap` Jacobians, the one lowest after its lap fitted on
// from there with the rest of `max_iterations`. The start's own residual does not say where its
// fit ends: a start off in the effect's coordinates but on the right base can pass one on a base
// bent to absorb the effect within a step or two (docs/loop.md). Where the budget is not larger
// than a lap per start, the lowest start alone is fitted (fit_from_starts).
multistart_result race_starts(const fit_problem& problem, const std::vector<named_start>& starts, int max_iterations, int lap);

}  // namespace rubref
