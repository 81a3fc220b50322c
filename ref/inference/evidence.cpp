#include "ref/inference/evidence.hpp"

#include <algorithm>
#include <cmath>

#include "ref/base/number_text.hpp"

namespace rubref {

void evidence_rules::validate() const {
  check({"evidence", "min_criterion_rise"}, min_criterion_rise);
  check({"evidence", "min_excess_share"}, min_excess_share);
  check({"evidence", "min_holdout_share"}, min_holdout_share);
  check({"evidence", "claim_share"}, claim_share);
  check({"evidence", "max_interval_ratio"}, max_interval_ratio);
  check({"evidence", "max_cancellation"}, max_cancellation);
  check({"evidence", "min_documented_level"}, min_documented_level);
}

double information_criterion(double chi2, double observations, std::size_t coordinates) {
  // A perfect fit (chi^2 = 0, noise-free data) has the lowest criterion of all, not a NaN.
  const double n = std::max(observations, 1.0);
  return n * std::log(std::max(chi2, 1e-300) / n) + static_cast<double>(coordinates) * std::log(n);
}

need judge_need(const part_comparison& c, const evidence_rules& rules) {
  need out;
  const bool rise = c.criterion_rise > rules.min_criterion_rise, share = c.excess_share >= rules.min_excess_share;
  const bool seen = !(c.resolution > 0.0) || c.change > c.resolution;  // 0: no test finer than the criterion
  out.significant = rise && share && seen;
  if (!rise || !share) {
    out.reason = "fails the significance rule (criterion rise " + format_digits(c.criterion_rise, 3) + ", share " + format_digits(c.excess_share, 3) + ")";
    return out;
  }
  if (!seen) {
    out.reason = "changes the noise test's statistic by " + format_digits(c.change) + ", within its resolution " + format_digits(c.resolution);
    return out;
  }
  if (!c.holdout_gain) {
    out.reason = "significant (criterion rise " + format_digits(c.criterion_rise, 3) + "), not tested out of sample";
    return out;
  }
  const double g = *c.holdout_gain;
  out.needed = g > rules.min_criterion_rise && g >= rules.min_holdout_share * c.in_sample_gain;
  out.reason = out.needed ? "needed (criterion rise " + format_digits(c.criterion_rise, 3) + ", out of sample it gains chi^2 " + format_digits(g, 3) + ")"
                          : "not needed out of sample: refitted on half of the data it gains chi^2 " + format_digits(g, 3) + " on the other half, against " +
                                format_digits(c.in_sample_gain, 3) + " on all";
  return out;
}

bool decisive(double chosen_criterion, double rival_criterion, const evidence_rules& rules) {
  return !(rival_criterion - chosen_criterion <= rules.min_criterion_rise);
}

bool interval_determined(double lo, double hi, const evidence_rules& rules) {
  return lo > 0.0 && std::isfinite(hi) && hi / lo < rules.max_interval_ratio;
}

std::string first_implausible(const std::vector<std::string>& reasons) {
  for (const auto& r : reasons)
    if (!r.empty()) return r;
  return {};
}

std::string claim_of(const claim_inputs& in, const evidence_rules& rules) {
  if (!in.anything_named) return "none";
  if (!in.plausible || !in.decisive) return "tentative";
  if (in.residual_is_noise) return "full";
  return in.explained_share >= rules.claim_share ? "partial" : "tentative";
}

double explained_share(double base_excess, double after_excess) {
  if (!(base_excess > 0.0)) return 1.0;
  return std::clamp(1.0 - std::max(after_excess, 0.0) / base_excess, 0.0, 1.0);
}

}  // namespace rubref
