#pragma once
// What one looks at first in a steady-state orbit, computed from the recorded revolutions.

#include <complex>
#include <string_view>

#include "ref/simulate.hpp"
#include "ref/spectrum.hpp"

namespace rubref {

// How the rotor meets the stator over the recorded revolutions (docs/sweeps.md).
enum class contact_regime {
  no_contact,    // no event and no sample in contact
  partial_rub,   // intermittent contact (the paper's subject)
  full_annular,  // in contact at every sample, with no separation: continuous rub
};
std::string_view to_string(contact_regime r);

struct orbit_summary {
  double peak_to_peak_x = 0.0;             // m, over the recorded samples
  double peak_to_peak_y = 0.0;             // m
  double max_radius = 0.0;                 // m, max |x + j y| over the samples
  double radius_spread = 0.0;              // m, spread of the per-revolution max radius: 0 for an
                                           // orbit that repeats every revolution, > 0 otherwise
  double max_penetration = 0.0;            // m, exact episode peaks (located on the dense output)
  double max_normal_force = 0.0;           // N, over the recorded samples
  double contact_episodes_per_rev = 0.0;   // onsets (compliant laws) or impacts (impact law)
  double contact_fraction = 0.0;           // share of samples with f_N > 0
  contact_regime regime = contact_regime::no_contact;
  directional_spectrum spectrum;           // full spectrum of x + j y, frequency in orders (Eq. 7)
  std::complex<double> forward_1x{};       // m, coefficient of e^{+j w t}
  std::complex<double> backward_1x{};      // m, coefficient of e^{-j w t}
  bool backward_whirl() const { return std::abs(backward_1x) > std::abs(forward_1x); }
};

orbit_summary summarize(const orbit& o);

}  // namespace rubref
