#pragma once
// The 1X response of a rotor that rubs, fitted to an order-tracked table (docs/real-data.md).
// Where the model touches the stator its 1X is no longer closed form: at every speed of the table
// (rising, as a run-up goes) the model's steady orbit is shot (Newton on the one-revolution map,
// ref/integrate/shooting.hpp) from the previous speed's orbit, so that the fit follows the branch
// a run-up follows, and its 1X and 2X are read from one period. Where the contact-free response
// stays inside the clearance and the previous speed did not touch, the closed form is exact and
// used.
//
// The model per unit mass (an order-tracked table cannot see the mass): the linear part of the
// 1X fit it starts from (one or two critical speeds and damping ratios, cross-coupling, bow,
// unbalance, each probe's runout), and the paper's contact at the top (Eq. 2): the stator at +y
// of the declared probe angles, a clearance delta, a contact stiffness k1/m (the piecewise-linear
// law k1 z: a 1X table cannot tell the laws apart) and Coulomb friction mu. Every coordinate is
// fitted by rubref's one least-squares solver (ref/inference/least_squares.hpp); the runouts by
// least squares at every step.

#include <Eigen/Dense>
#include <complex>
#include <string>
#include <vector>

#include "ref/format/order_table.hpp"
#include "ref/orbits/fit_orbits.hpp"
#include "ref/tracking/response_fit.hpp"

namespace rubref {

struct rub_fit {
  response_parts parts;               // the linear parts carried (those of the fit it started from)
  std::vector<response_mode> modes;   // lower critical speed first
  estimate unbalance_m, unbalance_phase_deg;
  estimate bow_m, bow_phase_deg;      // shaft_bow only
  estimate k_xy_over_m, k_yx_over_m;  // cross_coupling only, 1/s^2
  estimate clearance_m;               // delta, from the contact-free orbit's centre
  estimate contact_stiffness_over_m;  // k1/m, 1/s^2
  estimate friction;                  // mu
  std::vector<std::string> probes;
  std::vector<estimate> runout_m, runout_phase_deg;  // per probe
  std::vector<double> noise_m;        // per probe (as given)

  std::size_t rows_in_contact = 0;    // fitted rows whose orbit touches
  double contact_from_rpm = 0.0, contact_to_rpm = 0.0;  // the lowest and highest such row
  std::size_t rows_not_periodic = 0;  // rows where no stable periodic orbit was found
  std::size_t rows_circled = 0;       // of those, rows read from an unstable orbit the motion circles (a flip's or a torus's); the rest a transient's last revolution

  double chi2 = 0.0;
  double chi2_uncertainty = 0.0;  // its numerical uncertainty (the solver's unfinished descent and the orbits' error)
  std::size_t dof = 1;
  double chi2_bound = 1.0;
  bool consistent_with_noise = false;
  double rms_residual_m = 0.0;
  std::vector<std::vector<std::complex<double>>> model, residual;  // per probe and row: the 1X (every row)
  std::vector<std::vector<std::complex<double>>> model_2x;         // per probe and row: the orbit's own 2X (0 off contact)

  std::vector<double> q;              // the fit's coordinates (for a refit from it)
  double ref_m = 1.0;                 // the size the unbalance and bow coordinates are in units of
  std::vector<std::size_t> rows;      // the rows fitted
  std::size_t parameters = 0;         // real coordinates spent (runouts included)
  int evaluations = 0;                // evaluations of every row's orbit
  std::size_t shots = 0;              // orbits shot
};

struct rub_fit_options {
  std::vector<std::size_t> rows;      // the rows fitted (empty: all)
  std::vector<double> noise_m;        // per probe
  double noise_relative_error = 0.0;
  const rub_fit* start = nullptr;     // a previous rub fit: start there alone (a fold's refit)
  // Rub fits of other parts (fewer: this fit's extra parts off; more: theirs dropped, x's mode
  // kept): starts ranked with the grid's.
  std::vector<const rub_fit*> also_from;
  bool grid = true;                   // the grid of starts from the contact-free fit (else also_from alone)
  fit_orbit_options orbits = {};      // the orbits' tolerances (the verdict's check tightens them)
};

// input_error when a probe's angle was not declared (the stator's direction is then unknown
// against the probes) or `linear` has no probes.
rub_fit fit_rub(const order_table& table, const response_fit& linear, const rub_fit_options& options);

// A rub fit's Jacobian at its end (its residuals in its free coordinates, the runouts solved): from
// the orbits' exact sensitivities; with every shot row differenced alone, as the fit differences
// a row that has none (a transient's); and by central differences of `step` of whole evaluations
// from the same orbits: the tests of both. `exact` and `rows_differenced` are empty where some
// row's cannot be had.
struct rub_fit_jacobians {
  Eigen::MatrixXd exact, rows_differenced, differenced;
};
rub_fit_jacobians rub_fit_jacobians_at(const order_table& table, const response_fit& linear, const rub_fit& fit, double step);

// The linear part of a rub fit as a response fit (the chosen 1X fit's frame, the rub fit's
// coordinates): its modes for the 2X's forced response.
response_fit linear_part(const response_fit& linear, const rub_fit& rub);

}  // namespace rubref
