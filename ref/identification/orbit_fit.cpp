#include "ref/identification/orbit_fit.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <boost/math/distributions/chi_squared.hpp>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/identification/output_error.hpp"
#include "ref/inference/least_squares.hpp"
#include "ref/integrate/hybrid_integrator.hpp"
#include "ref/orbits/fit_orbits.hpp"
#include "variants/identified.hpp"

namespace rubref {

namespace {

// Central differences in the scaled unknowns (relative to the start): far above the shooting's
// 1e-12 m over the noise floor's 1e-8 m, far below the ~0.5 % the data resolve.
constexpr double kDifferenceStep = 1e-4;

class cycles_model {
 public:
  cycles_model(const std::vector<orbit_fit_cycle>& cycles, const parameters& start, const std::vector<std::string>& terms)
      : cycles_(cycles), start_(start), terms_(terms) {
    for (const auto& t : terms_) {
      if (t != "k1" && t != "k3" && t != "c2") throw input_error("orbit fit: unknown law term '" + t + "' (k1, k3, c2)");
      const double v = start.*member(t);
      scale_.push_back(v != 0.0 ? std::abs(v) : 1.0);
    }
    // mu's scale: its start, or 0.01 (friction too small to scale by).
    scale_.push_back(std::max(start.mu, 0.01));
    // The dampings: their starts (> 0 by validation of the linear part).
    scale_.push_back(start.c_x > 0.0 ? start.c_x : 1.0);
    scale_.push_back(start.c_y > 0.0 ? start.c_y : 1.0);
    scale_.push_back(start.k_x);  // > 0 by validation
    scale_.push_back(start.k_y);
    e_scale_ = start.e > 0.0 ? start.e : 1e-6;
    for (const auto& c : cycles_) {
      if (c.forces == nullptr || !c.forces->source->periodic)
        throw input_error("orbit fit: every cycle must be a synchronously averaged (periodic) dwell");
      const dwell& d = *c.forces->source;
      const std::size_t n = d.size();
      // The first guess: the cycle's own state at its first sample (velocities by the filter, or
      // the periodic central difference where the filter has none).
      const auto rate = [&](const std::vector<double>& v, const std::vector<double>& filtered) {
        return std::isfinite(filtered[0]) ? filtered[0] : (v[1] - v[n - 1]) / (2.0 * d.dt);
      };
      guess_.push_back(state_type{d.x[0], d.y[0], rate(d.x, c.forces->vx), rate(d.y, c.forces->vy)});
      offset_.push_back(residuals_);
      residuals_ += 2 * n;
    }
  }

  Eigen::Index unknowns() const { return static_cast<Eigen::Index>(shared() + 2 * cycles_.size()); }
  Eigen::Index residuals() const { return static_cast<Eigen::Index>(residuals_); }
  std::size_t shared() const { return scale_.size(); }
  double scale(std::size_t j) const { return scale_[j]; }

  Eigen::VectorXd start() const {
    Eigen::VectorXd u(unknowns());
    for (std::size_t j = 0; j < terms_.size(); ++j) u[static_cast<Eigen::Index>(j)] = (start_.*member(terms_[j])) / scale_[j];
    const auto shared_law = static_cast<Eigen::Index>(terms_.size());
    u[shared_law] = start_.mu / scale_[terms_.size()];
    u[shared_law + 1] = start_.c_x / scale_[terms_.size() + 1];
    u[shared_law + 2] = start_.c_y / scale_[terms_.size() + 2];
    u[shared_law + 3] = 1.0;
    u[shared_law + 4] = 1.0;
    for (std::size_t k = 0; k < cycles_.size(); ++k) {
      u[forcing(k)] = start_.e / e_scale_ * std::cos(start_.unbalance_phase);
      u[forcing(k) + 1] = start_.e / e_scale_ * std::sin(start_.unbalance_phase);
    }
    return u;
  }

