#pragma once
// A decision of rubref's evidence rules (ref/inference/evidence.hpp), as the loop on records, the
// loop on tables and identification's choice of the law's structure report it: what is named and
// claimed, by which share, against which rival, and why. One type, one JSON writer and one
// Markdown writer; the command line prints it with one printer (ref/cli/verdict_printer.hpp).

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace rubref {

struct verdict {
  std::string subject;                 // what was decided: "effects" (the loops), "law terms" (identify)
  std::string claim = "none";          // claim_of: "full", "partial", "tentative" or "none"
  std::vector<std::string> named;      // claimed (empty unless the claim is full or partial)
  std::vector<std::string> tentative;  // chosen by the rules but not claimed, or decided on a margin (claim_inputs::on_margin)
  double explained_share = 0.0;        // of the base fit's excess over noise, by the final model
  bool residual_is_noise = false;      // the final model's residual passes the wing's noise test
  // Something is left that no acceptable model explains: the residual is not noise (after a
  // partial claim, the share that remains), or only an implausible model fits it.
  bool unexplained = false;
  std::string rival;                   // a model of other parts within min_criterion_rise of the chosen one ("" if none)
  std::vector<std::string> reasons;    // one line each: why the claim is what it is

  // Every name chosen, claimed or not, in order.
  std::vector<std::string> chosen() const;

};

// The claim decided (claim_of) and the names split by it: the chosen names are `named` when
// the claim is full or partial, `tentative` otherwise.
struct claim_inputs;
struct evidence_rules;
verdict decide(std::string subject, std::vector<std::string> chosen, const claim_inputs& in, const evidence_rules& rules,
               std::string rival = {}, std::vector<std::string> reasons = {});

// The verdict's check (docs/loop.md, "The verdict's check"; both loops, records and tables): the
// same loop run again with every orbit tolerance `tolerance_scale` times the defaults. A verdict
// that changes with the orbits' accuracy was decided by it, not by the data.
struct verdict_check {
  double tolerance_scale = 0.0;  // the check's orbit tolerances, times the defaults
  verdict decision;              // the check's own verdict
  bool agrees = true;            // it names the effects the fit names
};
// The check of `fit` by `check` (nullopt: the check failed, `failure` says why), whose orbits were
// `factor` times the fit's (tolerance_scale: the check's, times the defaults), and the reason the
// fit's verdict is then tentative ("" when the two name the same effects): the one rule both loops
// apply (each claims with it as a decision on the margin, the check's chosen effects tentative too).
std::pair<verdict_check, std::string> checked(const verdict& fit, const std::optional<verdict>& check, double tolerance_scale, double factor,
                                              const std::string& failure);
// The effects the check chose that `names` lacks (and `also_not` too): tentative beside the fit's
// where the check disagrees (none when `check` is null, a failed check).
std::vector<std::string> chosen_by_check_only(const std::vector<std::string>& names, const verdict* check, const std::vector<std::string>& also_not = {});
// The check's JSON object ({"orbit_tolerance_scale", "agrees", "verdict"}) and its Markdown line.
nlohmann::ordered_json to_json(const verdict_check& c);
std::string to_markdown(const verdict_check& c);
// Names as a list in prose: "a, b, c" ("" for none).
std::string joined(const std::vector<std::string>& names);

// Its JSON object ({"subject", "claim", "named", "tentative", "explained_share", "residual_is_noise",
// "unexplained", "rival", "reasons"}) and its Markdown section (a "## Verdict" heading).
nlohmann::ordered_json to_json(const verdict& v);
std::string to_markdown(const verdict& v);
// One line, as the command line ends a run: "effects: a, b (tentative: c); named, partial: 3.1 %
// of the excess remains" ...
std::string summary_line(const verdict& v);

}  // namespace rubref
