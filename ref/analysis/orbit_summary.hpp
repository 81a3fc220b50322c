#pragma once
// What one looks at first in a steady-state orbit, computed from the recorded revolutions.

#include <complex>
#include <string_view>

#include "ref/analysis/spectrum.hpp"
#include "ref/run/simulate.hpp"

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
  double max_y = 0.0;                      // m, the orbit's top over the samples (the stator is at y = delta)
  double radius_spread = 0.0;              // m, spread of the per-revolution max radius: 0 for an
                                           // orbit that repeats every revolution, > 0 otherwise
  // Smallest n <= record_revs / 2 such that the samples repeat every n revolutions to
  // kRepeatRelTol of max_radius; 0: none does (non-periodic, or not settled, within the record);
  // -1: fewer than two revolutions recorded.
  int period_revs = -1;
  double max_penetration = 0.0;            // m, exact episode peaks (located on the dense output)
  double max_normal_force = 0.0;           // N, over the recorded samples
  double contact_episodes_per_rev = 0.0;   // onsets (compliant laws) or impacts (impact law)
  double contact_fraction = 0.0;           // share of samples with f_N > 0
  contact_regime regime = contact_regime::no_contact;
  directional_spectrum spectrum;           // full spectrum of x + j y, frequency in orders (Eq. 7);
                                           // empty where summarize was asked for the 1X alone
  std::complex<double> forward_1x{};       // m, coefficient of e^{+j w t}
  std::complex<double> backward_1x{};      // m, coefficient of e^{-j w t}
  bool backward_whirl() const { return std::abs(backward_1x) > std::abs(forward_1x); }
};

// A settled periodic orbit repeats to the integration error and the transient left by the
// settling (~1e-5 of its size after a sweep's 60 revolutions at the paper's damping; ~1e-12
// when shot); a torus or chaotic response differs between revolutions by > 1e-2 of its size.
// Shared with `rubref validate`'s candidate period (ref/validation/diagnosis.hpp).
inline constexpr double kRepeatRelTol = 1e-3;

// What summarize computes of the spectrum: the full spectrum and its 1X lines, or the 1X lines
// alone, for a caller that reads nothing else of it (a command's one summary: no FFT plan, which
// costs a process about as much as an orbit's shooting; docs/performance.md "Process start").
// The 1X lines come from direct sums either way (spectrum_line): the same bits in both.
enum class summary_spectrum { full, one_x };

orbit_summary summarize(const orbit& o, summary_spectrum spectrum = summary_spectrum::full);

}  // namespace rubref
