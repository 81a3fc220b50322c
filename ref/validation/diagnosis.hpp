#pragma once
// Why a candidate fails a golden case (docs/validation.md, "Causes"), in a fixed order, each
// stage run only while no earlier one has confirmed a cause:
//  1. coverage and the candidate's own header (variant, speed, parameters);
//  2. periodicity: the candidate's own revolution-to-revolution repetition against the case's
//     period (another attractor, or not settled);
//  3. transforms of the golden orbit: a time shift (origin or unbalance phase), a mirrored or
//     swapped axis, a unit factor, a constant offset;
//  4. single-parameter refits by re-simulation with the periodic-orbit engine (shooting from
//     the candidate's own state): clearance, friction (sign and value), the law's coefficients,
//     the unbalance, the damper form c2 |z_dot| z_dot, a static load, the rotation sense;
//  5. event heuristics: samples inside a rigid stator, missing or deeper contact episodes, and
//     a naive fixed-step integration that reproduces the candidate.
// Stages 3-4 need an orbit case with a period (`period_revs` > 0); chaotic cases get 1, 2, 5.

#include <array>
#include <cmath>
#include <string_view>
#include <vector>

#include "ref/analysis/orbit_summary.hpp"
#include "ref/format/record.hpp"
#include "ref/validation/causes.hpp"
#include "ref/validation/golden.hpp"

namespace rubref {

// The damper form a candidate may have used for Eq. 5's c2 z_dot^2: a true damper, c2 |z_dot| z_dot.
// Not a variant (it is no law of the paper's): a hypothesis of the diagnosis (contact_law_form).
struct abs_damper_law {
  static constexpr std::string_view name = "identified-abs-damper";
  static constexpr std::string_view equation = "f_N = k1 z + k3 z^3 + c2 |z_dot| z_dot";
  double k1, k3, c2;
  static abs_damper_law from(const parameters& p) { return {p.k1, p.k3, p.c2}; }
  double normal_force(double z, double z_dot) const noexcept { return z * (k1 + k3 * z * z) + c2 * std::abs(z_dot) * z_dot; }
  std::array<double, 2> normal_force_gradient(double z, double z_dot) const noexcept {
    return {k1 + 3.0 * k3 * z * z, 2.0 * c2 * std::abs(z_dot)};
  }
};

// The candidate's samples, as read (m, s; velocities when it has vx_m_s, vy_m_s).
struct candidate_data {
  std::vector<double> t, x, y, vx, vy;
};

// The candidate paired with the golden orbit at the same times of the case's run (orbit cases).
struct comparison_points {
  std::vector<double> t;       // s, in the case's run, ascending
  std::vector<double> x, y;    // m, the candidate
  std::vector<double> gx, gy;  // m, the golden orbit
  std::string note;
};

// Revolutions of the case a candidate must span: one period (at least one revolution).
double required_revolutions(const golden_case& g);
// Revolutions the candidate spans: (last - first + one sample spacing) / T.
double spanned_revolutions(const golden_case& g, const candidate_data& c);

// The smallest p in 1..kMaxCandidatePeriod after which the candidate repeats itself (to
// kRepeatRelTol (ref/analysis/orbit_summary.hpp) of its size, plus the linear interpolation's error when its sampling does not
// divide the revolution); 0 when it does not repeat; -1 when it is too short to tell.
inline constexpr int kMaxCandidatePeriod = 8;
int candidate_period(const golden_case& g, const candidate_data& c);

// The causes, most certain first: confirmed before likely, each group in the order of diagnosis.
// `header` is the candidate's record (its metadata); `pts` the comparison of an orbit case.
std::vector<cause> diagnose(const golden_case& g, const candidate_data& c, const record& header, const comparison_points* pts);

}  // namespace rubref
