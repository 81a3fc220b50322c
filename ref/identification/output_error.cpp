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
#include "ref/inference/least_squares.hpp"
#include "ref/orbits/fit_orbits.hpp"
#include "variants/identified.hpp"

namespace rubref {

namespace {


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

  // Residuals (x then y per sample, dwell after dwell) of the model with parameters p, and the
  // first dwell whose orbit cannot be computed (`failure`: then the residuals are not to be read);
  // empty when every orbit was computed.
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
  // Each dwell's x and y residuals in time order (their correlation factor's series).
  std::vector<residual_series> series() const {
    std::vector<residual_series> out;
    Eigen::Index at = 0;
    for (const auto& d : dwells_) {
      const auto n = static_cast<Eigen::Index>(d.source->size() - first_sample(*d.source));
      out.push_back({at, n, 2}), out.push_back({at + 1, n, 2});
      at += 2 * n;
    }
    return out;
  }

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
    // Sampled as every fit's orbit (ref/orbits/fit_orbits.hpp), over the dwell's revolutions.
    const double span = static_cast<double>(n - 1) * d.dt;
    const integration_options opt = fit_sampling(1 + static_cast<int>(std::ceil(span * std::abs(w) / (2.0 * std::numbers::pi))));
    Eigen::VectorXd r = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(2 * n));  // never read where `failure` is set
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

  // The model's periodic orbit through a state near `guess` at t0, as every fit's
  // (ref/orbits/fit_orbits.hpp: Newton with the exact monodromy, to the shooting's 1e-12 m): from
  // a cycle of the data it converges in a few iterations. A periodic cycle is compared with this
  // orbit: no dependence on a noisy initial velocity, and no drift onto a coexisting attractor.
  static state_type periodic_orbit(const rotor_system<identified>& model, const state_type& guess, double t0) {
    const auto orbit = shoot_fit_orbit(model, guess, t0);
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

void reid_settings::validate() const {
  check_reid_fit(fit);
  check({"reidentify", "max_jacobians"}, max_jacobians);
  check({"reidentify", "global_evaluations"}, global_evaluations);
  check({"reidentify", "derivative_half_width"}, derivative_half_width);
}

namespace {

// The fitted parameters' members and scales (their starts): u = value / start.
struct scaled_parameters {
  std::vector<double parameters::*> members;
  std::vector<double> scale;
  parameters start;
  parameters at(const Eigen::VectorXd& u) const {
    parameters p = start;
    for (Eigen::Index i = 0; i < u.size(); ++i) p.*members[static_cast<std::size_t>(i)] = u[i] * scale[static_cast<std::size_t>(i)];
    return p;
  }
};

scaled_parameters scaled(const std::vector<std::string>& fit, const parameters& start) {
  scaled_parameters out{{}, {}, start};
  for (const auto& name : fit) {
    out.members.push_back(member_named(name));
    const double v = start.*out.members.back();
    if (!(v > 0.0)) {
      std::ostringstream msg;
      msg << "re-identification of '" << name << "' needs a positive starting value";
      throw input_error(msg.str());
    }
    out.scale.push_back(v);
  }
  return out;
}

// The global stage (DIRECT-L over [0.1, 10] x start): only a start for the solver. DIRECT needs a
// number at every point it samples: one whose orbit cannot be computed is ranked last (the mean
// square of 1 m residuals, far above any orbit error); the solver never sees such a number.
Eigen::VectorXd global_start(const orbit_error& err, const scaled_parameters& sp, const reid_settings& s, reid_result& out) {
  const auto n = sp.members.size();
  std::vector<double> u(n, 1.0);
  struct context {
    const orbit_error* err;
    const scaled_parameters* sp;
    reid_result* out;
  } ctx{&err, &sp, &out};
  const auto objective = [](const std::vector<double>& x, std::vector<double>&, void* data) {
    auto* c = static_cast<context*>(data);
    ++c->out->evaluations;
    const auto e = c->err->residuals(c->sp->at(Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size()))));
    if (!e.failure.empty()) {
      ++c->out->failed_evaluations;
      if (c->out->failure.empty()) c->out->failure = e.failure;
      return 1.0;
    }
    return e.r.squaredNorm() / static_cast<double>(e.r.size());
  };
  nlopt::opt global(nlopt::GN_DIRECT_L, static_cast<unsigned>(n));
  global.set_lower_bounds(std::vector<double>(n, 0.1));
  global.set_upper_bounds(std::vector<double>(n, 10.0));
  global.set_min_objective(objective, &ctx);
  global.set_maxeval(s.global_evaluations);
  double f = 0.0;
  try {
    global.optimize(u, f);
  } catch (const nlopt::roundoff_limited&) {
  }
  return Eigen::Map<const Eigen::VectorXd>(u.data(), static_cast<Eigen::Index>(n));
}

}  // namespace

