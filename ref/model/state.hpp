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

// The unit vector (cos, sin) of the unbalance force's angle w t + phi (Eq. 1). A System that
// also takes it instead of t lets a stepper rotate it from stage to stage (ref/integrate/steppers.hpp).
struct forcing_phasor {
  double cos, sin;
};

namespace detail {
// pi/32 in three parts: the first two exactly double(pi)/32, with few enough bits that k times
// either is exact for |k| < 2^23; the third the rest of pi/32.
inline constexpr double kPiOver32Hi = 0x1.921fb54p-4;
inline constexpr double kPiOver32Mid = 0x1.921fb54442d18p-4 - 0x1.921fb54p-4;  // exact difference
inline constexpr double kPiOver32Lo = 1.2246467991473532e-16 / 32.0;           // (pi - double(pi)) / 32

// (cos, sin) of k pi/32, k = 0..63, each correctly rounded to ~0.5 ulp: j pi/32 (j < 16) from
// libm at the double nearest to it, corrected to first order by the exact remainder, then turned
// by whole quadrants (exact sign swaps).
inline const std::array<forcing_phasor, 64> kPhasorNodes = [] {
  std::array<forcing_phasor, 64> t{};
  for (int k = 0; k < 64; ++k) {
    const int q = k / 16, j = k % 16;
    const double hi = j * kPiOver32Hi + j * kPiOver32Mid;
    const double lo = ((j * kPiOver32Hi - hi) + j * kPiOver32Mid) + j * kPiOver32Lo;
    const double c = std::cos(hi) - std::sin(hi) * lo, s = std::sin(hi) + std::cos(hi) * lo;
    const forcing_phasor quadrant[4] = {{c, s}, {-s, c}, {-c, -s}, {s, -c}};
    t[static_cast<std::size_t>(k)] = quadrant[q];
  }
  return t;
}();
}  // namespace detail

// (cos a, sin a) for the forcing: a = k pi/32 + r with |r| <= pi/64 (Cody-Waite, pi/32 in three
// parts, exact for |a| < 2^23 pi/32 ~ 8e5 rad; beyond, libm), then degree-9/10 Taylor polynomials
// in r (truncation < 1e-17) turned by the node's phasor. Within 4e-16 of libm's (tested) and
// faster: libm's trig was most of an RHS evaluation (docs/performance.md). The unbalance angle
// w t + phi is itself only good to ~1e-13 rad at t ~ 10 s, far above either's error.
inline forcing_phasor phasor_of(double a) noexcept {
  if (!(std::abs(a) < 8e5)) return {std::cos(a), std::sin(a)};
  const double k = std::nearbyint(a * (32.0 / std::numbers::pi));
  const double r = ((a - k * detail::kPiOver32Hi) - k * detail::kPiOver32Mid) - k * detail::kPiOver32Lo;
  const double r2 = r * r;
  // r - r^3/3! + ... + r^9/9! and 1 - r^2/2! + ... - r^10/10!, nested (reciprocals: no division).
  const double s = r * (1.0 - r2 * (1.0 / 6) * (1.0 - r2 * (1.0 / 20) * (1.0 - r2 * (1.0 / 42) * (1.0 - r2 * (1.0 / 72)))));
  const double c = 1.0 - r2 * 0.5 * (1.0 - r2 * (1.0 / 12) * (1.0 - r2 * (1.0 / 30) * (1.0 - r2 * (1.0 / 56) * (1.0 - r2 * (1.0 / 90)))));
  const auto& n = detail::kPhasorNodes[static_cast<std::size_t>(static_cast<long long>(k) & 63)];
  return {n.cos * c - n.sin * s, n.sin * c + n.cos * s};
}

// p turned by the angle whose phasor is r.
inline constexpr forcing_phasor rotated(forcing_phasor p, forcing_phasor r) noexcept {
  return {p.cos * r.cos - p.sin * r.sin, p.sin * r.cos + p.cos * r.sin};
}

template <std::size_t N>
bool is_finite(const std::array<double, N>& s) {
  for (const double v : s)
    if (!std::isfinite(v)) return false;
  return true;
}

inline constexpr double rpm_to_rad_s(double rpm) { return rpm * (2.0 * std::numbers::pi / 60.0); }
inline constexpr double rad_s_to_rpm(double omega) { return omega * (60.0 / (2.0 * std::numbers::pi)); }

}  // namespace rubref
