#include "ref/inference/verdict.hpp"

#include <algorithm>

#include "ref/base/number_text.hpp"
#include "ref/inference/evidence.hpp"

namespace rubref {

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::pair<verdict_check, std::string> checked(const verdict& fit, const std::optional<verdict>& check, double tolerance_scale, double factor,
                                              const std::string& failure) {
  const auto sorted = [](std::vector<std::string> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  verdict_check c{tolerance_scale, check.value_or(verdict{}), check && sorted(fit.named) == sorted(check->named)};
  if (c.agrees) return {c, ""};
  const auto list = [](const std::vector<std::string>& v) { return v.empty() ? std::string("nothing") : joined(v); };
  return {c, "the verdict's check (the loop again with orbit tolerances " + format_digits(factor) + " times the fit's) " +
                 (check ? "names " + list(check->named) + " where the fit names " + list(fit.named) +
                              ": the orbits' accuracy, not the data, chose between them, so both are tentative"
                        : "failed (" + failure + "): the verdict is tentative")};
}

std::vector<std::string> chosen_by_check_only(const std::vector<std::string>& names, const verdict* check, const std::vector<std::string>& also_not) {
  std::vector<std::string> out;
  if (check == nullptr) return out;
  const auto in = [](const std::vector<std::string>& v, const std::string& e) { return std::find(v.begin(), v.end(), e) != v.end(); };
  for (const auto& e : check->chosen())
    if (!in(names, e) && !in(also_not, e)) out.push_back(e);
  return out;
}

nlohmann::ordered_json to_json(const verdict_check& c) {
  return {{"orbit_tolerance_scale", c.tolerance_scale}, {"agrees", c.agrees}, {"verdict", to_json(c.decision)}};
}

std::string to_markdown(const verdict_check& c) {
  return "- the verdict's check (the loop again with orbit tolerances " + format_digits(c.tolerance_scale) + " times the defaults) names " +
         (c.decision.named.empty() ? std::string("nothing") : joined(c.decision.named)) + " (claim: " + c.decision.claim + "): " +
         (c.agrees ? "the same effects" : "other effects, so the verdict above is tentative") + "\n\n";
}

std::vector<std::string> verdict::chosen() const {
  std::vector<std::string> all = named;
  all.insert(all.end(), tentative.begin(), tentative.end());
  return all;
}

verdict decide(std::string subject, std::vector<std::string> chosen, const claim_inputs& in, const evidence_rules& rules, std::string rival,
               std::vector<std::string> reasons) {
  verdict v;
  v.subject = std::move(subject);
  claim_inputs with = in;
  with.anything_named = !chosen.empty();
  with.decisive = in.decisive && rival.empty();
  v.claim = claim_of(with, rules);
  v.explained_share = in.explained_share;
  v.residual_is_noise = in.residual_is_noise;
  v.unexplained = !in.residual_is_noise || !in.plausible;
  v.rival = std::move(rival);
  (v.claim == "full" || v.claim == "partial" ? v.named : v.tentative) = std::move(chosen);
  v.reasons = std::move(reasons);
  if (v.claim == "partial")
    v.reasons.push_back("named, partial: together they remove " + format_digits(100.0 * v.explained_share, 3) +
                        " % of the base fit's excess, but the residual is not noise (" + format_digits(100.0 * (1.0 - v.explained_share), 3) +
                        " % of the excess remains unexplained)");
  if (v.claim == "tentative" && in.on_margin)
    v.reasons.push_back("tentative: a decision on the way lay within its statistic's numerical uncertainty of its threshold (a fit's unfinished descent, "
                        "its orbits' tolerance): another tolerance, thread count or machine could decide it the other way");
  else if (v.claim == "tentative" && !v.rival.empty())
    v.reasons.push_back("not decisive: " + v.rival + " explains the data alike (within " + format_digits(rules.min_criterion_rise) + " of the criterion)");
  else if (v.claim == "tentative" && in.plausible && !in.residual_is_noise)
    v.reasons.push_back("tentative: together they remove " + format_digits(100.0 * v.explained_share, 3) + " % of the base fit's excess (a claim needs " +
                        format_digits(100.0 * rules.claim_share, 3) + " %) and leave a residual that is not noise");
  return v;
}

nlohmann::ordered_json to_json(const verdict& v) {
  return {{"subject", v.subject},
          {"claim", v.claim},
          {"named", v.named},
          {"tentative", v.tentative},
          {"explained_share", v.explained_share},
          {"residual_is_noise", v.residual_is_noise},
          {"unexplained", v.unexplained},
          {"rival", v.rival},
          {"reasons", v.reasons}};
}

std::string to_markdown(const verdict& v) {
  std::string s = "## Verdict\n\n";
  s += "- claim: **" + v.claim + "**";
  if (v.claim == "partial" || v.claim == "tentative") s += " (" + format_fixed(100.0 * (1.0 - v.explained_share), 1) + " % of the base fit's excess remains)";
  s += "\n- " + v.subject + " named: " + (v.named.empty() ? std::string("none") : joined(v.named)) + "\n";
  if (!v.tentative.empty()) s += "- tentative (chosen by the rules or decided on a margin; not claimed): " + joined(v.tentative) + "\n";
  if (!v.rival.empty()) s += "- rival: " + v.rival + "\n";
  s += "- residual: " + std::string(v.residual_is_noise ? "noise" : v.claim == "partial" ? "not noise: the remaining share is unexplained" : "not noise, unexplained") + "\n";
  for (const auto& r : v.reasons) s += "- " + r + "\n";
  return s + "\n";
}

std::string summary_line(const verdict& v) {
  std::string s = v.subject + ": " + (v.named.empty() ? std::string("none") : joined(v.named));
  if (!v.tentative.empty()) s += " (tentative: " + joined(v.tentative) + ")";
  if (v.claim == "partial") s += "; named, partial: " + format_digits(100.0 * (1.0 - v.explained_share), 3) + " % of the excess remains";
  else s += v.unexplained ? "; residual unexplained" : "; residual is noise";
  return s;
}

}  // namespace rubref