reid_result reidentify(const std::vector<dwell_forces>& dwells, const parameters& start, double unbalance_phase, const reid_settings& s) {
  s.validate();
  if (dwells.empty()) throw input_error("re-identification needs at least one dwell with contact");
  const scaled_parameters sp = scaled(s.fit, start);
  const bool fit_clearance = std::find(s.fit.begin(), s.fit.end(), "clearance") != s.fit.end();
  if (fit_clearance)
    for (const auto& d : dwells)
      if (d.source->clearance > 0.0 && d.source->clearance != dwells.front().source->clearance)
        throw input_error("re-identification of the clearance needs records of one clearance");
  const orbit_error err(dwells, unbalance_phase, s.derivative_half_width, fit_clearance);
  reid_result out;
  // The orbit errors' RMS at u, or NaN where an orbit cannot be computed (never a number then).
  const auto rms_or_nan = [&](const Eigen::VectorXd& u, bool& failed) {
    const auto e = err.residuals(sp.at(u));
    failed = !e.failure.empty();
    if (failed && out.failure.empty()) out.failure = e.failure;
    return failed ? std::numeric_limits<double>::quiet_NaN() : std::sqrt(e.r.squaredNorm() / static_cast<double>(2 * err.samples()));
  };
  const auto n = static_cast<Eigen::Index>(sp.members.size());
  out.initial_rms = rms_or_nan(Eigen::VectorXd::Ones(n), out.initial_failed);
  out.algorithm = "least squares (ref/inference)";
  Eigen::VectorXd u0 = Eigen::VectorXd::Ones(n);
  if (s.global) {
    u0 = global_start(err, sp, s, out);
    out.algorithm = "NLopt GN_DIRECT_L (start), then least squares (ref/inference)";
  }
  // The solver on the orbit residuals (m): scaled parameters u = value / start in [0, 10]
  // (positive laws, and room for a start 10x off); a failed orbit is a rejected point.
  least_squares_problem lsq;
  lsq.residuals = [&](const Eigen::VectorXd& u) -> std::optional<Eigen::VectorXd> {
    ++out.evaluations;
    auto e = err.residuals(sp.at(u));
    if (e.failure.empty()) return std::move(e.r);
    ++out.failed_evaluations;
    if (out.failure.empty()) out.failure = e.failure;
    return std::nullopt;
  };
  lsq.lower = Eigen::VectorXd::Zero(n);
  lsq.upper = Eigen::VectorXd::Constant(n, 10.0);
  lsq.noise = kOrbitNoiseFloor;
  least_squares_options o;
  o.max_jacobians = s.max_jacobians;
  o.difference_step = default_of("reidentify", "difference_step");
  const least_squares_result fit = solve_least_squares(lsq, u0, o);
  const Eigen::VectorXd& u = fit.u;
  out.final_rms = rms_or_nan(u, out.final_failed);

  // Standard errors from the covariance at the end: the residuals' own scatter (never below the
  // noise floor) is their noise; a parameter the orbit barely feels has a huge standard error, one
  // in a direction the data do not constrain an infinite one.
  std::vector<residual_series> series;
  fit_covariance cc;
  if (fit.ok && !out.final_failed) {
    const Eigen::MatrixXd J = forward_difference_jacobian(lsq, u, fit.r, o.difference_step);
    const double dof = std::max(1.0, static_cast<double>(fit.r.size()) - static_cast<double>(n));
    cc = covariance_of(J, fit.r, std::max(std::sqrt(fit.r.squaredNorm() / dof), kOrbitNoiseFloor), err.series());
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double value = u[i] * sp.scale[k];
    const double se = cc.cov.size() ? cc.standard_deviation(i) * sp.scale[k] : std::numeric_limits<double>::infinity();
    const bool felt = std::isfinite(se);
    // On a bound: within 1e-9 of 0 or 10 in the scaled unknown (the projection ends exactly on an active bound).
    const bool at_bound = u[i] <= 1e-9 || u[i] >= 10.0 - 1e-9;
    out.parameters.push_back({s.fit[k], sp.scale[k], value, se, felt && value > 1.96 * se && !out.final_failed, at_bound});
  }
  return out;
}

}  // namespace rubref
