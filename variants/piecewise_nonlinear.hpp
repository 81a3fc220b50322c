#pragma once
#include <array>

#include "ref/model/contact_law.hpp"

namespace rubref {

// Piecewise-nonlinear contact stiffness (Fig. 7b): Eq. 5 without the damping term.
struct piecewise_nonlinear {
  static constexpr std::string_view name = "piecewise-nonlinear";
  static constexpr std::string_view equation = "f_N = k1 z + k3 z^3 (Fig. 7b)";

  double k1;  // N/m
  double k3;  // N/m^3

  static piecewise_nonlinear from(const parameters& p) { return {p.k1, p.k3}; }
  double normal_force(double z, double /*z_dot*/) const noexcept { return z * (k1 + k3 * z * z); }
  std::array<double, 2> normal_force_gradient(double z, double /*z_dot*/) const noexcept { return {k1 + 3.0 * k3 * z * z, 0.0}; }
};

}  // namespace rubref
