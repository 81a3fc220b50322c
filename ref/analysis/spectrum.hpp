#pragma once
// Full (directional) spectrum of a planar orbit, Eq. 7: the DFT of r(t) = x(t) + j y(t), whose
// positive frequencies are forward whirl (the rotation sense) and negative ones backward whirl.
//
// Scaling (docs/spectrum.md): coefficient c_k = sum_n w_n r_n e^{-j 2 pi k n / N} / sum_n w_n,
// re-referenced to t = 0, so a pure whirl r = A e^{j(2 pi f t + phi)} on a bin gives c = A e^{j phi}
// at +f and nothing at -f. With the rectangular window over whole revolutions (order-synchronous
// sampling) every harmonic and every subharmonic 1/m with m dividing the revolutions sits on a
// bin: no leakage. Computed with FFTW; one line by a direct sum (spectrum_line).

#include <complex>
#include <span>
#include <vector>

namespace rubref {

enum class window_kind { rectangular, hann };

struct directional_spectrum {
  // Bin frequencies, ascending from -N/2 to N/2 - 1 bins, in the reciprocal of the unit of the
  // sample spacing: Hz for seconds, orders (multiples of shaft speed) for revolutions.
  std::vector<double> frequency;
  std::vector<std::complex<double>> coefficient;  // same unit as x and y (m)
  double resolution = 0.0;                        // bin width

  // The coefficient of the bin nearest to f (exact when f is on a bin).
  std::complex<double> at(double f) const;
  double amplitude(double f) const { return std::abs(at(f)); }
};

// x, y: N >= 2 uniform samples, spacing `dt`, the first at time `t0` (same unit as dt).
directional_spectrum full_spectrum(std::span<const double> x, std::span<const double> y, double dt, double t0,
                                   window_kind window = window_kind::rectangular);

// full_spectrum(x, y, dt, t0, window).at(f) by a direct sum over the samples: the same line and
// scaling, equal to round-off. For a line or two of one series (an orbit's 1X) it is O(N) and
// needs no FFTW plan, whose first one in a process (FFTW registers every codelet) took
// `rubref orbit` about as long as its shooting (docs/performance.md, "Process start").
std::complex<double> spectrum_line(std::span<const double> x, std::span<const double> y, double dt, double t0, double f,
                                   window_kind window = window_kind::rectangular);

}  // namespace rubref
