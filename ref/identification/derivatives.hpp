#pragma once
// First and second time derivatives of sampled displacements by local polynomials
// (Savitzky-Golay): at each sample a degree-`degree` polynomial is fitted by least squares to a
// window of 2 half_width + 1 uniform samples and differentiated there (docs/identification.md).
//
// Near a switch of the force law the acceleration jumps, and a window across it would smear the
// jump into both sides. So windows never straddle a `segment` boundary: each sample's window is
// shifted, as little as possible, to stay inside its own segment (e.g. y > delta vs y <= delta),
// and is shortened (with the degree lowered to fit) where a segment is shorter than the window.

#include <span>
#include <vector>

#include "ref/model/settings.hpp"

namespace rubref {

struct derivative_settings {
  // Defaults, ranges and reasons: the settings registry (scope "derivatives").
  int half_width = default_count_of("derivatives", "half_width");  // samples each side: window 2h + 1
  int degree = default_count_of("derivatives", "degree");          // polynomial degree (>= 2 for a second derivative)
  void validate() const;  // input_error naming the setting
};

struct derivatives {
  std::vector<double> d1, d2;  // first and second derivative; NaN where a segment has < 3 samples
  // Standard deviation of d1 per unit white noise on v (1/s): sqrt(sum of squared weights) / dt.
  // What the probe noise puts into a velocity (the weak form's noise-bias correction).
  std::vector<double> d1_gain;
};

// `segment[i]` labels the smooth stretch sample i belongs to (empty: one segment).
derivatives differentiate(std::span<const double> v, double dt, const derivative_settings& s,
                          std::span<const int> segment = {});

}  // namespace rubref
