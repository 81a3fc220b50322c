#include "ref/loop/fit.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace rubref {

namespace {
// Relative finite-difference step of the Jacobian, in scaled coordinates: orbit changes of
// ~1e-9..1e-7 m, far above the 1e-13 m integration error and small enough to stay linear.
constexpr double kStep = 1e-3;
// A step that gains less than this in chi^2 (rss / noise^2), or this share of chi^2, ends the
// fit: near the noise a fraction of one degree of freedom, far from it a fraction of the BIC
// drops of thousands the loop then compares; both far below the smallest (10).
constexpr double kConvergedChi2 = 1e-2;
constexpr double kConvergedShare = 1e-5;
// Marquardt's damping: the first value (relative to the diagonal of J'J), and where it is so
// large that no step of useful size is left.
constexpr double kFirstDamping = 1e-3;
constexpr double kMaxDamping = 1e12;
// Accepted steps per finite-difference Jacobian at most (the others carry it by Broyden updates):
// a fit's budget of `max_iterations` Jacobians allows this many times as many steps.
constexpr int kStepsPerJacobian = 3;
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

Eigen::MatrixXd fit_problem::jacobian(const Eigen::VectorXd& u, const Eigen::VectorXd& r0) const {
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(r0.size(), size());
  for (std::size_t j = 0; j < coords.size(); ++j) {
    const auto col = static_cast<Eigen::Index>(j);
    for (const double h : {kStep, -kStep}) {
      Eigen::VectorXd v = u;
      v[col] += h;
      if (const auto r = predictor->residuals(at(v))) {
        J.col(col) = (*r - r0) / h;
        break;
      }
    }
  }
  if (!shifted.empty()) {
    const model_point m = at(u);
    if (predictor->residuals(m)) {  // the states at u for the analytic columns
      const Eigen::MatrixXd S = predictor->shift_columns(m);
      for (std::size_t j = 0; j < shifted.size(); ++j)
        J.col(static_cast<Eigen::Index>(coords.size() + j)) = S.col(static_cast<Eigen::Index>(shifted[j])) * shift_scale[j];
    }
  }
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

fit_result fit(const fit_problem& problem, const Eigen::VectorXd& start, int max_iterations, const orbit_anchors* from) {
  orbit_predictor& predictor = *problem.predictor;
  fit_result out;
  out.at = problem.at(problem.feasible(start));
  if (from) predictor.anchor(out.at, *from);
  else predictor.anchor(out.at);
  auto r = predictor.residuals(out.at);
  ++out.evaluations;
  if (!r) return out;
  out.ok = true;
  out.rss = r->squaredNorm();
  const double chi2_unit = std::max(problem.noise * problem.noise, 1e-300);
  Eigen::VectorXd u = problem.feasible(start);
  double damping = kFirstDamping, growth = 2.0;
  // The Jacobian: by finite differences (`fresh`), then carried along accepted steps by Broyden's
  // rank-one update, which costs no evaluation (Madsen, Nielsen & Tingleff 2004, Sec. 3.4). A
  // finite-difference one is taken again where the carried one fails: a rejected step, or a gain
  // too small to stop on, so that the fit ends only where a true Jacobian says it has converged.
  Eigen::MatrixXd J;
  bool fresh = false;
  int steps = 0;
  const auto refresh = [&] {
    J = problem.jacobian(u, *r);
    fresh = true;
    ++out.iterations;
    out.evaluations += static_cast<int>(problem.coords.size()) + 1;
  };
  refresh();
  while (steps < kStepsPerJacobian * max_iterations) {
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * *r;
    const Eigen::VectorXd d = A.diagonal().cwiseMax(1e-12 * std::max(A.diagonal().maxCoeff(), 1e-300));
    bool accepted = false;
    double gain = 0.0;
    while (damping < kMaxDamping) {
      Eigen::MatrixXd M = A;
      M.diagonal() += damping * d;
      const Eigen::VectorXd free_step = -M.ldlt().solve(g);
      if (!free_step.allFinite()) {
        damping *= growth, growth *= 2.0;
        continue;
      }
      // Projected onto the bounds: a coordinate at its bound that the step pushes further is held.
      const Eigen::VectorXd trial = problem.feasible(u + free_step);
      const Eigen::VectorXd step = trial - u;
      const auto rt = predictor.residuals(problem.at(trial));
      ++out.evaluations;
      const double predicted = step.dot(A * step) + 2.0 * damping * step.dot(d.cwiseProduct(step));
      if (!rt) {
        ++out.rejected;
        damping *= growth, growth *= 2.0;
        if (!fresh) break;  // the carried Jacobian may have misled the step: a true one first
        continue;
      }
      const double rss = rt->squaredNorm();
      if (rss < out.rss) {
        const double rho = predicted > 0.0 ? (out.rss - rss) / predicted : 1.0;
        damping *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
        growth = 2.0;
        gain = (out.rss - rss) / chi2_unit;
        if (const double h = step.squaredNorm(); h > 0.0) J += ((*rt - *r) - J * step) * (step.transpose() / h);
        u = trial;
        r = rt;
        out.rss = rss;
        accepted = true;
        break;
      }
      damping *= growth, growth *= 2.0;
      if (!fresh) break;
      // A step too small to change the residual at all: nothing is left to gain.
      if (step.cwiseAbs().maxCoeff() < 1e-14 * std::max(1.0, u.cwiseAbs().maxCoeff())) break;
    }
    const bool converged = !accepted || gain < std::max(kConvergedChi2, kConvergedShare * out.rss / chi2_unit);
    const bool from_fresh = fresh;  // the step (or its failure) came from a finite-difference Jacobian
    if (accepted) ++steps, fresh = false;
    if (converged) {
      if (from_fresh || out.iterations >= max_iterations) break;  // a true Jacobian agrees: done (or its budget is spent)
      refresh();
    } else if (!fresh && steps % kStepsPerJacobian == 0) {
      if (out.iterations >= max_iterations) break;
      refresh();  // the carried Jacobian drifts from the true one: renewed every few steps
    }
  }
  out.at = problem.at(u);
  // The end on the orbits the fit followed (its last evaluation may have been a rejected trial).
  if (auto rf = predictor.residuals(out.at)) {
    out.r = std::move(*rf);
    out.rss = out.r.squaredNorm();
  } else {
    out.r = *r;  // the accepted point's own evaluation
  }
  out.orbits = predictor.last_orbits();
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
  int fits = 0;
  for (const std::size_t i : order) {
    if (fits >= max_fits || !std::isfinite(out.starts[i].rss_start)) break;
    const fit_result f = fit(problem, problem.of(starts[i].at), max_iterations, starts[i].orbits ? &*starts[i].orbits : nullptr);
    ++fits;
    out.starts[i].rss_fit = f.rss;
    if (f.ok && f.rss < out.best.rss) {
      out.best = f;
      out.winner = starts[i].name;
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
