#pragma once
// From displacements to contact forces (paper §4): with the linear part of Eq. 1 known,
//   f_x = m x'' + c_x x' + k_x x - m e w^2 cos(w t + phase)
//   f_y = m y'' + c_y y' + k_y y - m e w^2 sin(w t + phase),   f_N = -f_y
// at every sample, the derivatives from `differentiate` with windows split at y = delta.

#include <array>
#include <string>
#include <string_view>
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
  std::vector<double> vy_gain;         // 1/s: standard deviation of vy per metre of white probe noise
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

// The linear part from dwells without contact (§3 from data). Eq. 1 divided by m is linear in
// c/m, k/m, e cos(phase), e sin(phase); m itself is not identifiable from displacements alone
// (Eq. 1 scales with it) and is taken as given. Needs dwells at >= 2 speeds. Two routes:
//  - harmonic (default): each steady dwell's 1X Fourier coefficients (and its mean, a probe
//    offset) by least squares on the samples, then Eq. 1 balanced at 1X, where a derivative is a
//    factor i w. No derivative of data is taken, and every sample averages the probe noise, so the
//    estimate survives micrometre noise (docs/identification.md). Assumes steady dwells: each
//    dwell's content beyond 1X is reported (`beyond_1x_rms`) to check it against the noise.
//  - equation_error: Eq. 1 at every sample with Savitzky-Golay derivatives (the paper's §4 route
//    applied to §3), exact on clean data, noise-dominated at micrometre noise.
enum class linear_method { harmonic, equation_error };
std::string_view to_string(linear_method m);
linear_method parse_linear_method(const std::string& name);  // input_error if unknown

struct linear_fit {
  linear_part value;
  std::array<double, 6> standard_error;  // c_x, c_y, k_x, k_y, e, phase
  linear_method method = linear_method::harmonic;
  std::size_t dwells = 0, samples = 0;
  double residual_rms = 0.0;             // m/s^2, of Eq. 1 / m (harmonic: of its 1X balance)
  std::vector<double> beyond_1x_rms;     // m, per dwell (harmonic): samples minus mean and 1X, RMS
};
linear_fit fit_linear_part(const std::vector<const dwell*>& no_contact, double m, const derivative_settings& ds,
                           linear_method method = linear_method::harmonic);

}  // namespace rubref
