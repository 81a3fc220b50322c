#include "ref/identification/output_error.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <nlopt.hpp>
#include <sstream>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/integrate/hybrid_integrator.hpp"
#include "ref/integrate/shooting.hpp"
#include "variants/identified.hpp"

namespace rubref {

namespace {

// Newton shooting for the model's periodic orbit near an averaged cycle (to the shooting's 1e-12 m,
// far below probe resolution): from a cycle of the data it converges in a few iterations; a trial
// law that needs more, or 10^5 steps per revolution, is far off the data.
constexpr int kShootIterations = 12;
constexpr std::size_t kMaxStepsPerRevolution = 100000;

// The parameter a re-identification fits, named as in the registry (ref/model/settings.hpp):
// the contact law's, the friction, the unbalance and the clearance (the rotor's are identified
// by the linear step).
double parameters::*member_named(const std::string& name) {
  const std::vector<std::string> fittable{"k1", "k3", "c2", "mu", "e", "clearance"};
  if (std::find(fittable.begin(), fittable.end(), name) == fittable.end()) {
    std::ostringstream msg;  // (not "literal" + string: GCC 12 raises a false -Wrestrict on it)
    msg << "re-identification: unknown parameter '" << name << "'" << did_you_mean(name, fittable) << " (k1, k3, c2, mu, e, clearance)";
    throw input_error(msg.str());
  }
  return parameter_member(name);
}

class orbit_error {
 public:
  orbit_error(const std::vector<dwell_forces>& dwells, double phase, int first, bool fit_clearance)
      : dwells_(dwells), phase_(phase), first_(first), fit_clearance_(fit_clearance) {
    for (const auto& d : dwells_) samples_ += d.source->size() - first_sample(*d.source);
  }

  // Residuals (x then y per sample, dwell after dwell) of the model with parameters p. Where a
  // dwell's orbit cannot be computed its residuals are 1 m (far off, for the optimiser) and
  // `failure` names the first such dwell; empty when every orbit was computed.
  struct evaluation {
    Eigen::VectorXd r;
    std::string failure;
  };
  evaluation residuals(const parameters& p) const {
    std::vector<Eigen::VectorXd> parts(dwells_.size());
    std::vector<std::string> failures(dwells_.size());
    parallel_for(dwells_.size(), 0, [&](std::size_t k) { parts[k] = dwell_residuals(dwells_[k], p, failures[k]); });
    evaluation out;
    out.r.resize(static_cast<Eigen::Index>(2 * samples_));
    Eigen::Index at = 0;
    for (std::size_t k = 0; k < parts.size(); ++k) {
      out.r.segment(at, parts[k].size()) = parts[k];
      at += parts[k].size();
      if (out.failure.empty() && !failures[k].empty()) out.failure = dwells_[k].source->source + ": " + failures[k];
    }
    return out;
  }
  std::size_t samples() const { return samples_; }

 private:
  Eigen::VectorXd dwell_residuals(const dwell_forces& f, const parameters& p, std::string& failure) const {
    const dwell& d = *f.source;
    parameters q = p;
    if (!fit_clearance_ && d.clearance > 0.0) q.clearance = d.clearance;  // each record keeps its own clearance
    const double w = d.omega();
    const std::size_t i0 = first_sample(d), n = d.size() - i0;
    q.unbalance_phase = phase_;  // the fitted or given unbalance angle at t = 0
    const double t0 = d.t[i0];
    const rotor_system<identified> model(q, w);
    integration_options opt;
    opt.stepper.rtol = 1e-10;
    opt.stepper.atol = 1e-14;
    Eigen::VectorXd r(2 * n);
    r.setConstant(1.0);  // 1 m: a parameter set the integrator cannot follow is far off
    try {
      state_type s0{d.x[i0], d.y[i0], f.vx[i0], f.vy[i0]};
      if (d.periodic) s0 = periodic_orbit(model, s0, t0);
      position_recorder rec;
      rec.x.reserve(n);
      rec.y.reserve(n);
      integrate_hybrid(model, start_state(model, s0, t0), t0 + static_cast<double>(n - 1) * d.dt, opt,
                       sample_grid{t0, d.dt, n}, rec);
      if (rec.x.size() < n) failure = "the simulated orbit ended after " + std::to_string(rec.x.size()) + " of " + std::to_string(n) + " samples";
      for (std::size_t i = 0; i < n && i < rec.x.size(); ++i) {
        r[static_cast<Eigen::Index>(2 * i)] = rec.x[i] - d.x[i0 + i];
        r[static_cast<Eigen::Index>(2 * i + 1)] = rec.y[i] - d.y[i0 + i];
      }
    } catch (const numerical_error& e) {
      failure = e.what();
    }
    return r;
  }

