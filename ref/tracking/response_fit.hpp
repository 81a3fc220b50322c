#pragma once
// The model's steady 1X response fitted to an order-tracked table (docs/real-data.md). Off contact
// Eq. 1 is linear, so its 1X vector at speed w is closed form: with the mass divided out,
//
//   [w_x^2 - w^2 + 2j z_x w_x w      k_xy/m                     ] [X]   =  e w^2 e^{j phi} [ 1]  + B [ w_x^2]
//   [k_yx/m                          w_y^2 - w^2 + 2j z_y w_y w ] [Y]                      [-j]      [-j w_y^2]
//
// (unbalance e at phi from the keyphasor; a shaft bow B, docs/loop.md's shaft_bow), and a probe at
// angle beta reads  v = cos(beta) X + sin(beta) Y + R,  R its slow-roll runout (the shaft surface's
// own 1X, the same at every speed). The complex amplitudes (e e^{j phi}, R, B) enter linearly and
// are solved for at every step of the fit of the rest (variable projection); the critical speeds,
// damping ratios, the probe's angle (one probe without a declared one) and the cross-coupling
// are fitted by rubref's one least-squares solver (ref/inference/least_squares.hpp) from
// families of starts (critical speeds scanned over the table's speeds, a mode split,
// cross-coupling switched on, the previous fit). The rotor's mass is not identifiable from
// displacements; nothing here depends on it.

#include <complex>
#include <optional>
#include <string>
#include <vector>

#include "ref/format/order_table.hpp"

namespace rubref {

// The layout of response_fit::theta, every fit's full set: ln w_x, ln w_y (rad/s), ln z_x, ln z_y,
// the probe angle beta (rad), k_xy/m and k_yx/m in units of w_x w_y, and a sweep's rate as
// ln(|alpha| / w_lo^2) (alpha the angular acceleration, w_lo the table's lowest speed in rad/s).
namespace response_slots {
enum : std::size_t { ln_wx, ln_wy, ln_zx, ln_zy, probe_beta, k_xy, k_yx, ln_sweep, kSlots };
}

// Which parts beyond the base (an isotropic rotor: one critical speed and damping ratio; the
// unbalance; each probe's runout) a fit carries.
struct response_parts {
  bool anisotropy = false;  // two critical speeds and damping ratios, along x and y (and, for one probe without a declared angle, its angle)
  bool shaft_bow = false;
  bool cross_coupling = false;
  // The run-up's own transient (`sweep_transient`): the rotor swept through the table's speeds at
  // a constant angular acceleration, each row read over a block of N revolutions
  // (ref/tracking/swept_response.hpp), in place of the steady response at each speed; the rows of
  // the table's dwell (order_table::dwell) stay steady (the sweep stood still there).
  bool sweep = false;
};

// A fitted quantity with its 95 % interval (from the fit's covariance, scaled by the residual's
// chi^2/dof where that exceeds 1) and whether the table determines it (the rule per quantity is
// in docs/real-data.md).
struct estimate {
  double value = 0.0;
  double lo = 0.0, hi = 0.0;
  bool determined = false;
};

struct response_mode {
  std::string axis;            // "both" (isotropic), or "x", "y": the support direction it moves along (one probe, undeclared: "a", "b")
  estimate critical_speed_rpm;
  estimate damping_ratio;
  bool at_edge = false;        // the fit put it at the lowest or highest speed of the table: not determined
};

struct response_fit {
  response_parts parts;
  std::vector<response_mode> modes;  // one (isotropic) or two, lower critical speed first
  estimate unbalance_m;              // e
  estimate unbalance_phase_deg;      // phi, from the keyphasor, in the rotation sense
  std::vector<std::string> probes;   // per tracked probe
  std::vector<estimate> probe_angle_deg;  // per probe: fitted (one probe, undeclared) or as declared (lo = hi)
  std::vector<bool> probe_angle_fitted;
  std::vector<estimate> runout_m, runout_phase_deg;  // per probe
  estimate bow_m, bow_phase_deg;                      // shaft_bow only
  // The model's parts (the unbalance's response, the bow's, each runout) over what they add up
  // to: RMS over the rows of the sum of their sizes over the RMS of their sum (1: none cancels).
  double cancellation = 1.0;
  estimate k_xy_over_m, k_yx_over_m;                  // 1/s^2, cross_coupling only
  bool cross_coupling_at_bound = false;               // a term reached +-w_x w_y / 2, the library's range
  // sweep only: the sweep rate |d rpm / dt| (determined when its interval spans less than 4x and it
  // is not at the bounds of its range), its direction (+1 rising speed, -1 falling), the block's
  // revolutions N (declared, or fitted among kSweepRevolutions), and whether the rate sits at its
  // slow bound (the table is then quasi-steady).
  estimate sweep_rpm_per_s;
  int sweep_direction = 0;
  double sweep_revolutions = 0.0;
  bool sweep_revolutions_fitted = false;
  bool sweep_at_slow_bound = false;
  bool sweep_rate_held = false;  // the rate was given (response_fit_options::sweep_rate), not fitted
  // The blocks (revolutions per row, negative for a coast-down) that fit as well as the chosen one
  // (first): its estimates' intervals cover theirs.
  std::vector<double> sweep_alternatives;

