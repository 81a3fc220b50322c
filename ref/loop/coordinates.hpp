#pragma once
// The coordinates the loop fits (docs/loop.md): the paper's model's, and each library effect's,
// built from the effect's row of the library (effect_info::fit), so that a new effect needs no
// code here unless it needs a new fit_form.

#include <cmath>
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
  // The physical bounds of the value (a contact force term or stiffness that cannot be negative,
  // an exponent's range): the fit projects its steps onto them.
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
  // An effect's shape parameter (not a switch): its derivative where the effect is off is 0, so
  // the trace's scores leave it out; it is fitted with its switch, and profiled over its physical
  // range [range_lo, range_hi] (in natural units: the value itself, or exp(value) when
  // `logarithmic`) to say whether the records determine it.
  std::string effect = {};  // the effect it belongs to (empty: the paper's model)
  bool shape = false;
  std::string quantity = {}, unit = {};  // a shape's natural quantity and its unit (e.g. "v_c", "m/s"; "sqrt(k_s/m_s)", "rad/s")
  bool logarithmic = false;
  double range_lo = 0.0, range_hi = 0.0;
  double natural(double value) const { return logarithmic ? std::exp(value) : value; }
  double chart(double natural_value) const { return logarithmic ? std::log(natural_value) : natural_value; }
  // When the effect enters the orbit so nonlinearly that its linearisation where it is off
  // misleads (the contact's angle, the probes' orientation), the trace also tries it at these values
  // of a trial variable (0: off). `apply` sets the model there.
  struct trial_grid {
    std::vector<double> values;
    std::function<void(model_point&, double)> apply;
  };
  std::optional<trial_grid> trials = {};
  // When the effect adds a lightly damped resonance that still rings when the rotor comes back
  // (a compliant stator), the residual along its ring frequency is a comb of narrow dips: the
  // phase of that ringing at the next impact turns with it. A local fit stays in the dip it
  // starts in (docs/loop.md, stator), so the effect's refit searches instead: a profile over
  // `envelope` values on the staged model with the coordinates named in `profiled` refitted at
  // each (`switch_on` first turns the effect on where it is off), fits from its best few, then hops:
  // the residual along the coordinate within `factor` of the fit's value either way (in its
  // natural units), in relative steps of `step`, and a fit from the lowest other dip while that
  // lands clearly lower (ref/loop/search.cpp).
  struct dip_search {
    std::vector<double> envelope;
    // Another coordinate set, at each envelope value, to each of these values in turn (the
    // stator's damping ratio: lightly damped, it rings from impact to impact and the residual is a
    // comb; heavily damped, it does not, and the law's own damping competes with it).
    std::string alternate;
    std::vector<double> alternate_values;
    std::vector<std::string> profiled;
    std::function<void(model_point&)> switch_on;
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
// amplitude-phase pairs as their two Cartesian components so that the fit is smooth through zero,
// then its shape parameters in their charts. The switches at zero are the effect off.
std::vector<fit_coordinate> effect_coordinates(const effect_info& e);

// How many of an effect's coordinates (effect_coordinates, switches first) are switches.
std::size_t switch_count(const std::vector<fit_coordinate>& ec);

// The coordinate of an effect that has a dip search, or end(): such an effect is refitted by it.
std::vector<fit_coordinate>::const_iterator dip_searched(const std::vector<fit_coordinate>& ec);

}  // namespace rubref
