#pragma once
// What one looks at first in a steady-state orbit, computed from the recorded revolutions.

#include <complex>
#include <span>

#include "ref/simulate.hpp"

namespace rubref {

struct orbit_summary {
  double peak_to_peak_x = 0.0;             // m, over the recorded samples
  double peak_to_peak_y = 0.0;             // m
  double max_penetration = 0.0;            // m, exact episode peaks (located on the dense output)
  double max_normal_force = 0.0;           // N, over the recorded samples
  double contact_episodes_per_rev = 0.0;   // onsets (compliant laws) or impacts (impact law)
  std::complex<double> forward_1x{};       // m, coefficient of e^{+j w t} in x + j y (Eq. 7)
  std::complex<double> backward_1x{};      // m, coefficient of e^{-j w t}
  bool backward_whirl() const { return std::abs(backward_1x) > std::abs(forward_1x); }
};

// Coefficient of e^{j order w t} in r(t) = x + j y over uniform samples spanning whole
// revolutions: (1/N) sum r_n e^{-j order w t_n}. Exact for a pure harmonic of that order.
std::complex<double> whirl_coefficient(std::span<const orbit_sample> samples, double omega, int order);

orbit_summary summarize(const orbit& o);

}  // namespace rubref
