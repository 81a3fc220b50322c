#pragma once
// The coordinates the loop fits (docs/loop.md): the paper's model's, and each library effect's,
// built from the effect's row of the library (effect_info::fit), so that a new effect needs no
// code here unless it needs a new fit_form.

#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ref/loop/predictor.hpp"
#include "ref/model/effects.hpp"

namespace rubref {

// One scalar coordinate of the fit, with the scale it is searched in (value = scale * u).
struct fit_coordinate {
  std::string name;              // e.g. "k1", "hertz_contact.k_h", "shaft_bow.b_cos"
  double scale;
  std::function<double(const model_point&)> get;
  std::function<void(model_point&, double)> set;
  // The smallest physical value (a contact force term or stiffness that cannot be negative): the
  // fit projects its steps onto it.
  double lower = -std::numeric_limits<double>::infinity();
  // When the effect enters the orbit so nonlinearly that its linearisation where it is off
  // misleads (the contact's angle, the probes' orientation), the trace also tries it at these values
  // of a trial variable (0: off). `apply` sets the model there.
  struct trial_grid {
    std::vector<double> values;
    std::function<void(model_point&, double)> apply;
  };
  std::optional<trial_grid> trials = {};
  // When the effect adds a lightly damped resonance that still rings when the rotor comes back
  // (a compliant stator), the residual along its coordinate is a comb of narrow dips: the phase of
  // that ringing at the next impact turns with the coordinate. A local fit stays in the dip it
  // starts in (docs/loop.md, stator), so the effect's refit searches instead: a profile over
  // `envelope` values on the staged model with the coordinates named in `profiled` refitted at
  // each, a fit from its best, then hops: the residual along the coordinate within `factor` of
  // the fit's value either way, in relative steps of `step`, with `move` setting each value, and
  // a fit from the lowest other dip while that lands clearly lower (ref/loop/search.cpp).
  struct dip_search {
    std::vector<double> envelope;
    std::vector<std::string> profiled;
    // Sets the coordinate to a value and keeps what the data already pin (false: it cannot there).
    std::function<bool(model_point&, double)> move;
    double factor = 1.0;
    double step = 0.0;
  };
  std::optional<dip_search> search = {};
};

// The paper's model's coordinates: the linear part (c_x, c_y, k_x, k_y, e, unbalance angle), the
// identified law (k1, k3, c2) and friction (mu). The linear part, positive by nature, is searched
// as logarithms; the contact's coefficients, which a fit may drive to 0, as themselves, bounded by 0.
// m is given (Eq. 1 scales with it).
std::vector<fit_coordinate> paper_coordinates();

// The coordinates an effect adds, from its library row (effect_info::fit): its switch parameters,
// amplitude-phase pairs as their two Cartesian components so that the fit is smooth through zero;
// shape parameters are held at the library's values. Zero everywhere is the effect off.
std::vector<fit_coordinate> effect_coordinates(const effect_info& e);

// The coordinate of an effect that has a dip search, or end(): such an effect is refitted by it.
std::vector<fit_coordinate>::const_iterator dip_searched(const std::vector<fit_coordinate>& ec);

}  // namespace rubref
