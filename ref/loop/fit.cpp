#include "ref/loop/fit.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "ref/inference/least_squares.hpp"

namespace rubref {

namespace {
// Relative finite-difference step of the Jacobian, in scaled coordinates: orbit changes of
// ~1e-9..1e-7 m, far above the 1e-13 m integration error and small enough to stay linear.
constexpr double kStep = 1e-3;
// The step of the exact sensitivities' vector-field differences (orbit_predictor::harmonic_columns),
// in scaled coordinates, central where both sides lie within the bounds: no orbit is shot there,
// so it need not clear any integration error; the vector field's curvature leaves ~1e-8 of a
// column (one-sided at a bound: ~1e-4, where the coordinates enter linearly), the rounding of its
// largest terms ~1e-10 of an acceleration per unit.
constexpr double kVectorFieldStep = 1e-4;
}  // namespace

model_point fit_problem::at(const Eigen::VectorXd& u) const {
  model_point m = base;
  for (std::size_t j = 0; j < coords.size(); ++j) coords[j].set(m, u[static_cast<Eigen::Index>(j)] * coords[j].scale);
  for (std::size_t j = 0; j < shifted.size(); ++j) m.shift[shifted[j]] = u[static_cast<Eigen::Index>(coords.size() + j)] * shift_scale[j];
  return m;
}

Eigen::VectorXd fit_problem::of(const model_point& m) const {
  Eigen::VectorXd u(size());
  for (std::size_t j = 0; j < coords.size(); ++j) u[static_cast<Eigen::Index>(j)] = coords[j].get(m) / coords[j].scale;
  for (std::size_t j = 0; j < shifted.size(); ++j) u[static_cast<Eigen::Index>(coords.size() + j)] = m.shift[shifted[j]] / shift_scale[j];
  return u;
}

Eigen::VectorXd fit_problem::feasible(Eigen::VectorXd u) const {
  for (std::size_t j = 0; j < coords.size(); ++j) {
    auto& v = u[static_cast<Eigen::Index>(j)];
    v = std::clamp(v, coords[j].lower / coords[j].scale, coords[j].upper / coords[j].scale);
  }
  return u;
}

Eigen::MatrixXd fit_problem::jacobian(const Eigen::VectorXd& u, const Eigen::VectorXd& r0) const { return columns(u, r0, false); }

Eigen::MatrixXd fit_problem::harmonic_jacobian(const Eigen::VectorXd& u, const Eigen::VectorXd& r0) const { return columns(u, r0, true); }

Eigen::MatrixXd fit_problem::columns(const Eigen::VectorXd& u, const Eigen::VectorXd& r0, bool harmonics) const {
  const auto residuals = [&](const model_point& m) { return harmonics ? predictor->harmonic_residuals(m) : predictor->residuals(m); };
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(r0.size(), size());
  // The shifts' analytic columns need the harmonics (or states) at u: read first where the
  // predictor's last evaluation was at u (the solver's usual order: r0, then its Jacobian), else
  // evaluated again after the coordinates' columns.
  const auto shift_columns = [&](const model_point& m) {
    const Eigen::MatrixXd S = harmonics ? predictor->harmonic_shift_columns(m) : predictor->shift_columns(m);
    for (std::size_t j = 0; j < shifted.size(); ++j)
      J.col(static_cast<Eigen::Index>(coords.size() + j)) = S.col(static_cast<Eigen::Index>(shifted[j])) * shift_scale[j];
  };
  const model_point m = at(u);
  // The exact columns need the band's harmonics at u: one evaluation there, where the last was elsewhere.
  const bool exact = harmonics && exact_columns && !coords.empty() && (predictor->harmonics_are_of(m) || predictor->harmonic_residuals(m));
  const bool shifts_done = !shifted.empty() && harmonics && predictor->harmonics_are_of(m);
  if (shifts_done) shift_columns(m);
  std::vector<std::optional<Eigen::VectorXd>> sensitivities(coords.size());
  if (exact) {
    std::vector<model_point> up, down;
    std::vector<double> span;
    for (std::size_t j = 0; j < coords.size(); ++j) {
      const auto col = static_cast<Eigen::Index>(j);
      const double lo = coords[j].lower / coords[j].scale, hi = coords[j].upper / coords[j].scale, h = kVectorFieldStep;
      const bool above = u[col] + h <= hi, below = u[col] - h >= lo;
      Eigen::VectorXd a = u, b = u;
      if (above) a[col] += h;
      if (below) b[col] -= h;
      up.push_back(at(a));
      down.push_back(at(b));
      span.push_back(static_cast<double>(above + below) * h);  // 0: no room either way, differenced below
    }
    sensitivities = predictor->harmonic_columns(m, up, down, span);
  }
  // A differenced column takes the transient where m's evaluation did (orbit_predictor::harmonic_residuals_as).
  std::optional<std::vector<orbit_kind>> held;
  if (harmonics && predictor->harmonics_are_of(m)) held = predictor->kinds();
  const auto differenced = [&](const model_point& v) { return held ? predictor->harmonic_residuals_as(v, *held) : residuals(v); };
  for (std::size_t j = 0; j < coords.size(); ++j) {
    const auto col = static_cast<Eigen::Index>(j);
    if (sensitivities[j]) {
      J.col(col) = *sensitivities[j];
      continue;
    }
    for (const double h : {kStep, -kStep}) {
      Eigen::VectorXd v = u;
      v[col] += h;
      if (const auto r = differenced(at(v))) {
        J.col(col) = (*r - r0) / h;
        break;
      }
    }
  }
  if (!shifted.empty() && !shifts_done && residuals(m)) shift_columns(m);
  return J;
}

fit_problem make_problem(orbit_predictor& predictor, const std::vector<loop_dwell>& dwells, const model_point& base,
                         std::vector<fit_coordinate> coords, double noise) {
  fit_problem p{&predictor, std::move(coords), {}, base, {}, noise};
  for (std::size_t k = 0; k < dwells.size(); ++k)
    if (std::isfinite(dwells[k].timing_sigma)) {
      p.shifted.push_back(k);
      p.shift_scale.push_back(std::max(dwells[k].timing_sigma, 1e-9));
    }
  return p;
}

least_squares_options fit_options(int max_jacobians) {
  least_squares_options o;
  o.max_jacobians = max_jacobians;
  o.steps_per_jacobian = default_count_of("loop", "steps_per_jacobian");
  return o;
}

fit_result fit(const fit_problem& problem, const Eigen::VectorXd& start, int max_iterations, const orbit_anchors* from) {
  orbit_predictor& predictor = *problem.predictor;
  fit_result out;
  const std::size_t evaluations_before = predictor.evaluations();
  out.at = problem.at(problem.feasible(start));
  if (from) predictor.anchor(out.at, *from);
  else predictor.anchor(out.at);
  const std::optional<Eigen::VectorXd> start_r = predictor.residuals(out.at);  // the start on the samples
  const orbit_anchors start_orbits = predictor.last_orbits();
  // The one solver (ref/inference/least_squares.hpp), searching on the orbits' residuals in
  // harmonics (orbit_predictor::harmonic_residuals: |r|^2 less the data's part outside the band,
  // at a cost that does not grow with the record's length); each evaluation starts every dwell's
  // shooting from the anchors (the start's orbits).
  least_squares_problem lsq;
  lsq.residuals = [&](const Eigen::VectorXd& u) { return predictor.harmonic_residuals(problem.at(u)); };
  lsq.jacobian = [&](const Eigen::VectorXd& u, const Eigen::VectorXd& r) { return problem.harmonic_jacobian(u, r); };
  lsq.lower = Eigen::VectorXd::Constant(problem.size(), -std::numeric_limits<double>::infinity());
  lsq.upper = Eigen::VectorXd::Constant(problem.size(), std::numeric_limits<double>::infinity());
  for (std::size_t j = 0; j < problem.coords.size(); ++j) {
    const auto k = static_cast<Eigen::Index>(j);
    lsq.lower[k] = problem.coords[j].lower / problem.coords[j].scale;
    lsq.upper[k] = problem.coords[j].upper / problem.coords[j].scale;
  }
  lsq.noise = problem.noise;
  const least_squares_result s = solve_least_squares(lsq, start, fit_options(max_iterations));
  out.iterations = s.jacobians;
  out.evaluations = static_cast<int>(predictor.evaluations() - evaluations_before);  // the Jacobians' differenced columns included
  out.rejected = s.rejected;
  if (!s.ok) return out;
  // The end on the samples, on the orbits the fit followed: every statistic is taken there. Where
  // they cannot be read at the record's phases (a grid point of the band could), the fit failed.
  const model_point end = problem.at(s.u);
  auto rf = predictor.residuals(end);
  if (!rf) return out;
  out.ok = true;
  out.at = end;
  out.r = std::move(*rf);
  out.rss = out.r.squaredNorm();
  out.orbits = predictor.last_orbits();
  // The search left out the model's readings above the band (a contact's), which can move the
  // samples' minimum: by at most what they add here, counted twice (here and at that minimum).
  // (Measured on scenario #000 of the loop campaign's seed 9001: below 1 chi^2 per fit, 0.1 % of
  // the solver's own `remaining`.)
  const double outside = out.rss - (s.cost + predictor.harmonic_offset());
  out.remaining = s.remaining + 2.0 * std::abs(outside);
  // Never worse than the start: where the band's search left the samples' minimum (by what lies
  // above the band), the start stands; the minimum lies at most `remaining` below the end, so
  // less than that below the start.
  if (start_r && start_r->squaredNorm() < out.rss) {
    out.at = problem.at(problem.feasible(start));
    out.r = *start_r;
    out.rss = start_r->squaredNorm();
    out.orbits = start_orbits;
  }
  return out;
}

std::optional<Eigen::VectorXd> residual_at(orbit_predictor& predictor, const model_point& m) {
  predictor.anchor(m);
  return predictor.residuals(m);
}

namespace {
// A start's residual on its own orbits (or those found from the data); inf where it cannot be computed.
start_outcome evaluate_start(const fit_problem& problem, const named_start& s) {
  start_outcome o{s.name};
  if (s.orbits) problem.predictor->anchor(s.at, *s.orbits);
  else problem.predictor->anchor(s.at);
  if (const auto r = problem.predictor->residuals(s.at)) o.rss_start = r->squaredNorm();
  return o;
}
}  // namespace

multistart_result fit_from_starts(const fit_problem& problem, const std::vector<named_start>& starts, int max_iterations,
                                  const std::function<bool(const fit_result&)>& good_enough, int max_fits) {
  multistart_result out;
  for (const auto& s : starts) out.starts.push_back(evaluate_start(problem, s));
  std::vector<std::size_t> order(starts.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return out.starts[a].rss_start < out.starts[b].rss_start; });
  // Fits alike within their numerical uncertainty are a tie, which the starts' declared order
  // breaks: a lower residual by less than that is round-off, and the winner must not depend on it
  // (seed 7919 #10: two starts ended 6e-7 of the residual apart, 0.2 % apart in k1 along the law's
  // flat valley, and the dwells' order picked one and with it the trace's path).
  const double orbit_error = problem.predictor->orbit_options().orbit_error();
  const auto uncertainty = [&](const fit_result& f) { return cost_uncertainty(f.r, f.remaining, orbit_error); };
  std::size_t best_index = starts.size();
  int fits = 0;
  for (const std::size_t i : order) {
    if (fits >= max_fits || !std::isfinite(out.starts[i].rss_start)) break;
    const fit_result f = fit(problem, problem.of(starts[i].at), max_iterations, starts[i].orbits ? &*starts[i].orbits : nullptr);
    ++fits;
    out.starts[i].rss_fit = f.rss;
    if (!f.ok) continue;
    const bool tie = out.best.ok && std::abs(f.rss - out.best.rss) <= uncertainty(f) + uncertainty(out.best);
    if (tie) out.tie = true;
    if (tie ? i < best_index : f.rss < out.best.rss) {
      out.tie = tie;  // a fit lower beyond the uncertainty wins outright
      out.best = f;
      out.winner = starts[i].name;
      best_index = i;
      if (good_enough(f)) break;
    }
  }
  return out;
}

