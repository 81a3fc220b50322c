#pragma once
// The contact law refined by the periodic orbits themselves (docs/identification.md §5): the
// maximum-likelihood fit of averaged cycles, where the weak form is only a start.
//
// A synchronously averaged dwell is one revolution of a periodic orbit plus white noise. Its
// likelihood is that of the model's periodic orbit (Eq. 1 with the law, found by Newton shooting)
// sampled on the cycle's grid: the residual x_sim - x, y_sim - y over the whole revolution, not
// only around the contact. The contact's impulse moves every harmonic of the orbit, and hundreds
// of free-flight samples pin it down where the weak form's supports see only the pulse: on the
// issue's 2 um records the Cramer-Rao bound of k1 is ~0.5 %, the weak form's spread ~4.5 %.
// The model's z and z_dot come from the simulated orbit, never from the noisy data, so there are
// no errors in the variables.
//
// Unknowns: the law's terms among k1 z, k3 z^3, c2 z_dot^2, mu and the linear part's c_x, c_y,
// k_x, k_y (shared by all cycles; m is not identifiable, it is given), and per cycle its unbalance
// forcing, e (cos, sin)(phase) (a nuisance: it absorbs the cycle's timing and the free record's
// estimate of e). The linear part is refitted because the orbits resolve the law better than a
// free record resolves c and k: on the 2 um records, the free record's c_y 3.7 % low and
// k_y 0.06 % high (near resonance, 0.7 % of k_y - m w^2) left chi^2/dof 8.4 and k1 +16 % when held
// fixed, chi^2/dof 1.4 with the dampings alone fitted, and ~1 with all four (measured). With a
// per-cycle forcing, x and y together over several speeds still fix c and k. The one solver
// (ref/inference/least_squares.hpp) on the residuals whitened by each cycle's noise; standard
// errors from its covariance (scaled by the residual where it exceeds the noise, and by the
// residuals' correlation over neighbouring samples).

#include <string>
#include <vector>

#include "ref/identification/contact_forces.hpp"
#include "ref/model/parameters.hpp"
#include "ref/model/settings.hpp"

namespace rubref {

// An averaged cycle (dwell::periodic) with its forces (for the initial velocities) and the
// standard deviation of its samples' noise.
struct orbit_fit_cycle {
  const dwell_forces* forces = nullptr;
  double noise = 0.0;  // m
};

struct orbit_fit_settings {
  // Defaults, ranges and reasons: the settings registry (scope "orbit_fit").
  int max_jacobians = default_count_of("orbit_fit", "max_jacobians");  // of the least-squares solver
  // Cycles whose shaft angle is not known (times not on one angle): before the fit, each cycle's
  // forcing phase starts at the best of this many phases around the circle and its given start
  // (0: the given start).
  int phase_search = default_count_of("orbit_fit", "phase_search");
  void validate() const;  // input_error naming the setting
};

struct orbit_fit_parameter {
  std::string name;  // k1, k3, c2, mu
  double start, value, standard_error;
};

struct orbit_fit_result {
  std::vector<orbit_fit_parameter> parameters;  // the law's terms, then mu, c_x, c_y, k_x, k_y
  std::vector<double> e, phase;                 // per cycle: the fitted unbalance (m, rad)
  double initial_chi2 = 0.0, final_chi2 = 0.0;  // whitened residual sum of squares per degree of freedom
  // The whitened residual sum of squares' numerical uncertainty (not per degree of freedom): the
  // solver's unfinished descent (least_squares_result::remaining) and the orbits' error.
  double sum_uncertainty = 0.0;
  double final_rms = 0.0;                       // m, RMS of x_sim - x, y_sim - y
  // The residuals' long-run variance over their variance (ref/inference/least_squares.hpp,
  // correlation_factor; x and y series of every cycle pooled), at least 1: an averaged cycle
  // resampled off its grid by cubic interpolation has neighbouring samples that share raw ones, so
  // its noise is correlated over a few samples and (J'J)^-1 alone understates the covariance of
  // parameters that move the orbit smoothly. The covariance is scaled by it.
  double correlation_factor = 1.0;
  std::size_t residuals = 0, unknowns = 0;
  int iterations = 0, evaluations = 0, failed_evaluations = 0;  // Jacobians; residual evaluations; those whose orbit failed
  bool converged = false;  // the solver converged, and the final orbits were all computed
  std::string status;      // the solver's stop reason, or the failure
};

// `start`: the linear part (m, c, k), clearance delta, and the law's start (k1, k3, c2, mu; e and
// unbalance_phase as every cycle's start). `terms`: which of "k1", "k3", "c2" the law has (the
// others are 0). Throws input_error for an unknown term, no cycle, or a cycle that is not periodic.
orbit_fit_result fit_periodic_orbits(const std::vector<orbit_fit_cycle>& cycles, const parameters& start,
                                     const std::vector<std::string>& terms, const orbit_fit_settings& s = {});

// The chi^2 per degree of freedom of a fit's residual that noise alone exceeds with probability 0.1 %.
double orbit_fit_chi2_limit(const orbit_fit_result& o);

}  // namespace rubref
