#pragma once
// The rotor state of Eq. 1: geometric-centre displacements and velocities, SI units.

#include <array>
#include <cmath>
#include <numbers>

namespace rubref {

// (x, y, x_dot, y_dot) in m, m, m/s, m/s. Fixed size: no allocation per step.
using state_type = std::array<double, 4>;

namespace idx {
inline constexpr int x = 0;
inline constexpr int y = 1;
inline constexpr int vx = 2;
inline constexpr int vy = 3;
}  // namespace idx

template <std::size_t N>
bool is_finite(const std::array<double, N>& s) {
  for (const double v : s)
    if (!std::isfinite(v)) return false;
  return true;
}

inline constexpr double rpm_to_rad_s(double rpm) { return rpm * (2.0 * std::numbers::pi / 60.0); }
inline constexpr double rad_s_to_rpm(double omega) { return omega * (60.0 / (2.0 * std::numbers::pi)); }

}  // namespace rubref
