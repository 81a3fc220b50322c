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

decision exceeds(const statistic& s, double threshold) {
  const double u = std::abs(s.uncertainty);
  return {s.value > threshold, !(s.value - u > threshold) && s.value + u > threshold};
}

decision reaches(const statistic& s, double threshold) {
  const double u = std::abs(s.uncertainty);
  return {s.value >= threshold, !(s.value - u >= threshold) && s.value + u >= threshold};
}

decision both(const decision& a, const decision& b) {
  const bool a_fails = !a.yes && !a.on_margin, b_fails = !b.yes && !b.on_margin;
  return {a.yes && b.yes, !a_fails && !b_fails && (a.on_margin || b.on_margin)};
}

double criterion_change_uncertainty(double observations, double chi2_a, double u_a, double chi2_b, double u_b) {
  const double n = std::max(observations, 1.0);
  const auto relative = [](double u, double chi2) { return u > 0.0 ? u / std::max(chi2, 1e-300) : 0.0; };
  return n * (relative(u_a, chi2_a) + relative(u_b, chi2_b));
}

double information_criterion(double chi2, double observations, std::size_t coordinates) {
  // A perfect fit (chi^2 = 0, noise-free data) has the lowest criterion of all, not a NaN.
  const double n = std::max(observations, 1.0);
  return n * std::log(std::max(chi2, 1e-300) / n) + static_cast<double>(coordinates) * std::log(n);
}

need judge_need(const part_comparison& c, const evidence_rules& rules) {
  need out;
  const decision rise = exceeds({c.criterion_rise, c.criterion_rise_uncertainty}, rules.min_criterion_rise);
  const decision share = reaches({c.excess_share, c.excess_share_uncertainty}, rules.min_excess_share);
  // 0: no test finer than the criterion
  const decision seen = c.resolution > 0.0 ? exceeds({c.change, c.change_uncertainty}, c.resolution) : decision{true, false};
  const decision significant = both(both(rise, share), seen);
  out.significant = significant.yes;
  out.on_margin = significant.on_margin;
  const std::string margin = out.on_margin ? " (on the margin: within the statistics' numerical uncertainty)" : "";
  if (!rise.yes || !share.yes) {
    out.reason = "fails the significance rule (criterion rise " + format_digits(c.criterion_rise, 3) + ", share " + format_digits(c.excess_share, 3) + ")" + margin;
    return out;
  }
  if (!seen.yes) {
    out.reason = "changes the noise test's statistic by " + format_digits(c.change) + ", within its resolution " + format_digits(c.resolution) + margin;
    return out;
  }
  if (!c.holdout_gain) {
    out.reason = "significant (criterion rise " + format_digits(c.criterion_rise, 3) + "), not tested out of sample" + margin;
    return out;
  }
  const double g = *c.holdout_gain;
  // g >= share x in-sample gain, as g - share x gain >= 0 with both uncertainties.
  const decision gain = exceeds({g, c.holdout_gain_uncertainty}, rules.min_criterion_rise);
  const decision kept = reaches({g - rules.min_holdout_share * c.in_sample_gain,
                                 c.holdout_gain_uncertainty + rules.min_holdout_share * c.in_sample_gain_uncertainty},
                                0.0);
  const decision needed = both(significant, both(gain, kept));
  out.needed = needed.yes;
  out.on_margin = needed.on_margin;
  const std::string needed_margin = out.on_margin ? " (on the margin: within the statistics' numerical uncertainty)" : "";
  out.reason = out.needed ? "needed (criterion rise " + format_digits(c.criterion_rise, 3) + ", out of sample it gains chi^2 " + format_digits(g, 3) + ")" + needed_margin
                          : "not needed out of sample: " +
                                (c.holdout_folds == 2 ? "refitted on half of the data it gains chi^2 " + format_digits(g, 3) + " on the other half"
                                                      : "refitted without each of " + std::to_string(c.holdout_folds) + " folds in turn it gains chi^2 " +
                                                            format_digits(g, 3) + " on the rows left out") +
                                ", against " + format_digits(c.in_sample_gain, 3) + " on all" + needed_margin;
  return out;
}

decision decisive(double chosen_criterion, double rival_criterion, const evidence_rules& rules, double uncertainty) {
  // Decisive when the rival's criterion lies more than min_criterion_rise above the chosen one's.
  return exceeds({rival_criterion - chosen_criterion, uncertainty}, rules.min_criterion_rise);
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
  if (!in.plausible || !in.decisive || in.on_margin) return "tentative";
  if (in.residual_is_noise) return "full";
  const decision enough = reaches({in.explained_share, in.explained_share_uncertainty}, rules.claim_share);
  return enough.yes && !enough.on_margin ? "partial" : "tentative";
}

double explained_share(double base_excess, double after_excess) {
  if (!(base_excess > 0.0)) return 1.0;
  return std::clamp(1.0 - std::max(after_excess, 0.0) / base_excess, 0.0, 1.0);
}

}  // namespace rubref
