#pragma once
#include <array>

#include "ref/model/contact_law.hpp"

namespace rubref {

// Piecewise-linear contact stiffness (Fig. 7a): Eq. 5 without its nonlinear terms.
struct piecewise_linear {
  static constexpr std::string_view name = "piecewise-linear";
  static constexpr std::string_view equation = "f_N = k1 z (Fig. 7a)";

  double k1;  // N/m

  static piecewise_linear from(const parameters& p) { return {p.k1}; }
  double normal_force(double z, double /*z_dot*/) const noexcept { return k1 * z; }
  std::array<double, 2> normal_force_gradient(double /*z*/, double /*z_dot*/) const noexcept { return {k1, 0.0}; }
};

}  // namespace rubref
