#pragma once
// Stage 4 of `rubref loop` (docs/loop.md, "Trace"): from a residual that is not noise to the
// library effects the model lacks. Each round scores every effect not yet in the model, refits
// the best few, and adds the one that lowers the information criterion (BIC) most, if it passes
// three tests of the evidence rules (ref/inference/evidence.hpp):
//   - significance: a criterion rise without it and a share of the residual's synchronous excess;
//   - a fair comparison: the model without it, refitted from where its refit ended, must not
//     explain the same gain (a refit can gain by leaving the base's own local minimum);
//   - out of sample: refitted on half of the dwells, it must predict the other half better.
// After an effect is added, every earlier one is tested for removal (backward elimination) and
// for exchange with the effects that competed with it in its round.

#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "ref/inference/evidence.hpp"
#include "ref/loop/fit.hpp"
#include "ref/loop/preprocess.hpp"

namespace rubref {

struct trace_settings {
  // Defaults, ranges and reasons: the settings registry (scope "trace").
  int max_effects = default_count_of("trace", "max_effects");            // effects in the model at most
  int refit_candidates = default_count_of("trace", "refit_candidates");  // effects refitted per round (best linearised scores)
  // The evidence rules (ref/inference/evidence.hpp): an effect is added when it is needed (the
  // criterion rises without it, it removes a share of the synchronous excess: the energy of the
  // residual's shaft orders -orders..orders above what noise alone puts there; and it is needed
  // out of sample), and claimed by the claim rule.
  evidence_rules rules;
  int orders = default_count_of("trace", "orders");                  // shaft orders of the residual spectrum and the synchronous test
  int whiteness_lags = default_count_of("trace", "whiteness_lags");
  int max_jacobians = default_count_of("trace", "max_jacobians");    // per fit (ref/inference/least_squares.hpp)
  // Shape parameters are profiled at this many values across their physical range (ends included).
  int profile_points = default_count_of("trace", "profile_points");
  // How the model's orbits are shot and sampled (the stability check scales their tolerances).
  fit_orbit_options orbits;
  std::function<void(const std::string&)> progress = [](const std::string&) {};
  // input_error naming the setting, its range and its reason.
  void validate() const;
};

struct effect_candidate {
  std::string name;
  double score = 0.0;        // ERR on the residual of its linearised regressors (or its profile's share)
  bool refitted = false;
  std::string start;         // the start its refit won from
  double bic_drop = 0.0;     // BIC before - BIC after the refit (positive: better)
  double excess_share = 0.0; // of the synchronous excess (shaft orders above their noise energy), removed by the refit
  double error_after = 0.0;  // NRMSE over contact dwells after the refit
  double holdout_gain = std::numeric_limits<double>::quiet_NaN();  // chi^2 gained out of sample (NaN: not tested)
  // Its numerical uncertainty, and the gain on all data it is compared with (chi^2, with its own).
  double holdout_gain_uncertainty = 0.0, in_sample_gain = 0.0, in_sample_gain_uncertainty = 0.0;
  std::string verdict;       // why it was or was not added
};

// Whether the records determine a shape parameter: its profile over the physical range (every
// other coordinate refitted at each value), in chi^2 above the fit's, scaled by the fit's own
// chi^2/dof where that exceeds 1 (a residual that is not noise). A parameter whose profile stays
// below the 95 % bound over the whole range is not identifiable from these records, and the claim
// holds at any value of it.
struct parameter_profile {
  std::string coordinate;              // the fit's coordinate
  std::string quantity, unit;          // what it is, in natural units
  double estimate = 0.0;               // natural units
  double range_lo = 0.0, range_hi = 0.0;
  std::vector<double> values, delta_chi2;  // the profile (natural units)
  // The 95 % interval lies strictly between these grid values (the range's ends where unbounded).
  double interval_lo = 0.0, interval_hi = 0.0;
  bool bounded_below = false, bounded_above = false;
  std::string verdict;                 // "determined", "bounded below", "bounded above", or "not identifiable: ..."
};

struct loop_step {
  std::string effect;
  std::vector<std::pair<std::string, double>> params;  // the library's keys and SI values (every one fitted)
  std::vector<parameter_profile> profiles;             // its shape parameters' profiles (identifiability)
  double error_after_adding = 0.0;
  double bic_drop = 0.0, excess_share = 0.0, holdout_gain = 0.0;
  std::vector<effect_candidate> candidates;            // the round's scores, best first
  std::vector<std::string> alternatives;               // the others that passed the significance rule in its round
  std::string rival;                                   // one needed too, within the decisive margin of its criterion ("" if none)
  std::string exchanged_for;                           // it took this effect's place later (its scores are then that round's)
};

// An effect taken out again: the model without it, refitted, is not significantly worse
// (backward elimination), or the model with another in its place is better (exchange).
struct removed_effect {
  std::string effect;
  std::size_t after_adding = 0;  // how many effects had been added when it was removed
  double bic_drop = 0.0, excess_share = 0.0;  // what it still gained over the refit without it
  std::string replaced_by;       // the exchange's effect (empty: removed)
};

struct trace_result {
  model_point before;  // the paper's model's best fit: a fair comparison before any effect may improve it
  model_point after;
  orbit_anchors before_orbits, after_orbits;  // the orbits each is on
  std::vector<loop_step> effects;  // in the model at the end, in the order added
  std::vector<removed_effect> removed;
  std::vector<effect_candidate> last_round;  // the round that added nothing (if any)
  // Effects whose addition, rejection, removal or exchange lay within its statistics' numerical
  // uncertainty of the rule's threshold (ref/inference/evidence.hpp): tentative, whichever way it went.
  std::vector<std::string> on_margin;
  double before_uncertainty = 0.0, after_uncertainty = 0.0;  // m^2: each model's |r|^2's numerical uncertainty
  std::vector<std::string> notes;
};

// The trace from the paper's model's fit `before` (its orbit computable in every dwell).
trace_result trace(const std::vector<loop_dwell>& dwells, orbit_predictor& predictor, double noise, const model_point& staged,
                   const fit_result& before, const trace_settings& s);

// The first parameter of the effect (present at m) whose value lies outside the library's fit range
// (what a fit may search: beyond it the effect is no longer the physics its row describes), or nullptr.
const effect_parameter_info* outside_fit_range(const effect_info& e, const model_point& m);

// An effect's parameters in `fx` (library keys, SI).
std::vector<std::pair<std::string, double>> effect_params(const effect_info& e, const effect_parameters& fx);

}  // namespace rubref
