#include "ref/loop/report.hpp"

#include <cmath>
#include <sstream>

#include "ref/model/parameter_io.hpp"

namespace rubref {

using json = nlohmann::ordered_json;

namespace {

json check_json(const correlation_check& c) {
  return {{"name", c.name}, {"value", c.value}, {"uncertainty", c.uncertainty}, {"limit", c.limit}, {"pass", c.pass}, {"on_margin", c.on_margin}};
}

json validity_json(const validity_report& v) {
  json j{{"noise_m", v.noise}, {"residual_rms_m", v.rms}, {"pass", v.pass}, {"on_margin", v.on_margin}};
  j["checks"] = json::array({check_json(v.noise_level), check_json(v.synchronous), check_json(v.whiteness)});
  for (const auto& c : v.state) j["checks"].push_back(check_json(c));
  return j;
}

json candidates_json(const std::vector<effect_candidate>& cs) {
  json a = json::array();
  for (const auto& c : cs) {
    json j{{"name", c.name}, {"score", c.score}, {"refitted", c.refitted}};
    if (c.refitted) {
      j["start"] = c.start;
      j["bic_drop"] = c.bic_drop;
      j["excess_share"] = c.excess_share;
      j["error_after"] = c.error_after;
      if (std::isfinite(c.holdout_gain)) {
        j["holdout_gain_chi2"] = c.holdout_gain;
        j["holdout_gain_uncertainty_chi2"] = c.holdout_gain_uncertainty;
        j["in_sample_gain_chi2"] = c.in_sample_gain;
        j["in_sample_gain_uncertainty_chi2"] = c.in_sample_gain_uncertainty;
      }
    }
    j["verdict"] = c.verdict;
    a.push_back(j);
  }
  return a;
}

std::string fmt(double v, int digits = 4) { return std::isfinite(v) ? format_digits(v, digits) : "—"; }

// NaN (no fit: nothing synchronous with contact) as JSON null.
json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

}  // namespace

json to_json(const loop_result& r) {
  json j;
  j["error_before"] = number(r.error_before);
  j["error_after"] = number(r.error_after);
  j["error_definition"] = "orbit NRMSE over the dwells with contact: sqrt(sum |model - measured|^2 / sum |measured - dwell mean|^2)";
  j["effects"] = json::array();
  for (const auto& e : r.effects) {
    json params;
    for (const auto& [k, v] : e.params) params[k] = v;
    json profiles = json::array();
    for (const auto& pr : e.profiles) {
      json d = json::array();
      for (double v : pr.delta_chi2) d.push_back(number(v));
      profiles.push_back({{"coordinate", pr.coordinate},
                          {"quantity", pr.quantity},
                          {"unit", pr.unit},
                          {"estimate", pr.estimate},
                          {"range", {pr.range_lo, pr.range_hi}},
                          {"values", pr.values},
                          {"delta_chi2", d},
                          {"interval_95", {pr.interval_lo, pr.interval_hi}},
                          {"bounded_below", pr.bounded_below},
                          {"bounded_above", pr.bounded_above},
                          {"verdict", pr.verdict}});
    }
    j["effects"].push_back({{"name", e.effect},
                            {"params", params},
                            {"claimed", r.decision.claim == "full" || r.decision.claim == "partial"},
                            {"profiles", profiles},
                            {"error_after_adding", e.error_after_adding},
                            {"bic_drop", e.bic_drop},
                            {"excess_share", e.excess_share},
                            {"holdout_gain_chi2", e.holdout_gain},
                            {"alternatives", e.alternatives},
                            {"rival", e.rival},
                            {"exchanged_for", e.exchanged_for},
                            {"candidates", candidates_json(e.candidates)}});
  }
  j["verdict"] = to_json(r.decision);
  j["on_margin"] = r.on_margin;  // effects decided within their statistics' numerical uncertainty (docs/loop.md, "Margins")
  // The verdict's check (docs/loop.md, "The verdict's check"): the loop again with tighter orbits.
  j["check"] = r.check ? json(to_json(*r.check))
                       : json(nullptr);
  j["removed"] = json::array();
  for (const auto& e : r.removed)
    j["removed"].push_back({{"name", e.effect},
                            {"after_adding", e.after_adding},
                            {"bic_drop", e.bic_drop},
                            {"excess_share", e.excess_share},
                            {"replaced_by", e.replaced_by}});
  if (!r.last_round.empty()) j["rejected_round"] = candidates_json(r.last_round);
  j["excluded"] = json::array();
  for (const auto& e : r.excluded)
    j["excluded"].push_back(
        {{"record", e.record}, {"rpm", e.rpm}, {"contact", e.contact}, {"revolution_spread_m", e.spread}, {"reason", e.reason}});
  j["before_fit"] = {{"winner", r.start_winner}, {"tie", r.start_tie}, {"starts", json::array()}};
  for (const auto& st : r.starts)
    j["before_fit"]["starts"].push_back({{"name", st.name}, {"rss_start_m2", number(st.rss_start)}, {"rss_fit_m2", number(st.rss_fit)}});
  j["model_evaluations"] = r.model_evaluations;
  j["sensitivity_evaluations"] = r.sensitivity_evaluations;
  j["noise_m"] = r.noise;
  j["mass_source"] = r.mass_source;
  j["model_staged"] = to_json(r.initial.p);
  j["model_before"] = to_json(r.before.p);
  j["model_after"] = to_json(r.after.p);
  j["validity_before"] = validity_json(r.validity_before);
  j["validity_after"] = validity_json(r.validity_after);
  j["records"] = json::array();
  for (const auto& e : r.errors)
    j["records"].push_back({{"record", e.record},
                            {"rpm", e.rpm},
                            {"contact", e.contact},
                            {"samples", e.samples},
                            {"orbit", e.orbit},
                            {"periods", e.periods},
                            {"rms_before_m", e.rms_before},
                            {"rms_after_m", e.rms_after},
                            {"error_before", e.nrmse_before},
                            {"error_after", e.nrmse_after}});
  j["residual_spectrum"] = {{"orders", r.spectrum.orders}, {"before_m", r.spectrum.before}, {"after_m", r.spectrum.after}};
  j["warnings"] = r.warnings;
  j["notes"] = r.notes;
  return j;
}

std::string to_markdown(const loop_result& r) {
  std::ostringstream o;
  o << "# rubref loop report\n\n";
  if (!std::isfinite(r.error_before))
    o << "No dwell with contact was usable (each one left out is listed below with why): nothing was fitted.\n\n";
  o << "| | before | after |\n|---|---|---|\n";
  o << "| orbit NRMSE (contact dwells) | " << fmt(r.error_before) << " | " << fmt(r.error_after) << " |\n";
  const bool fitted = std::isfinite(r.error_before);
  const auto rms_um = [&](double rms) { return fitted ? fmt(rms * 1e6) + " um" : std::string("—"); };
  o << "| residual RMS | " << rms_um(r.validity_before.rms) << " | " << rms_um(r.validity_after.rms) << " |\n";
  const auto noise_verdict = [](const validity_report& v) { return std::string(v.pass ? "yes" : "no") + (v.on_margin ? " (on the margin)" : ""); };
  o << "| residual consistent with noise (" << fmt(r.noise * 1e6) << " um) | " << noise_verdict(r.validity_before) << " | "
    << noise_verdict(r.validity_after) << " |\n\n";
  o << to_markdown(r.decision);
  if (r.check) o << to_markdown(*r.check);
  o << "Effects the trace added, in order (" << (r.decision.named.empty() ? "not claimed" : "claimed: " + r.decision.claim) << "):";
  if (r.effects.empty()) o << " none.";
  o << "\n\n";
  if (!r.effects.empty()) {
    o << "| # | effect | parameters | error after adding | BIC drop | share of synchronous excess removed | out-of-sample gain (chi^2) |\n"
         "|---|---|---|---|---|---|---|\n";
    int i = 1;
    for (const auto& e : r.effects) {
      std::string ps;
      for (const auto& [k, v] : e.params) ps += (ps.empty() ? "" : ", ") + k + " = " + fmt(v);
      o << "| " << i++ << " | " << e.effect << " | " << ps << " | " << fmt(e.error_after_adding) << " | " << fmt(e.bic_drop, 6) << " | "
        << fmt(e.excess_share, 3) << " | " << fmt(e.holdout_gain, 4) << " |\n";
    }
    o << "\n";
    bool any_profile = false;
    for (const auto& e : r.effects) any_profile = any_profile || !e.profiles.empty();
    if (any_profile) {
      o << "Shape parameters (every one fitted; profiled over its physical range, every other coordinate refitted at each value; 95 % bound "
           "Delta chi^2 = 3.84, scaled by chi^2/dof where that exceeds 1):\n\n"
           "| effect | quantity | estimate | physical range | 95 % interval within | verdict |\n|---|---|---|---|---|---|\n";
      for (const auto& e : r.effects)
        for (const auto& pr : e.profiles)
          o << "| " << e.effect << " | " << pr.quantity << " [" << pr.unit << "] | " << fmt(pr.estimate) << " | " << fmt(pr.range_lo) << " ... "
            << fmt(pr.range_hi) << " | (" << (pr.bounded_below ? fmt(pr.interval_lo) : std::string("—")) << ", "
            << (pr.bounded_above ? fmt(pr.interval_hi) : std::string("—")) << ") | " << pr.verdict << " |\n";
      o << "\n";
    }
  }
  for (const auto& e : r.removed)
    if (e.replaced_by.empty())
      o << "Removed again: " << e.effect << " (after " << e.after_adding << " effects it gained only BIC " << fmt(e.bic_drop) << ", share "
        << fmt(e.excess_share, 3) << " over the model refitted without it).\n\n";
    else
      o << "Exchanged: " << e.replaced_by << " in place of " << e.effect << " (after " << e.after_adding << " effects, a lower BIC).\n\n";
  if (!r.start_winner.empty()) {
    o << "Before-fit starts (the best fit wins; fits alike within their numerical uncertainty are a tie, won by the first start):";
    for (const auto& st : r.starts)
      o << " " << st.name << " (residual " << fmt(st.rss_start) << " -> " << (std::isnan(st.rss_fit) ? std::string("not fitted") : fmt(st.rss_fit))
        << " m^2)" << (st.name == r.start_winner ? (r.start_tie ? " **won the tie**" : " **won**") : "") << ";";
    o << "\n\n";
  }
  if (!r.excluded.empty()) {
    o << "Left out of the fit:\n\n";
    for (const auto& e : r.excluded) o << "- " << e.record << ", " << fmt(e.rpm) << " rpm: " << e.reason << "\n";
    o << "\n";
  }
  if (!r.plot_x.empty()) o << "![orbit](orbit.png)\n\n![residual spectrum](residual_spectrum.png)\n\n![residual](residual.png)\n\n";
  // Nothing fitted: no check was made and no dwell compared (the tables would be empty rows).
  if (fitted) {
    o << "## Validity checks (after)\n\n| check | value | limit | pass |\n|---|---|---|---|\n";
    const auto passed = [](const correlation_check& c) { return std::string(c.pass ? "yes" : "no") + (c.on_margin ? " (on the margin)" : ""); };
    for (const auto* c : {&r.validity_after.noise_level, &r.validity_after.synchronous, &r.validity_after.whiteness})
      o << "| " << c->name << " | " << fmt(c->value) << " | " << fmt(c->limit) << " | " << passed(*c) << " |\n";
    for (const auto& c : r.validity_after.state) o << "| corr " << c.name << " | " << fmt(c.value) << " | " << fmt(c.limit) << " | " << passed(c) << " |\n";
    o << "\n## Per dwell\n\n| record | rpm | contact | samples | orbit | NRMSE before | NRMSE after | RMS before [um] | RMS after [um] |\n"
         "|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& e : r.errors)
      o << "| " << e.record << " | " << e.rpm << " | " << (e.contact ? "yes" : "no") << " | " << e.samples << " | " << e.orbit << (e.periods > 1 ? ", period " + std::to_string(e.periods) : std::string()) << " | " << fmt(e.nrmse_before) << " | "
        << fmt(e.nrmse_after) << " | " << fmt(e.rms_before * 1e6) << " | " << fmt(e.rms_after * 1e6) << " |\n";
  }
  for (const auto& w : r.warnings) o << "\n**Warning:** " << w << "\n";
  for (const auto& n : r.notes) o << "\nNote: " << n << "\n";
  return o.str();
}

json plot_data(const loop_result& r) {
  if (r.plot_x.empty()) return json::object();
  const auto& d = r.dwells[r.plot_dwell];
  return {{"title", d.record + ", " + fmt(d.data.rpm) + " rpm"},
          {"clearance_m", d.data.clearance},
          {"phase_deg", r.plot_phase},
          {"x_m", r.plot_x},
          {"y_m", r.plot_y},
          {"x_before_m", r.plot_x_before},
          {"y_before_m", r.plot_y_before},
          {"x_after_m", r.plot_x_after},
          {"y_after_m", r.plot_y_after},
          {"orders", r.spectrum.orders},
          {"spectrum_before_m", r.spectrum.before},
          {"spectrum_after_m", r.spectrum.after}};
}

}  // namespace rubref
