#pragma once
// The 2X columns of an order-tracked table (docs/real-data.md): each probe reads its shaft's 2X
// runout R2 (the surface's own 2X, the same at every speed), the 1X model's own 2X where it has
// one (a rubbing orbit's), plus, with a misalignment (the
// effect library's misalignment_2x: a forward force F2 (cos(2wt + phi2), sin(2wt + phi2))), the
// rotor's response to that force at twice the shaft's speed through the modes the 1X fit found:
//
//   v2 = R2 + H(2w) F2/m e^{j phi2},  H(2w) the probe's reading per unit forward force per unit mass.
//
// Both R2 and F2/m e^{j phi2} enter linearly: the fit is one weighted least-squares solve. The
// modes come from the 1X fit (their 2X response peaks at half each critical speed, which is how
// a misalignment shows against a runout that does not change with speed).

#include <complex>
#include <string>
#include <vector>

#include "ref/format/order_table.hpp"
#include "ref/tracking/response_fit.hpp"

namespace rubref {

struct two_x_fit {
  bool misalignment = false;           // whether the forced 2X response is a part
  std::vector<std::string> probes;
  std::vector<estimate> runout_m, runout_phase_deg;  // per probe: R2
  estimate force_over_m, force_phase_deg;            // F2/m (m/s^2) and phi2, misalignment only
  double cancellation = 1.0;           // as the 1X fit's: the parts' sizes over their sum (RMS)
  std::vector<double> noise_m;         // per probe
  double chi2 = 0.0;
  std::size_t dof = 1;
  double chi2_bound = 1.0;
  bool consistent_with_noise = false;
  double rms_residual_m = 0.0;         // per real and imaginary part, over the fitted rows
  std::vector<std::vector<std::complex<double>>> model, residual;  // per probe and row (every row)
  std::vector<std::size_t> rows;       // the rows fitted
  std::size_t parameters = 0;          // real coordinates spent
};

struct two_x_options {
  std::vector<std::size_t> rows;       // the rows fitted (empty: all)
  std::vector<double> noise_m;         // per probe (empty: each column's row scatter)
  double noise_relative_error = 0.0;   // widens the chi^2 test as the 1X fit's does
  // The model's own 2X per probe and row, added to the fit's (a rub's orbit has one); none: 0.
  const std::vector<std::vector<std::complex<double>>>* known = nullptr;
};

// The index into table.orders of each probe's 2X column, in the order of `modes.probes`; empty
// unless every probe the 1X fit reads has one.
std::vector<std::size_t> two_x_columns(const order_table& table, const response_fit& modes);

// Each probe's 2X noise from the rows' scatter (row_scatter_noise's rule).
std::vector<double> two_x_scatter_noise(const order_table& table, const response_fit& modes);

// The 2X columns fitted with each probe's runout and, with `misalignment`, the forced response
// through `modes`. input_error when the table has no 2X column for every probe.
two_x_fit fit_two_x(const order_table& table, const response_fit& modes, bool misalignment, const two_x_options& options = {});

// A fit's noise from its residual (residual_noise's rule).
std::vector<double> two_x_residual_noise(const two_x_fit& fit);

}  // namespace rubref