  // The fit's quality.
  std::vector<double> noise_m;       // per probe: the row-to-row scatter of its 1X vector (robust)
  double chi2 = 0.0;                 // sum of (residual / noise)^2 over real and imaginary parts
  double chi2_uncertainty = 0.0;     // its numerical uncertainty: how much lower the minimum may lie (least_squares_result::remaining)
  std::size_t dof = 0;
  double rms_residual_m = 0.0;
  double chi2_bound = 1.0;           // chi2/dof's 0.1 % false-alarm bound, widened by the noise estimate's uncertainty
  bool consistent_with_noise = false;  // chi2/dof within chi2_bound
  int evaluations = 0;

  // Per probe and row (the table's rows, rising speed): the model's 1X vector and the residual.
  std::vector<std::vector<std::complex<double>>> model, residual;

  // The fit itself, in its own chart, for response_at, a refit or a fold: the nonlinear
  // coordinates (response_slots) and the complex amplitudes (e e^{j phi}, each probe's R, B).
  std::vector<double> theta;
  std::vector<std::complex<double>> amplitudes;
  std::vector<std::size_t> rows;  // the rows fitted
  std::size_t parameters = 0;     // real coordinates spent (the nonlinear ones and 2 per amplitude)
};

// How a fit starts: from its grid of starts (and `start`, when given), or from `start` alone (a
// fold's refit stays in the basin of the fit on every row, as the waveform loop's folds do).
enum class fit_starts { grid, given_only };

struct response_fit_options {
  std::vector<std::size_t> rows;      // the rows fitted (empty: all)
  // A sweep's block (revolutions per row; 0: fitted) and direction (+1 a run-up, -1 a coast-down;
  // 0: from the table's row order, sweep_direction_of).
  const response_fit* start = nullptr;  // a previous fit to start from (an isotropic one also by splitting its mode)
  fit_starts starts = fit_starts::grid;
  std::vector<double> noise_m;        // per probe (empty: row_scatter of each)
  double noise_relative_error = 0.0;  // the noise estimate's relative standard error (widens the chi^2 test)
  double revolutions_per_row = 0.0;
  std::vector<double> sweep_blocks;  // the blocks to try where none is declared (empty: kSweepRevolutions)
  int sweep_direction = 0;
  // A swept fit from a steady one: start at this rate (rad/s^2, another fit's) in place of the
  // grid of rates (0: the grid).
  double sweep_rate_start = 0.0;
  // The sweep's rate |alpha| (rad/s^2) held, not fitted: measured (the table's time_s column,
  // sweep_of_times) or declared (0: fitted).
  double sweep_rate = 0.0;
};

// The block sizes (revolutions per row) a sweep fit tries when the table does not declare one.
inline constexpr double kSweepRevolutions[] = {1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0};

// The direction the table's speed ran in, from its time_s column or else its rows' order in the
// file, the dwell's rows left out: +1 rising (a run-up), -1 falling (a coast-down), 0 when the
// order says neither (shuffled rows).
int sweep_direction_of(const order_table& table);

// The sweep a table's time_s column shows (its rows outside the dwell): the least-squares line of
// its speeds against its times (the swept model's constant acceleration), alpha in rad/s^2 (< 0 a coast-down) with its standard
// error, and how far the speeds depart from the line (largest, rpm; a sweep whose rate changes
// departs by more than its speed column's jitter). Unset when the table has no time column;
// input_error when its speed does not change with time.
struct timed_sweep {
  double alpha = 0.0, alpha_sd = 0.0;
  double departure_rpm = 0.0, range_rpm = 0.0;
};
std::optional<timed_sweep> sweep_of_times(const order_table& table);

// input_error unless the table can be fitted: a 1X column, at least 8 rows, more than one speed.
void check_fittable(const order_table& table);

// The 1X tracked orders of the table, fitted with `parts`. input_error when the table has no 1X
// column, or several probes of which one has no angle.
response_fit fit_response(const order_table& table, const response_parts& parts, const response_fit_options& options = {});

// Each probe's noise (m per real and imaginary part) from the scatter of its 1X vector from row
// to row: second differences in speed order, a median-based scale clipped at 3 of itself, over
// sqrt(6). A response that is not smooth on the rows' spacing (a sharp critical speed) can only
// inflate it; the loop takes the smaller of this and the current model's residual scatter
// (docs/real-data.md).
std::vector<double> row_scatter_noise(const order_table& table);
// Each probe's noise from a fit's residual over its fitted rows: the same clipped scale, corrected
// for the coordinates the fit spent. A residual the model does not fit can only inflate it.
std::vector<double> residual_noise(const response_fit& fit);
// The same for any fit's residual (per probe and row) over its fitted rows, `parameters` real
// coordinates spent in all.
std::vector<double> residual_noise(const std::vector<std::vector<std::complex<double>>>& residual, const std::vector<std::size_t>& rows, std::size_t parameters);

// The standard deviation of Gaussian values from their magnitudes, robust to a minority of
// outliers (a median-based scale, clipped at 3 of itself); and the row-to-row scatter of a
// sequence of complex vectors in speed order (row_scatter_noise's, for one column).
double robust_scale(std::vector<double> magnitudes);
// A quantity fitted as its logarithm `chart` with standard deviation sd: exp(chart) / unit with
// the 95 % interval exp(chart +- 1.96 sd) / unit, determined when that spans less than max_ratio.
estimate log_estimate(double chart, double sd, double unit, double max_ratio);
// |c| (with the 95 % interval of the amplitude and "determined" when it excludes 0) and arg c in
// degrees (determined when within +-45 degrees), from the covariance of (Re c, Im c).
std::pair<estimate, estimate> polar_estimate(std::complex<double> c, double var_re, double var_im, double cov_re_im);
double row_scatter_of(const std::vector<std::complex<double>>& vectors);
// An angle fitted in radians with standard deviation sd, in degrees with its 95 % interval,
// determined when that reaches less than 45 degrees either side (a phase's, a probe's or the
// stator's direction alike).
estimate angle_estimate(double rad, double sd);

// The reading of probe `probe` at frequency w (rad/s) per unit forward force per unit mass,
// (cos wt, sin wt) = Re((1, -j) e^{j w t}), through the fit's modes (a misalignment's 2X is one
// at w = 2 x the shaft's speed).
std::complex<double> forward_force_response(const response_fit& fit, std::size_t probe, double w);

// The model's 1X vector of a fit at a speed for probe `probe` (index into the fit's probes).
std::complex<double> response_at(const response_fit& fit, std::size_t probe, double rpm);

}  // namespace rubref
