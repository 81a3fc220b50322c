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
