#pragma once
#include "ref/model/contact_law.hpp"

namespace rubref {

// Coefficient of restitution (Eq. 6): no contact force; at y = delta with y_dot > 0 the
// velocity map y_dot+ = -r y_dot-. As in the paper, no tangential force acts at the impact.
struct restitution {
  static constexpr std::string_view name = "restitution";
  static constexpr std::string_view equation = "impact map y_dot+ = -r y_dot- at y = delta (Eq. 6), no friction";

  double r;  // -

  static restitution from(const parameters& p) { return {p.r}; }
  double rebound_velocity(double v_normal) const noexcept { return -r * v_normal; }
  double rebound_slope(double /*v_normal*/) const noexcept { return -r; }
};

}  // namespace rubref