  // Cycle k's model parameters at u.
  parameters at(const Eigen::VectorXd& u, std::size_t k) const {
    parameters q = start_;
    q.k1 = q.k3 = q.c2 = 0.0;
    for (std::size_t j = 0; j < terms_.size(); ++j) q.*member(terms_[j]) = u[static_cast<Eigen::Index>(j)] * scale_[j];
    const auto shared_law = static_cast<Eigen::Index>(terms_.size());
    q.mu = u[shared_law] * scale_[terms_.size()];
    q.c_x = u[shared_law + 1] * scale_[terms_.size() + 1];
    q.c_y = u[shared_law + 2] * scale_[terms_.size() + 2];
    q.k_x = u[shared_law + 3] * scale_[terms_.size() + 3];
    q.k_y = u[shared_law + 4] * scale_[terms_.size() + 4];
    const double a = u[forcing(k)], b = u[forcing(k) + 1];
    q.e = e_scale_ * std::hypot(a, b);
    q.unbalance_phase = std::atan2(b, a);
    const dwell& d = *cycles_[k].forces->source;
    if (d.clearance > 0.0) q.clearance = d.clearance;  // each record keeps its own clearance
    return q;
  }

  // All whitened residuals at u, or nothing where some cycle's orbit cannot be computed (the
  // solver rejects the point); the cycles' orbits become the next evaluation's first guesses.
  std::optional<Eigen::VectorXd> evaluate(const Eigen::VectorXd& u) {
    Eigen::VectorXd r(residuals());
    std::vector<int> failed(cycles_.size(), 0);
    parallel_for(cycles_.size(), 0, [&](std::size_t k) {
      state_type orbit = guess_[k];
      const bool ok = cycle_residuals(k, at(u, k), orbit, r.segment(offset(k), size(k)));
      if (ok) guess_[k] = orbit;
      failed[k] = ok ? 0 : 1;
    });
    for (std::size_t k = 0; k < cycles_.size(); ++k) failed_ += failed[k];
    last_failed_ = std::count(failed.begin(), failed.end(), 1) > 0;
    ++evaluations_;
    if (last_failed_) return std::nullopt;
    return r;
  }

  // Central differences (one-sided where one side's orbit cannot be computed; a column with
  // neither is 0, held for the step); cycle k's residuals depend on the shared unknowns and its own
  // forcing only.
  Eigen::MatrixXd jacobian(const Eigen::VectorXd& u, const Eigen::VectorXd& r0) const {
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(residuals(), unknowns());
    parallel_for(cycles_.size(), 0, [&](std::size_t k) {
      std::vector<Eigen::Index> columns;
      for (std::size_t j = 0; j < shared(); ++j) columns.push_back(static_cast<Eigen::Index>(j));
      columns.push_back(forcing(k));
      columns.push_back(forcing(k) + 1);
      Eigen::VectorXd up(size(k)), down(size(k));
      const auto base = r0.segment(offset(k), size(k));
      for (const auto c : columns) {
        Eigen::VectorXd u1 = u, u2 = u;
        u1[c] += kDifferenceStep;
        u2[c] -= kDifferenceStep;
        state_type g1 = guess_[k], g2 = guess_[k];
        const bool ok_up = cycle_residuals(k, at(u1, k), g1, up), ok_down = cycle_residuals(k, at(u2, k), g2, down);
        auto column = J.block(offset(k), c, size(k), 1);
        if (ok_up && ok_down) column = (up - down) / (2.0 * kDifferenceStep);
        else if (ok_up) column = (up - base) / kDifferenceStep;
        else if (ok_down) column = (base - down) / kDifferenceStep;
      }
    });
    return J;
  }

  // Each cycle's forcing phase set to the best (smallest residual) of `count` phases around the
  // circle and its current one, the law and the linear part as in u.
  void search_phases(Eigen::VectorXd& u, int count) {
    const Eigen::VectorXd base = u;  // read by every cycle; each writes only its own forcing into u
    parallel_for(cycles_.size(), 0, [&](std::size_t k) {
      const double a = base[forcing(k)], b = base[forcing(k) + 1], size = std::hypot(a, b);
      Eigen::VectorXd r(this->size(k));
      double best = std::numeric_limits<double>::infinity();
      std::pair<double, double> chosen{a, b};
      state_type chosen_orbit = guess_[k];
      for (int j = -1; j < count; ++j) {
        Eigen::VectorXd trial = base;
        if (j >= 0) {
          const double phase = 2.0 * std::numbers::pi * j / count;
          trial[forcing(k)] = size * std::cos(phase), trial[forcing(k) + 1] = size * std::sin(phase);
        }
        state_type orbit = guess_[k];
        if (!cycle_residuals(k, at(trial, k), orbit, r)) continue;  // never read: that phase is not chosen
        if (r.squaredNorm() < best) best = r.squaredNorm(), chosen = {trial[forcing(k)], trial[forcing(k) + 1]}, chosen_orbit = orbit;
      }
      u[forcing(k)] = chosen.first, u[forcing(k) + 1] = chosen.second;
      guess_[k] = chosen_orbit;
    });
  }

