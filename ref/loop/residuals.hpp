#pragma once
// What the loop measures on a residual (docs/loop.md, steps 4-5): the orbit error, the shaft-order
// spectrum, the synchronous energy, and whether the residual is consistent with probe noise.

#include <Eigen/Dense>
#include <algorithm>
#include <complex>
#include <string>
#include <vector>

#include "ref/loop/predictor.hpp"

namespace rubref {

struct correlation_check {
  std::string name;
  double value = 0.0, limit = 0.0;
  bool pass = false;
  double uncertainty = 0.0;  // how far the residual's own numerical error may move the value (residuals.cpp: exact or first order doubled)
  bool on_margin = false;    // the limit lies within it: whether the check passes is not decided
};

// Is the residual noise? Each check is a statistic against its limit at a 0.1 % false-alarm rate;
// `pass` is decided on the values, and is on the margin where no check fails beyond its
// uncertainty and one lies within it of its limit (evidence.hpp's rule).
struct validity_report {
  double noise = 0.0;                  // m, probe noise estimated from the data (4th differences, MAD)
  double rms = 0.0;                    // m, residual RMS over all samples
  correlation_check noise_level;       // rms / noise
  correlation_check synchronous;       // chi^2 / dof of shaft orders -H..H of the residual
  correlation_check whiteness;         // Box-Pierce Q / dof over lags 1..L
  std::vector<correlation_check> state;  // correlation of the residual with z+, z_dot, x, cos, sin of the shaft angle
  bool pass = false;
  bool on_margin = false;
};

// Energy of a residual's shaft orders -orders..orders (for a period-n dwell, the orders of w / n up
// to the same shaft order), sum over dwells of n |c_k|^2 (m^2) with c_k the mean of
// (r_x + i r_y) e^{-i k psi}, and its expectation under noise alone, sigma^2 dof
// (n |c_k|^2 / sigma^2 ~ chi^2(2) per order and dwell): the synchronous check and the trace's
// share rule measure this.
struct synchronous_energy {
  double energy = 0.0, dof = 0.0;
  double excess(double noise) const { return std::max(energy - noise * noise * dof, 0.0); }
  // The energy above sigma^2 dof that the synchronous check still calls noise (its limit, in m^2):
  // a change of the residual smaller than this is one the check cannot see.
  double tolerance(double noise) const;
};
synchronous_energy synchronous_part(const std::vector<loop_dwell>& dwells, const orbit_predictor& pr, const model_point& m,
                                    const Eigen::VectorXd& r, int orders);

// Order coefficients c_k = mean(z e^{-i k psi}), k = -orders..orders, of the complex residual
// z = r_x + i r_y of the dwell whose rows start at `at`; psi = w t / periods (1: shaft orders).
std::vector<std::complex<double>> order_coefficients(const dwell& d, const Eigen::VectorXd& r, std::size_t at, double shift, int orders,
                                                     int periods = 1);

// Orbit errors: per dwell, and the NRMSE over the dwells with contact,
// sqrt(sum |model - measured|^2 / sum |measured - dwell mean|^2).
struct error_totals {
  double nrmse_contact = 0.0;
  std::vector<double> rms, nrmse;  // per dwell
};
error_totals errors_of(const std::vector<loop_dwell>& dwells, const orbit_predictor& pr, const Eigen::VectorXd& r);

// The validity checks on the residual r of model m (after a residuals() call at m). `residual_error`
// bounds how far r may lie from the exact fit's residual (m, a vector norm: residual_error_of) and
// gives each check's uncertainty.
validity_report validity(const std::vector<loop_dwell>& dwells, const orbit_predictor& pr, const model_point& m, const Eigen::VectorXd& r,
                         double noise, int orders, int whiteness_lags, double residual_error = 0.0);

// The norm of a residual vector's numerical error from its |r|^2's uncertainty u (m^2): the e with
// (|r| + e)^2 = |r|^2 + u, i.e. the error that moves |r|^2 by u at most (cost_uncertainty's bound
// read backwards).
double residual_error_of(const Eigen::VectorXd& r, double cost_uncertainty);

// Error reduction ratio of the columns S (after removing what J already spans) on r. `outside`
// (m^2): the residual's energy no column can reach (the data's part outside the harmonic band, for
// rows in harmonics, orbit_predictor::harmonic_residuals), counted in the ratio's denominator.
double err_score(const Eigen::MatrixXd& J, const Eigen::MatrixXd& S, const Eigen::VectorXd& r, double outside = 0.0);

}  // namespace rubref
