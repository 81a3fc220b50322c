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

dwell_forces contact_forces(const dwell& d, const linear_part& lin, double clearance, const derivative_settings& ds);

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
  // One forcing phase for every dwell, tested (harmonic, >= 2 dwells): the weighted residual of
  // the fit above minus that of a fit with each dwell's own forcing (e cos, e sin per dwell), which
  // under one phase is chi^2 with 2 (dwells - 1) degrees of freedom. Above phase_limit (its 99.9 %
  // quantile) the dwells' 1X phases disagree with one unbalance on one shaft angle.
  double phase_chi2 = 0.0, phase_limit = 0.0;
  int phase_dof = 0;
};
linear_fit fit_linear_part(const std::vector<const dwell*>& no_contact, double m, const derivative_settings& ds,
                           linear_method method = linear_method::harmonic);

// Each contact-free dwell's forcing phase, for dwells whose times are not on one shaft angle
// (phase_chi2 above its limit): returns the time shift (s) that puts each on the angle of the
// harmonic fit's one unbalance (add it to every t). Alternates the harmonic fit on the shifted
// dwells with each dwell's best phase against it (closed form), from the phases of a fit with
// every dwell's own forcing, until the shifts move by less than 1e-9 rad; the phase common to all
// is left (the unbalance's). c and k then rest on the 1X amplitudes across speeds and the x-y
// phase of each dwell, plus what the dwells' relative timing still holds.
std::vector<double> shaft_angle_shifts(const std::vector<const dwell*>& no_contact, double m);

// The time shift (s) that brings a dwell's 1X closest to the linear part's 1X response (the same
// closed form): a start for the shaft angle of a dwell that touches, whose contact also moves its
// 1X (the orbit fit's per-cycle forcing then refines it).
double one_x_shift(const dwell& d, const linear_part& lin);

}  // namespace rubref