  int evaluations() const { return evaluations_; }
  int failed() const { return failed_; }
  bool last_failed() const { return last_failed_; }

 private:
  static double parameters::*member(const std::string& t) {
    return t == "k1" ? &parameters::k1 : t == "k3" ? &parameters::k3 : &parameters::c2;
  }
  Eigen::Index forcing(std::size_t k) const { return static_cast<Eigen::Index>(shared() + 2 * k); }
  Eigen::Index offset(std::size_t k) const { return static_cast<Eigen::Index>(offset_[k]); }
  Eigen::Index size(std::size_t k) const { return static_cast<Eigen::Index>(2 * cycles_[k].forces->source->size()); }

  // The periodic orbit of cycle k's model near `orbit` (updated to it), sampled on the cycle's grid:
  // (x_sim - x, y_sim - y) / noise per sample. False where it cannot be computed (r then holds
  // nothing to read).
  template <class Out>
  bool cycle_residuals(std::size_t k, const parameters& q, state_type& orbit, Out&& r) const {
    const dwell& d = *cycles_[k].forces->source;
    const std::size_t n = d.size();
    const double noise = std::max(cycles_[k].noise, kOrbitNoiseFloor);
    try {
      const rotor_system<identified> model(q, d.omega());
      // Shot and sampled as every fit's orbit (ref/orbits/fit_orbits.hpp): from the previous orbit
      // of the same cycle Newton converges in a few iterations.
      const double t0 = d.t[0];
      const auto shot = shoot_fit_orbit(model, orbit, t0);
      if (!shot.converged) return false;
      const integration_options opt = fit_sampling();
      position_recorder rec;
      rec.x.reserve(n);
      rec.y.reserve(n);
      integrate_hybrid(model, start_state(model, shot.state, t0), t0 + static_cast<double>(n - 1) * d.dt, opt,
                       sample_grid{t0, d.dt, n}, rec);
      if (rec.x.size() < n) return false;
      for (std::size_t i = 0; i < n; ++i) {
        r[static_cast<Eigen::Index>(2 * i)] = (rec.x[i] - d.x[i]) / noise;
        r[static_cast<Eigen::Index>(2 * i + 1)] = (rec.y[i] - d.y[i]) / noise;
      }
      orbit = shot.state;
      return true;
    } catch (const numerical_error&) {
      return false;
    }
  }

