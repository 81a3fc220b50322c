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
// The turn's cosine and sine are taken once per model, and an absent runout costs nothing: the
// loop reads the model at every sample of every evaluation (the same bits as term by term).
class probe_model {
 public:
  explicit probe_model(const effect_parameters& fx)
      : fx_(fx), ca_(std::cos(fx.misorientation)), sa_(std::sin(fx.misorientation)), runout_(fx.runout_1x != 0.0 || fx.runout_2x != 0.0) {}
  std::array<double, 2> operator()(double x, double y, double psi) const {
    std::array<double, 2> out{ca_ * x + sa_ * y, -sa_ * x + ca_ * y};
    if (runout_) out[0] += runout(psi), out[1] += runout(psi - 0.5 * std::numbers::pi);
    return out;
  }

 private:
  double runout(double a) const {
    return fx_.runout_1x * std::cos(a + fx_.runout_1x_phase) + fx_.runout_2x * std::cos(2.0 * a + fx_.runout_2x_phase);
  }
  effect_parameters fx_;
  double ca_, sa_;
  bool runout_;
};

inline std::array<double, 2> probe_reading(const effect_parameters& fx, double x, double y, double psi) { return probe_model(fx)(x, y, psi); }

}  // namespace rubref