multistart_result race_starts(const fit_problem& problem, const std::vector<named_start>& starts, int max_iterations, int lap) {
  const auto laps = static_cast<long long>(lap) * static_cast<long long>(starts.size());
  if (starts.size() < 2 || lap < 1 || max_iterations <= laps)
    return fit_from_starts(problem, starts, max_iterations, [](const fit_result&) { return true; }, 1);
  multistart_result out;
  std::optional<std::size_t> leader;
  for (std::size_t i = 0; i < starts.size(); ++i) {
    const auto& s = starts[i];
    start_outcome o = evaluate_start(problem, s);
    if (std::isfinite(o.rss_start)) {
      fit_result f = fit(problem, problem.of(s.at), lap, s.orbits ? &*s.orbits : nullptr);
      o.rss_fit = f.rss;
      if (f.ok && f.rss < out.best.rss) out.best = std::move(f), leader = i;
    }
    out.starts.push_back(std::move(o));
  }
  if (!leader) return out;
  out.winner = starts[*leader].name;
  const fit_result rest = fit(problem, problem.of(out.best.at), max_iterations - lap, &out.best.orbits);
  if (rest.ok && rest.rss <= out.best.rss) out.best = rest;
  out.starts[*leader].rss_fit = out.best.rss;
  return out;
}

}  // namespace rubref