  // The model's periodic orbit through a state near `guess` at t0, by the one shooting routine
  // (ref/integrate/shooting.hpp: Newton with the exact monodromy). A periodic cycle is compared with
  // this orbit: no dependence on a noisy initial velocity, and no drift onto a coexisting attractor.
  static state_type periodic_orbit(const rotor_system<identified>& model, const state_type& guess, double t0) {
    shooting_settings set;
    set.max_iterations = kShootIterations;
    set.integration.max_steps = kMaxStepsPerRevolution;
    const auto orbit = shoot_periodic_orbit(model, guess, t0, 1, set);
    if (!orbit.converged) throw numerical_error("shooting: " + orbit.failure);
    return orbit.state;
  }

  std::size_t first_sample(const dwell& d) const { return d.periodic ? 0 : static_cast<std::size_t>(first_); }

  const std::vector<dwell_forces>& dwells_;
  double phase_;
  int first_;
  bool fit_clearance_;
  std::size_t samples_ = 0;
};

}  // namespace

void check_reid_fit(const std::vector<std::string>& fit) {
  for (const auto& name : fit) member_named(name);
}

reid_result reidentify(const std::vector<dwell_forces>& dwells, const parameters& start, double unbalance_phase,
                       const reid_settings& s) {
  if (dwells.empty()) throw input_error("re-identification needs at least one dwell with contact");
  std::vector<double parameters::*> members;
  std::vector<double> scale;
  for (const auto& name : s.fit) {
    members.push_back(member_named(name));
    const double v = start.*members.back();
    if (!(v > 0.0)) {
      std::ostringstream msg;
      msg << "re-identification of '" << name << "' needs a positive starting value";
      throw input_error(msg.str());
    }
    scale.push_back(v);
  }
  const bool fit_clearance = std::find(s.fit.begin(), s.fit.end(), "clearance") != s.fit.end();
  if (fit_clearance)
    for (const auto& d : dwells)
      if (d.source->clearance > 0.0 && d.source->clearance != dwells.front().source->clearance)
        throw input_error("re-identification of the clearance needs records of one clearance");
  const orbit_error err(dwells, unbalance_phase, s.derivative_half_width, fit_clearance);
  const auto at = [&](const std::vector<double>& u) {
    parameters p = start;
    for (std::size_t i = 0; i < u.size(); ++i) p.*members[i] = u[i] * scale[i];
    return p;
  };
  // Minimise the mean square, smooth at a perfect fit (its square root, the RMS, is a cone there
  // and stalls BOBYQA's quadratic models); report the RMS. Failed orbits are counted: the
  // optimiser sees their 1 m penalty, the result never reports it as an orbit error.
  reid_result out;
  const auto mean_square = [&](const std::vector<double>& u) {
    const auto e = err.residuals(at(u));
    if (!e.failure.empty()) {
      ++out.failed_evaluations;
      if (out.failure.empty()) out.failure = e.failure;
    }
    return e.r.squaredNorm() / static_cast<double>(2 * err.samples());
  };
  const auto rms_or_nan = [&](const std::vector<double>& u, bool& failed) {
    const auto e = err.residuals(at(u));
    failed = !e.failure.empty();
    if (failed && out.failure.empty()) out.failure = e.failure;
    return failed ? std::numeric_limits<double>::quiet_NaN() : std::sqrt(e.r.squaredNorm() / static_cast<double>(2 * err.samples()));
  };

  std::vector<double> u(members.size(), 1.0);
  out.initial_rms = rms_or_nan(u, out.initial_failed);
  struct context {
    const decltype(mean_square)* f;
    int calls = 0;
  } ctx{&mean_square};
  const auto objective = [](const std::vector<double>& x, std::vector<double>&, void* data) {
    auto* c = static_cast<context*>(data);
    ++c->calls;
    return (*c->f)(x);
  };
  // Scaled parameters u = value / start live in [0, 10]: positive laws, and room for a start 10x off.
  const std::vector<double> lower(u.size(), 0.0), upper(u.size(), 10.0);
  out.algorithm = "NLopt LN_BOBYQA";
  if (s.global) {
    nlopt::opt global(nlopt::GN_DIRECT_L, static_cast<unsigned>(u.size()));
    global.set_lower_bounds(std::vector<double>(u.size(), 0.1));
    global.set_upper_bounds(upper);
    global.set_min_objective(objective, &ctx);
    global.set_maxeval(s.max_evaluations);
    double f = 0.0;
    try {
      global.optimize(u, f);
    } catch (const nlopt::roundoff_limited&) {
    }
    out.algorithm = "NLopt GN_DIRECT_L, then LN_BOBYQA";
  }
  nlopt::opt local(nlopt::LN_BOBYQA, static_cast<unsigned>(u.size()));
  local.set_lower_bounds(lower);
  local.set_upper_bounds(upper);
  local.set_min_objective(objective, &ctx);
  local.set_xtol_rel(s.relative_tolerance);
  local.set_maxeval(s.max_evaluations);
  local.set_initial_step(std::vector<double>(u.size(), 0.05));
  double f = 0.0;
  try {
    local.optimize(u, f);
  } catch (const nlopt::roundoff_limited&) {
    // The objective stopped improving at rounding level: u holds the best point.
  }
  out.evaluations = ctx.calls;
  out.final_rms = rms_or_nan(u, out.final_failed);

  // Standard errors from the Jacobian of the residuals (central differences in u).
  const Eigen::VectorXd r0 = err.residuals(at(u)).r;
  Eigen::MatrixXd J(r0.size(), static_cast<Eigen::Index>(u.size()));
  constexpr double kStep = 1e-4;  // relative: well above the 1e-9 integration tolerance
  for (std::size_t i = 0; i < u.size(); ++i) {
    auto up = u, down = u;
    up[i] += kStep;
    down[i] -= kStep;
    J.col(static_cast<Eigen::Index>(i)) = (err.residuals(at(up)).r - err.residuals(at(down)).r) / (2 * kStep);
  }
  const double dof = std::max(1.0, static_cast<double>(r0.size()) - static_cast<double>(u.size()));
  const double sigma = std::max(std::sqrt(r0.squaredNorm() / dof), kOrbitNoiseFloor);
  // Cov = sigma^2 (J'J)^-1. A parameter the orbit barely feels has a tiny pivot and so a huge
  // standard error; an exactly singular J'J leaves it undetermined (infinite).
  const Eigen::MatrixXd info = J.transpose() * J;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(info);
  const Eigen::MatrixXd cov = sigma * sigma * ldlt.solve(Eigen::MatrixXd::Identity(info.rows(), info.cols()));
  const bool solvable = ldlt.info() == Eigen::Success && ldlt.isPositive();
  for (std::size_t i = 0; i < u.size(); ++i) {
    const double se = std::sqrt(std::max(0.0, cov(i, i))) * scale[i];
    const double value = u[i] * scale[i];
    const bool felt = solvable && cov(i, i) > 0.0 && std::isfinite(se);
    // On a bound: within 1e-9 of 0 or 10 in the scaled unknown (BOBYQA ends exactly on an active bound).
    const bool at_bound = u[i] <= lower[i] + 1e-9 || u[i] >= upper[i] - 1e-9;
    out.parameters.push_back({s.fit[i], scale[i], value, felt ? se : std::numeric_limits<double>::infinity(),
                              felt && value > 1.96 * se && !out.final_failed, at_bound});
  }
  return out;
}

}  // namespace rubref
