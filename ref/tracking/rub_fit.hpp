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
// of the declared probe angles, a clearance delta, a contact stiffness k1/m and Coulomb friction
// mu; and, where the form asks (rub_form), the law's stiffening and velocity-squared terms (Eq. 5:
// k3/m, c2/m) and the stator's direction (the effect library's contact angle). Every coordinate
// is fitted by rubref's one least-squares solver (ref/inference/least_squares.hpp); the runouts by
// least squares at every step.
//
// The rows are followed as the rig ran them (the table's file order, kept by the reader as
// order_table::line): a run-up in rising speed, a coast-down in falling speed (so it jumps at the
// other fold), a run-up then a coast-down as both; rows in no such order in rising speed.

#include <Eigen/Dense>
#include <complex>
#include <optional>
#include <string>
#include <vector>

#include "ref/format/order_table.hpp"
#include "ref/orbits/fit_orbits.hpp"
#include "ref/tracking/response_fit.hpp"

namespace rubref {

// The contact's form beyond the piecewise-linear law with the stator at +y: each an optional
// coordinate, chosen by the evidence rules like an effect (tracking_loop.cpp, "the rub's form").
struct rub_form {
  bool cubic = false;             // k3 z^3 (Eq. 5): k3/m
  bool velocity_squared = false;  // c2 z_dot^2 (Eq. 5): c2/m
  bool contact_angle = false;     // the stator at angle theta from +y towards +x (the model's frame)
  bool hertz = false;             // k_h z^1.5 (the effect library's hertz_contact): k_h/m
  bool hunt_crossley = false;     // lambda z^p z_dot (hunt_crossley_damping): lambda/m and p in [1, 2]
  friend bool operator==(const rub_form&, const rub_form&) = default;
};
// "k1 z", "k1 z + k3 z^3", ... and ", stator at theta": the form in words.
std::string law_text(const rub_form& form);

// The order the rig ran the table's rows in: the file's order where it is a run-up, a coast-down
// or a few such runs one after the other (its direction turns at most kMaxTurns times), else
// rising speed (`as_run` false).
struct row_path {
  std::vector<std::size_t> order;  // table rows, in the order followed
  bool as_run = true;
  std::size_t turns = 0;           // the direction's turns along the file
};
row_path rows_as_run(const order_table& table);

struct rub_fit {
  response_parts parts;
  rub_form form;               // the linear parts carried (those of the fit it started from)
  std::vector<response_mode> modes;   // lower critical speed first
  estimate unbalance_m, unbalance_phase_deg;
  estimate bow_m, bow_phase_deg;      // shaft_bow only
  estimate k_xy_over_m, k_yx_over_m;  // cross_coupling only, 1/s^2
  estimate clearance_m;               // delta, from the contact-free orbit's centre
  estimate contact_stiffness_over_m;  // k1/m, 1/s^2
  estimate friction;                  // mu
  estimate cubic_stiffness_over_m;    // k3/m, 1/(s^2 m^2) (form.cubic)
  estimate velocity_squared_over_m;   // c2/m, 1/m (form.velocity_squared)
  estimate hertz_over_m;               // k_h/m, 1/(s^2 m^0.5) (form.hertz)
  estimate hunt_crossley_over_m;       // lambda/m, 1/(s m^p) (form.hunt_crossley)
  estimate hunt_crossley_exponent;     // p (form.hunt_crossley; the library's range [1, 2])
  // The Hunt-Crossley term's size: lambda/m times z^p at hunt_crossley_reference_m (the coordinate
  // fitted, so lambda and p do not trade along the fit's path); determined as the other terms.
  estimate hunt_crossley_at_reference;
  double hunt_crossley_reference_m = 0.0;
  estimate contact_angle_deg;         // theta within 90 degrees of the top (form.contact_angle; else 0 as assumed): a 1X table reads theta + 180 alike
  double penetration_m = 0.0;         // the largest penetration over the fitted rows' orbits
  double approach_speed_m_s = 0.0;    // the largest rate of penetration while in contact
  bool probe_angle_fitted = false;    // one undeclared probe: the stator's direction fitted against it
  estimate probe_angle_deg;           // the first probe's: declared; the 1X fit's (supports alike); or fitted (supports differ)
  std::vector<std::string> probes;
  std::vector<estimate> runout_m, runout_phase_deg;  // per probe
  std::vector<double> noise_m;        // per probe (as given)

  std::size_t rows_in_contact = 0;    // fitted rows whose orbit touches
  double contact_from_rpm = 0.0, contact_to_rpm = 0.0;  // the lowest and highest such row
  std::size_t rows_not_periodic = 0;  // rows where no stable periodic orbit was found
  std::size_t rows_circled = 0;       // of those, rows read from an unstable orbit the motion circles (a flip's or a torus's); the rest a transient's last revolution
  // Per row: the revolutions the model's motion takes, from the orbit of the row before it on the
  // path, to come within the noise of its own orbit: ln(|step| / sigma) / -ln(rho), the step the
  // 1X change between the two rows' orbits over the probe's noise (the largest probe's), rho the
  // row's largest Floquet multiplier's modulus (the linear state matrix's over a revolution where
  // the row is in closed form). 0 where the step is within the noise (or the path's first row);
  // infinite where the row has no stable orbit. The rows the rig may have read before they settled
  // rank first (issue 65, item 4; rows_freed).
  std::vector<double> settling_revolutions;
  // Rows fitted as mean-shift outliers (rub_fit_options::freed_rows): their 1X free, two coordinates
  // per probe counted in `parameters`, their residuals outside chi^2 (shown, not fitted).
  struct freed_row {
    std::size_t row = 0;
    double rpm = 0.0;
    double settling_revolutions = 0.0;
  };
  std::vector<freed_row> rows_freed;

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
  // The form fitted (absent: the start's, else the piecewise-linear law at the top). Terms the start
  // lacks start at a few sizes against its contact (and from `form_from`'s values where given).
  std::optional<rub_form> form;
  const rub_fit* form_from = nullptr;
  // Rub fits of other parts (fewer: this fit's extra parts off; more: theirs dropped, x's mode
  // kept): starts ranked with the grid's, or with `start`'s.
  std::vector<const rub_fit*> also_from;
  bool grid = true;                   // the grid of starts from the contact-free fit (else also_from alone)
  // Rows fitted as mean-shift outliers (read before they settled: the loop frees them, tracking_loop.cpp):
  // left out of `rows` (or of every row), each counted as two coordinates per probe.
  std::vector<std::size_t> freed_rows;
  fit_orbit_options orbits = {};      // the orbits' tolerances (the verdict's check tightens them)
};

// input_error when `linear` has no probes, or more than one whose angle is not declared. With one
// undeclared probe the stator's direction is fitted (the form's contact angle is always on): the
// probe's angle is the 1X fit's, and only the angle between probe and stator is seen where the
// supports are isotropic.
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
