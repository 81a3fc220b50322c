#pragma once
// The evidence rules of rubref (docs/architecture.md, "Fit and evidence"; docs/loop.md, "The
// rules"): what is needed in a model, what is plausible, when a choice is decisive, and what is
// claimed. The loop on records, the loop on tables and identification's choice of the law's
// structure all decide by these functions; each wing computes the statistics (its residuals,
// folds and noise tests), the rules compare them with the thresholds of the settings registry
// (scope "evidence"), and a decision is one `verdict` (ref/inference/verdict.hpp).

#include <optional>
#include <string>
#include <vector>

#include "ref/model/settings.hpp"

namespace rubref {

// The thresholds, from the registry (each row says why its value).
struct evidence_rules {
  double min_criterion_rise = default_of("evidence", "min_criterion_rise");  // a part's rise of the criterion without it
  double min_excess_share = default_of("evidence", "min_excess_share");      // of the excess without it that it removes
  double min_holdout_share = default_of("evidence", "min_holdout_share");    // out-of-sample gain over its gain on all data
  double claim_share = default_of("evidence", "claim_share");                // of the base fit's excess, for a partial claim
  double max_interval_ratio = default_of("evidence", "max_interval_ratio");  // a positive quantity's 95 % interval, end to end
  double max_cancellation = default_of("evidence", "max_cancellation");      // a model's parts over their sum
  double min_documented_level = default_of("evidence", "min_documented_level");  // an effect's size over its weakest documented level
  // input_error naming the rule, its range and its reason.
  void validate() const;
};

// A statistic and its numerical uncertainty: how far the computation alone may move it (a fit's
// unfinished descent, its orbits' tolerance, rounding), not the data's noise. A comparison of a
// statistic with a threshold is decided on its value, and is *on the margin* where the threshold
// lies within its uncertainty: another tolerance, thread count or machine could decide it the
// other way, and what hangs on it is tentative, never claimed.
struct statistic {
  double value = 0.0;
  double uncertainty = 0.0;  // >= 0, in the statistic's unit
};

// A comparison's outcome: `yes` on the value, and whether it lies on the margin.
struct decision {
  bool yes = false;
  bool on_margin = false;
};
decision exceeds(const statistic& s, double threshold);  // s.value > threshold
decision reaches(const statistic& s, double threshold);  // s.value >= threshold
// Both must hold: certain where either fails for certain, on the margin where neither does and
// one is on it.
decision both(const decision& a, const decision& b);

// The uncertainty of a criterion's change, n ln(chi2_a / chi2_b), from its two chi^2's own
// (u_a, u_b, in chi^2's unit): n (u_a / chi2_a + u_b / chi2_b), to first order.
double criterion_change_uncertainty(double observations, double chi2_a, double u_a, double chi2_b, double u_b);

// The information criterion of a least-squares fit (Schwarz's BIC for Gaussian noise whose
// scale is estimated with the fit): n ln(chi^2 / n) + k ln n, for chi^2 the sum of squared
// residuals (in any unit: a difference of two criteria on the same data does not depend on it),
// n residuals and k fitted coordinates. Records and tables alike; a lower value is better.
// Scale-free, a decision does not hinge on the noise estimate, and a model that leaves more than
// noise gains less from a part than a chi^2 difference would give it (the gain is weighed
// against what the model leaves, not against a noise it does not reach).
double information_criterion(double chi2, double observations, std::size_t coordinates);

// A model against the same model without one part (an effect, a law's term).
// Each statistic's numerical uncertainty beside it (0: exact as far as the wing knows).
struct part_comparison {
  double criterion_rise = 0.0;  // criterion without the part minus criterion with it
  double excess_share = 0.0;    // share of the without-model's excess over noise that the part removes
  double criterion_rise_uncertainty = 0.0, excess_share_uncertainty = 0.0;
  // The change the part makes to the wing's noise test's statistic, and the smallest change that
  // test resolves: a change within it is one that the test that calls a residual noise cannot
  // see, and neither can a claim (0 where the wing's test resolves nothing finer than the criterion).
  double change = 0.0, resolution = 0.0, change_uncertainty = 0.0;
  // Out of sample: chi^2 gained on data the models were not refitted on, and the gain on all data
  // (absent: not tested).
  std::optional<double> holdout_gain;
  std::size_t holdout_folds = 2;  // the folds each left out in turn (2: halves)
  double in_sample_gain = 0.0;
  double holdout_gain_uncertainty = 0.0, in_sample_gain_uncertainty = 0.0;
};

struct need {
  bool significant = false;  // criterion rise, share and resolution
  bool needed = false;       // significant and needed out of sample
  // The decision that ends the judgement (needed where tested out of sample, else significant)
  // lies within a statistic's numerical uncertainty of its threshold: tentative either way.
  bool on_margin = false;
  std::string reason;        // one line: why or why not
};

// Significant: the criterion rises by more than min_criterion_rise without it, it removes at
// least min_excess_share of the excess, and its change exceeds the test's resolution. Needed:
// significant, and out of sample it gains more than min_criterion_rise and at least
// min_holdout_share of its gain on all data.
need judge_need(const part_comparison& c, const evidence_rules& rules);

// Decisive: no rival explanation (another model of other parts that passes the rules) comes
// within min_criterion_rise of the chosen model's criterion; two within it explain the data alike.
// `uncertainty`: that of the two criteria's difference.
decision decisive(double chosen_criterion, double rival_criterion, const evidence_rules& rules, double uncertainty = 0.0);

// A positive quantity with 95 % interval [lo, hi] is determined when the interval spans less than
// max_interval_ratio end to end (within a factor of 2 either way, at the default).
bool interval_determined(double lo, double hi, const evidence_rules& rules);

// Plausible: every part determined and nothing outside its physical range. The wing lists what is
// not (one reason per failing part); the first reason, or "" when plausible.
std::string first_implausible(const std::vector<std::string>& reasons);

// What is claimed (one word): "full" (something named, and the residual is noise), "partial"
// (named, the residual is not noise, but at least claim_share of the base fit's excess is
// removed), "tentative" (chosen by the rules but not claimed: too little removed, implausible, not
// decisive, or a decision on the way lay on its margin), "none" (nothing named).
struct claim_inputs {
  bool anything_named = false;
  bool residual_is_noise = false;
  double explained_share = 0.0;  // of the base fit's excess over the noise
  double explained_share_uncertainty = 0.0;
  bool plausible = true;
  bool decisive = true;
  bool on_margin = false;  // a decision that chose (or left out) a part lay within its statistic's uncertainty
};
std::string claim_of(const claim_inputs& in, const evidence_rules& rules);

// The share of the base fit's excess over what noise leaves that a model removes, in [0, 1]:
// 1 - after / base for the two excesses (a negative excess is none; 1 when the base has none).
double explained_share(double base_excess, double after_excess);

}  // namespace rubref
