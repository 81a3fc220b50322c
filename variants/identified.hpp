#pragma once
#include <array>

#include "ref/model/contact_law.hpp"

namespace rubref {

// The identified law, exactly as the paper writes it (Eq. 5, Table 2). The term c2 z_dot^2 has
// the same sign while the rotor enters (z_dot > 0) and leaves (z_dot < 0): it resists the
// approach but pushes the rebound, so it is not a damper. We keep it as published; see
// docs/model.md ("The c2 term is not dissipative").
struct identified {
  static constexpr std::string_view name = "identified";
  static constexpr std::string_view equation = "f_N = k1 z + k3 z^3 + c2 z_dot^2 (Eq. 5, Table 2)";

  double k1;  // N/m
  double k3;  // N/m^3
  double c2;  // kg/m

  static identified from(const parameters& p) { return {p.k1, p.k3, p.c2}; }
  double normal_force(double z, double z_dot) const noexcept {
    return z * (k1 + k3 * z * z) + c2 * z_dot * z_dot;
  }
  std::array<double, 2> normal_force_gradient(double z, double z_dot) const noexcept {
    return {k1 + 3.0 * k3 * z * z, 2.0 * c2 * z_dot};
  }
};

}  // namespace rubref