  const std::vector<orbit_fit_cycle>& cycles_;
  parameters start_;
  std::vector<std::string> terms_;
  std::vector<double> scale_;
  double e_scale_ = 1.0;
  std::vector<state_type> guess_;
  std::vector<std::size_t> offset_;
  std::size_t residuals_ = 0;
  int evaluations_ = 0, failed_ = 0;
  bool last_failed_ = false;
};

}  // namespace

void orbit_fit_settings::validate() const {
  check({"orbit_fit", "max_jacobians"}, max_jacobians);
  check({"orbit_fit", "phase_search"}, phase_search);
}

orbit_fit_result fit_periodic_orbits(const std::vector<orbit_fit_cycle>& cycles, const parameters& start,
                                     const std::vector<std::string>& terms, const orbit_fit_settings& s) {
  s.validate();
  if (cycles.empty()) throw input_error("orbit fit: no averaged cycle to fit");
  cycles_model model(cycles, start, terms);
  orbit_fit_result out;
  out.residuals = static_cast<std::size_t>(model.residuals());
  out.unknowns = static_cast<std::size_t>(model.unknowns());
  const double dof = std::max(1.0, static_cast<double>(out.residuals) - static_cast<double>(out.unknowns));

  Eigen::VectorXd start_values = model.start();
  if (s.phase_search > 0) model.search_phases(start_values, s.phase_search);
  const auto initial = model.evaluate(start_values);
  out.initial_chi2 = initial ? initial->squaredNorm() / dof : std::numeric_limits<double>::infinity();
  // The one solver (ref/inference/least_squares.hpp) on the whitened residuals.
  least_squares_problem lsq;
  lsq.residuals = [&model](const Eigen::VectorXd& u) { return model.evaluate(u); };
  lsq.jacobian = [&model](const Eigen::VectorXd& u, const Eigen::VectorXd& r) { return model.jacobian(u, r); };
  least_squares_options o;
  o.max_jacobians = s.max_jacobians;
  const least_squares_result fit = solve_least_squares(lsq, start_values, o);
  out.iterations = fit.jacobians;
  out.status = fit.status;
  const Eigen::VectorXd& u = fit.u;
  const auto final_r = model.evaluate(u);
  out.evaluations = model.evaluations();
  out.failed_evaluations = model.failed();
  out.converged = fit.ok && fit.converged && final_r.has_value();
  if (!final_r) {
    out.status = "failed: the final parameters' orbit could not be computed";
    out.final_chi2 = out.final_rms = std::numeric_limits<double>::quiet_NaN();
  }
  for (std::size_t k = 0; k < cycles.size(); ++k) {
    const parameters q = model.at(u, k);
    out.e.push_back(q.e);
    out.phase.push_back(q.unbalance_phase);
  }
  std::vector<std::string> names = terms;
  names.insert(names.end(), {"mu", "c_x", "c_y", "k_x", "k_y"});
  if (!final_r) {
    for (std::size_t j = 0; j < names.size(); ++j) {
      const auto jj = static_cast<Eigen::Index>(j);
      out.parameters.push_back({names[j], start_values[jj] * model.scale(j), u[jj] * model.scale(j), std::numeric_limits<double>::infinity()});
    }
    return out;
  }
  const Eigen::VectorXd& r = *final_r;
  out.final_chi2 = r.squaredNorm() / dof;
  {
    // The orbits' error per sample over the smallest noise (the residuals are whitened).
    double smallest = std::numeric_limits<double>::infinity();
    for (const auto& c : cycles) smallest = std::min(smallest, std::max(c.noise, kOrbitNoiseFloor));
    out.sum_uncertainty = cost_uncertainty(r, fit.remaining, fit_orbit_options{}.orbit_error() / smallest);
  }
  double sq = 0.0;
  Eigen::Index at = 0;
  std::vector<residual_series> series;  // each cycle's x (even entries) and y (odd entries) in time order
  for (const auto& c : cycles) {
    const double noise = std::max(c.noise, kOrbitNoiseFloor);
    const auto n = static_cast<Eigen::Index>(c.forces->source->size());
    sq += r.segment(at, 2 * n).squaredNorm() * noise * noise;
    series.push_back({at, n, 2}), series.push_back({at + 1, n, 2});
    at += 2 * n;
  }
  out.final_rms = std::sqrt(sq / static_cast<double>(out.residuals));
  // Covariance: (J'J)^-1 on whitened residuals, times the residual's excess over the noise when
  // the model leaves more than noise (never narrowed below what the noise gives), times the
  // residuals' correlation factor.
  const fit_covariance cc = covariance_of(model.jacobian(u, r), r, 1.0, series);
  out.correlation_factor = cc.correlation;
  for (std::size_t j = 0; j < names.size(); ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    out.parameters.push_back({names[j], start_values[jj] * model.scale(j), u[jj] * model.scale(j), cc.standard_deviation(jj) * model.scale(j)});
  }
  return out;
}

double orbit_fit_chi2_limit(const orbit_fit_result& o) {
  const double dof = std::max(1.0, static_cast<double>(o.residuals) - static_cast<double>(o.unknowns));
  return boost::math::quantile(boost::math::chi_squared(dof), 0.999) / dof;
}

}  // namespace rubref
