#pragma once
// From displacements to contact forces (paper §4): with the linear part of Eq. 1 known,
//   f_x = m x'' + c_x x' + k_x x - m e w^2 cos(w t + phase)
//   f_y = m y'' + c_y y' + k_y y - m e w^2 sin(w t + phase),   f_N = -f_y
// at every sample, the derivatives from `differentiate` with windows split at y = delta.

#include <array>
#include <string>
#include <vector>

#include "ref/identification/derivatives.hpp"
#include "ref/identification/dwells.hpp"

namespace rubref {

// The linear part of Eq. 1 and the unbalance: m e w^2 (cos(w t + phase), sin(w t + phase)).
struct linear_part {
  double m, c_x, c_y, k_x, k_y, e, phase;  // kg, kg/s, kg/s, N/m, N/m, m, rad
};

struct dwell_forces {
  const dwell* source = nullptr;
  std::vector<double> vx, vy, ax, ay;  // m/s, m/s^2 (NaN where a segment is too short)
  std::vector<double> z, fx, fn;       // m, N, N
  std::vector<bool> contact;           // y > delta and every derivative available
};

dwell_forces contact_forces(const dwell& d, const linear_part& lin, double delta, const derivative_settings& ds);

// Samples used for the friction ratio: in contact, with f_N at least this share of the dwell's
// peak, so that f_x / f_N never divides by the noise around onset and separation.
inline constexpr double kFrictionForceShare = 0.1;

struct friction_estimate {
  double rpm;
  std::size_t samples;
  double mean, std_dev, median;  // of f_x / f_N over the samples (paper Fig. 5: the mean)
  double slope;                  // least-squares f_x = mu f_N through the origin
};
friction_estimate estimate_friction(const dwell_forces& f);

// Least squares on Eq. 1 divided by m over dwells without contact (§3 from data). The unknowns
// c/m, k/m, e cos(phase), e sin(phase) are found; m itself is not identifiable from displacements
// alone (Eq. 1 scales with it) and is taken as given. Needs dwells at >= 2 speeds.
struct linear_fit {
  linear_part value;
  std::array<double, 6> standard_error;  // c_x, c_y, k_x, k_y, e, phase
  std::size_t dwells = 0, samples = 0;
  double residual_rms = 0.0;             // m/s^2
};
linear_fit fit_linear_part(const std::vector<const dwell*>& no_contact, double m, const derivative_settings& ds);

}  // namespace rubref
