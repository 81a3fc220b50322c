#pragma once
// What the virtual rig's probes read (measurement-only effects of ref/model/effects.hpp): the
// rotor model (ref/model/rotor_model.hpp) moves the shaft, the probes see it through these.

#include <array>
#include <cmath>
#include <numbers>

#include "ref/model/effects.hpp"

namespace rubref {

// What the two probes read (x at 0, y at 90 deg) of a rotor at (x, y) with the shaft at angle psi:
// the position in axes turned by the misorientation alpha, plus the shaft surface's runout
// a1 cos(psi' + phi1) + a2 cos(2 psi' + phi2), psi' = psi minus the probe's angle.
inline std::array<double, 2> probe_reading(const effect_parameters& fx, double x, double y, double psi) {
  const double ca = std::cos(fx.misorientation), sa = std::sin(fx.misorientation);
  const auto runout = [&](double a) {
    return fx.runout_1x * std::cos(a + fx.runout_1x_phase) + fx.runout_2x * std::cos(2.0 * a + fx.runout_2x_phase);
  };
  return {ca * x + sa * y + runout(psi), -sa * x + ca * y + runout(psi - 0.5 * std::numbers::pi)};
}

}  // namespace rubref
