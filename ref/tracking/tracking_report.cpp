#include "ref/tracking/tracking_report.hpp"

#include <cmath>

#include "ref/base/number_text.hpp"
#include "ref/base/version.hpp"

namespace rubref {

namespace {

using json = nlohmann::ordered_json;

json interval(const estimate& e) { return json::array({e.lo, e.hi}); }

json quantity(const estimate& e) { return {{"value", e.value}, {"interval_95", interval(e)}, {"determined", e.determined}}; }

// An effect's evidence against the model without it.
json need_json(const tracked_model::need& n, bool with_name) {
  json j;
  if (with_name) j["effect"] = n.effect;
  j["bic_rise_without"] = n.bic_rise;
  j["excess_share"] = n.excess_share;
  j["held_out_chi2_without"] = n.held_out_without;
  j["held_out_chi2_with"] = n.held_out_with;
  j["held_out_gain"] = n.held_out_gain;
  j["needed"] = n.needed;
  j["reason"] = n.reason;
  return j;
}

json modes_json(const std::vector<response_mode>& modes) {
  json out = json::array();
  for (const auto& m : modes)
    out.push_back({{"axis", m.axis},
                          {"critical_speed_rpm", m.critical_speed_rpm.value},
                          {"critical_speed_rpm_interval_95", interval(m.critical_speed_rpm)},
                          {"damping_ratio", m.damping_ratio.value},
                          {"damping_ratio_interval_95", interval(m.damping_ratio)},
                          {"at_edge_of_speeds", m.at_edge},
                          {"determined", m.critical_speed_rpm.determined && m.damping_ratio.determined}});
  return out;
}

json fit_json(const response_fit& f) {
  json j;
  j["modes"] = modes_json(f.modes);
  j["unbalance"] = {{"e_m", quantity(f.unbalance_m)}, {"phase_deg", quantity(f.unbalance_phase_deg)}};
  j["probes"] = json::array();
  for (std::size_t p = 0; p < f.probes.size(); ++p)
    j["probes"].push_back({{"name", f.probes[p]},
                           {"angle_deg", quantity(f.probe_angle_deg[p])},
                           {"angle_fitted", static_cast<bool>(f.probe_angle_fitted[p])},
                           {"runout_m", quantity(f.runout_m[p])},
                           {"runout_phase_deg", quantity(f.runout_phase_deg[p])},
                           {"noise_m", f.noise_m[p]}});
  if (f.parts.shaft_bow) j["shaft_bow"] = {{"bow_m", quantity(f.bow_m)}, {"phase_deg", quantity(f.bow_phase_deg)}};
  if (f.parts.cross_coupling) j["cross_coupling"] = {{"k_xy_over_m_1_s2", quantity(f.k_xy_over_m)}, {"k_yx_over_m_1_s2", quantity(f.k_yx_over_m)}};
  if (f.parts.sweep)
    j["sweep_transient"] = {{"rate_rpm_per_s", quantity(f.sweep_rpm_per_s)},
                            {"direction", f.sweep_direction > 0 ? "run-up" : "coast-down"},
                            {"revolutions_per_row", f.sweep_revolutions},
                            {"revolutions_per_row_fitted", f.sweep_revolutions_fitted},
                            {"quasi_steady", f.sweep_at_slow_bound},
                            {"rate_given", f.sweep_rate_held},
                            {"revolutions_per_row_fitting_as_well", json(std::vector<double>(f.sweep_alternatives.begin() + (f.sweep_alternatives.empty() ? 0 : 1),
                                                                                         f.sweep_alternatives.end()))}};
  j["cancellation"] = f.cancellation;
  j["chi2"] = f.chi2;
  j["dof"] = f.dof;
  j["chi2_per_dof"] = f.chi2 / static_cast<double>(f.dof);
  j["rms_residual_m"] = f.rms_residual_m;
  j["consistent_with_noise"] = f.consistent_with_noise;
  j["evaluations"] = f.evaluations;
  return j;
}

json rub_json(const rub_result& t) {
  const rub_fit& f = t.fit;
  json j;
  j["named"] = t.named;
  j["law"] = "f_N/m = " + law_text(f.form) + ", Coulomb friction, per unit mass (the stator at +y of the probes' frame, turned by the contact angle)";
  j["form"] = {{"cubic", f.form.cubic},
               {"velocity_squared", f.form.velocity_squared},
               {"hertz", f.form.hertz},
               {"hunt_crossley", f.form.hunt_crossley},
               {"contact_angle", f.form.contact_angle}};
  j["form_needs"] = json::array();
  for (const auto& n : t.form_needs) j["form_needs"].push_back(need_json(n, true));
  j["path"] = "the rows followed as the rig ran them where the file's order is a run-up, a coast-down or a few such runs, else in rising speed";
  j["clearance_m"] = quantity(f.clearance_m);
  j["contact_stiffness_over_m_1_s2"] = quantity(f.contact_stiffness_over_m);
  if (f.form.cubic) j["cubic_stiffness_over_m_1_s2_m2"] = quantity(f.cubic_stiffness_over_m);
  if (f.form.velocity_squared) j["velocity_squared_over_m_1_m"] = quantity(f.velocity_squared_over_m);
  if (f.form.hertz) j["hertz_over_m_1_s2_m0_5"] = quantity(f.hertz_over_m);
  if (f.form.hunt_crossley)
    j["hunt_crossley"] = {{"lambda_over_m_1_s_mp", quantity(f.hunt_crossley_over_m)},
                          {"exponent", quantity(f.hunt_crossley_exponent)},
                          {"term_at_reference_over_m_1_s", quantity(f.hunt_crossley_at_reference)},
                          {"reference_penetration_m", f.hunt_crossley_reference_m}};
  if (f.form.contact_angle) j["contact_angle_deg"] = quantity(f.contact_angle_deg), j["probe_angle_fitted"] = f.probe_angle_fitted;
  j["friction"] = quantity(f.friction);
  j["modes"] = modes_json(f.modes);
  j["unbalance"] = {{"e_m", quantity(f.unbalance_m)}, {"phase_deg", quantity(f.unbalance_phase_deg)}};
  if (f.parts.shaft_bow) j["shaft_bow"] = {{"bow_m", quantity(f.bow_m)}, {"phase_deg", quantity(f.bow_phase_deg)}};
  if (f.parts.cross_coupling) j["cross_coupling"] = {{"k_xy_over_m_1_s2", quantity(f.k_xy_over_m)}, {"k_yx_over_m_1_s2", quantity(f.k_yx_over_m)}};
  j["probes"] = json::array();
  for (std::size_t p = 0; p < f.probes.size(); ++p)
    j["probes"].push_back({{"name", f.probes[p]}, {"runout_m", quantity(f.runout_m[p])}, {"runout_phase_deg", quantity(f.runout_phase_deg[p])}, {"noise_m", f.noise_m[p]}});
  j["rows_in_contact"] = f.rows_in_contact;
  j["contact_speed_range_rpm"] = json::array({f.contact_from_rpm, f.contact_to_rpm});
  j["rows_not_periodic"] = f.rows_not_periodic;
  j["rows_circled"] = f.rows_circled;
  j["rows_read_before_settled"] = json::array();
  for (const auto& r : f.rows_freed)
    j["rows_read_before_settled"].push_back({{"rpm", r.rpm}, {"settling_revolutions", std::isfinite(r.settling_revolutions) ? json(r.settling_revolutions) : json(nullptr)}});
  j["chi2"] = f.chi2;
  j["dof"] = f.dof;
  j["chi2_per_dof"] = f.chi2 / static_cast<double>(f.dof);
  j["rms_residual_m"] = f.rms_residual_m;
  j["consistent_with_noise"] = f.consistent_with_noise;
  j["undetermined"] = t.undetermined;
  j["need"] = need_json(t.need, false);
  j["evaluations"] = f.evaluations;
  j["orbits_shot"] = f.shots;
  j["summary"] = t.summary;
  return j;
}

json two_x_fit_json(const two_x_fit& f) {
  json j;
  j["misalignment"] = f.misalignment;
  if (f.misalignment) j["force_over_m_m_s2"] = quantity(f.force_over_m), j["force_phase_deg"] = quantity(f.force_phase_deg);
  j["probes"] = json::array();
  for (std::size_t p = 0; p < f.probes.size(); ++p)
    j["probes"].push_back({{"name", f.probes[p]}, {"runout_m", quantity(f.runout_m[p])}, {"runout_phase_deg", quantity(f.runout_phase_deg[p])}, {"noise_m", f.noise_m[p]}});
  j["cancellation"] = f.cancellation;
  j["chi2"] = f.chi2;
  j["dof"] = f.dof;
  j["chi2_per_dof"] = f.chi2 / static_cast<double>(f.dof);
  j["rms_residual_m"] = f.rms_residual_m;
  j["consistent_with_noise"] = f.consistent_with_noise;
  return j;
}

std::string um(double m, int digits = 3) { return format_digits(m * 1e6, digits) + " µm"; }
std::string with_interval(const estimate& e, double scale = 1.0, int digits = 3) {
  return format_digits(e.value * scale, digits) + " [" + format_digits(e.lo * scale, digits) + ", " + format_digits(e.hi * scale, digits) + "]";
}
std::string yes_no(bool b) { return b ? "yes" : "no"; }

}  // namespace

json to_json(const tracking_result& r) {
  json j;
  j["generator"] = "rubref " + std::string(version()) + " loop";
  j["kind"] = "order-tracked";
  j["source"] = r.table.source;
  j["rows"] = r.table.rows();
  j["speed_range_rpm"] = json::array({r.table.rpm.front(), r.table.rpm.back()});
  j["intake"] = {{"conventions", r.table.conventions}, {"notes", r.notes}};
  json after = fit_json(r.after);
  const bool rub_named = r.rub && r.rub->named;
  j["modes"] = rub_named ? modes_json(r.rub->fit.modes) : after["modes"];
  j["modes_from"] = rub_named ? "the rub fit" : "the contact-free fit";
  j["unbalance"] = rub_named ? rub_json(*r.rub)["unbalance"] : after["unbalance"];
  j["probes"] = after["probes"];
  j["noise"] = {{"from_row_scatter_m", r.noise_scatter_m},
                {"from_base_residual_m", r.noise_residual_m},
                {"used_m", r.after.noise_m},
                {"rule", "per probe, the smallest of the rows' scatter and the residual scatter of the base fit and of the best-fitting plausible model"}};
  j["verdict"] = to_json(r.decision);
  j["check"] = r.check ? json(to_json(*r.check)) : json(nullptr);
  j["error_before"] = r.error_before;
  j["error_after"] = r.error_after;
  j["error_unit"] = "m, RMS of the 1X residual per real and imaginary part";
  if (r.rub) j["rub"] = rub_json(*r.rub);
  if (r.two_x) {
    const two_x_result& t = *r.two_x;
    j["two_x"] = {{"error_before", t.before.rms_residual_m},
                  {"error_after", t.after().rms_residual_m},
                  {"misalignment_named", t.named},
                  {"verdict", to_json(t.decision)},
                  {"undetermined", t.undetermined},
                  {"need", need_json(t.need, false)},
                  {"noise", {{"from_row_scatter_m", t.noise_scatter_m}, {"from_runout_residual_m", t.noise_residual_m}, {"used_m", t.after().noise_m}}},
                  {"summary", t.summary},
                  {"before_fit", two_x_fit_json(t.before)},
                  {"with_misalignment_fit", two_x_fit_json(t.with)}};
  }
  j["before_fit"] = fit_json(r.before);
  if (r.steady) after["sweep_transient"]["steady_fit_of_the_same_effects"] = fit_json(*r.steady);
  j["after_fit"] = after;
  j["models"] = json::array();
  for (const auto& m : r.models) {
    json needs = json::array();
    for (const auto& n : m.needs) needs.push_back(need_json(n, true));
    j["models"].push_back({{"effects", m.effects},
                           {"chi2", m.chi2},
                           {"bic", m.bic},
                           {"plausible", m.undetermined.empty()},
                           {"undetermined", m.undetermined},
                           {"estimates", m.estimates},
                           {"needs", needs},
                           {"eligible", m.eligible},
                           {"summary", m.summary}});
  }
  j["residual_bands"] = json::array();
  for (const auto& b : r.bands)
    j["residual_bands"].push_back({{"probe", b.probe}, {"order", b.order}, {"from_rpm", b.from_rpm}, {"to_rpm", b.to_rpm}, {"rows", b.rows}, {"rms_over_noise", b.rms_over_noise}});
  j["cannot_see"] = r.cannot_see;
  return j;
}

std::string to_markdown(const tracking_result& r) {
  std::string s = "# rubref loop: order-tracked table\n\n";
  s += "`" + r.table.source + "`: " + std::to_string(r.table.rows()) + " rows, " + format_fixed(r.table.rpm.front(), 0) + "–" +
       format_fixed(r.table.rpm.back(), 0) + " rpm. Read as: " + r.table.conventions + ".\n\n";
  for (const auto& n : r.notes) s += "- " + n + "\n";
  const response_fit& f = r.after;
  const bool rub_named = r.rub && r.rub->named;
  s += "\n## Modes" + std::string(rub_named ? " (of the rub fit)" : "") +
       "\n\n| mode | critical speed (rpm) [95 %] | damping ratio [95 %] | determined |\n|---|---|---|---|\n";
  for (const auto& m : rub_named ? r.rub->fit.modes : f.modes)
    s += "| " + m.axis + " | " + with_interval(m.critical_speed_rpm, 1.0, 4) + " | " + with_interval(m.damping_ratio) + " | " +
         yes_no(m.critical_speed_rpm.determined && m.damping_ratio.determined) + (m.at_edge ? " (at the edge of the table's speeds)" : "") + " |\n";
  s += "\n## Unbalance, probes, runout" + std::string(rub_named ? " (of the contact-free fit; the rub fit's are below)" : "") + "\n\n";
  s += "- unbalance e: " + with_interval(f.unbalance_m, 1e6) + " µm at " + with_interval(f.unbalance_phase_deg) + "° from the keyphasor\n";
  for (std::size_t p = 0; p < f.probes.size(); ++p) {
    const std::string name = f.probes[p].empty() ? "the probe" : "probe " + f.probes[p];
    s += "- " + name + ": angle " + with_interval(f.probe_angle_deg[p]) + "° " + (f.probe_angle_fitted[p] ? "(fitted, from mode a's axis)" : "(declared)") +
         "; runout " + with_interval(f.runout_m[p], 1e6) + " µm at " + with_interval(f.runout_phase_deg[p]) + "°; noise " + um(f.noise_m[p]) + "\n";
  }
  if (f.parts.shaft_bow) s += "- shaft bow: " + with_interval(f.bow_m, 1e6) + " µm at " + with_interval(f.bow_phase_deg) + "°\n";
  if (f.parts.cross_coupling)
    s += "- cross-coupling k_xy/m " + with_interval(f.k_xy_over_m) + " 1/s², k_yx/m " + with_interval(f.k_yx_over_m) + " 1/s²\n";
  if (f.parts.sweep)
    s += "- the run-up's transient: swept " + std::string(f.sweep_direction > 0 ? "up" : "down") + " at " +
         (f.sweep_rate_held ? format_digits(f.sweep_rpm_per_s.value, 4) + " rpm/s (given: see the notes)" : with_interval(f.sweep_rpm_per_s) + " rpm/s") +
         " (constant acceleration), each row read over " + format_digits(f.sweep_revolutions) + " revolutions (" +
         (f.sweep_revolutions_fitted ? "fitted" : "declared") + "); the steady fit of the same effects put ";
  if (f.parts.sweep && r.steady) {
    std::string modes;
    for (const auto& m : r.steady->modes)
      modes += (modes.empty() ? "" : "; ") + ("mode " + m.axis + " at " + with_interval(m.critical_speed_rpm, 1.0, 4) + " rpm, damping ratio " + with_interval(m.damping_ratio));
    s += modes + " (a steady fit's bias on a swept table)\n";
  }
  // Where the sweep was fitted and not kept for want of a determined rate: the table is
  // quasi-steady at its noise, said as such.
  for (const auto& m : r.models)
    if (m.effects == std::vector<std::string>{"sweep_transient"} && !m.undetermined.empty() && !f.parts.sweep)
      s += "- the run-up's transient: the table is quasi-steady at its noise (" + m.undetermined + "): a steady fit's critical speed and damping "
           "are not biased by the sweep beyond their intervals\n";
  for (std::size_t p = 0; p < r.noise_scatter_m.size(); ++p)
    s += "- noise" + (f.probes[p].empty() ? std::string() : " of " + f.probes[p]) + ": " + um(r.noise_scatter_m[p]) + " from the rows' scatter, " +
         um(r.noise_residual_m[p]) + " from the base fit's residual; used " + um(f.noise_m[p]) +
         " (the smallest of those and the best-fitting plausible model's residual scatter)\n";
  s += "\n" + to_markdown(r.decision);
  if (r.check) s += to_markdown(*r.check);
  const double chi2_after = rub_named ? r.rub->fit.chi2 / static_cast<double>(r.rub->fit.dof) : f.chi2 / static_cast<double>(f.dof);
  s += "- error before (base fit): " + um(r.error_before) + " RMS; after: " + um(r.error_after) + " (χ²/dof " +
       format_digits(r.before.chi2 / static_cast<double>(r.before.dof), 3) + " → " + format_digits(chi2_after, 3) + ")\n";
  if (r.rub) {
    const rub_fit& g = r.rub->fit;
    s += "- rub (the chosen model with the paper's contact, f_N/m = " + law_text(g.form) + ", shot at every speed): " + r.rub->summary + "\n";
    for (const auto& n : r.rub->form_needs) s += "  - its form, " + n.effect + ": " + n.reason + "\n";
    if (r.rub->named) {
      s += "  - its modes: ";
      for (std::size_t m = 0; m < g.modes.size(); ++m)
        s += (m ? "; " : "") + g.modes[m].axis + " " + with_interval(g.modes[m].critical_speed_rpm, 1.0, 4) + " rpm, damping ratio " + with_interval(g.modes[m].damping_ratio);
      s += "; unbalance " + with_interval(g.unbalance_m, 1e6) + " µm at " + with_interval(g.unbalance_phase_deg) + "°\n";
    }
  }
  if (r.two_x) {
    const two_x_result& t = *r.two_x;
    s += "- 2X: error before (runout alone): " + um(t.before.rms_residual_m) + " RMS; after: " + um(t.after().rms_residual_m) + "; " + t.summary +
         "; " + summary_line(t.decision) + "\n";
    if (t.with.misalignment)
      s += "- misalignment fit: F2/m " + with_interval(t.with.force_over_m) + " m/s² at " + with_interval(t.with.force_phase_deg) + "° (through the chosen modes at 2X)\n";
    for (std::size_t p = 0; p < t.after().probes.size(); ++p)
      s += "- 2X runout" + (t.after().probes[p].empty() ? std::string() : " of " + t.after().probes[p]) + ": " + with_interval(t.after().runout_m[p], 1e6) +
           " µm at " + with_interval(t.after().runout_phase_deg[p]) + "°; 2X noise " + um(t.after().noise_m[p]) + "\n";
  }
  s += "\nEvery combination of the effects, fitted (the chosen one has the lowest BIC of those whose every part is determined and every effect "
       "needed):\n\n| effects | their parameters [95 %] | verdict |\n|---|---|---|\n";
  for (const auto& m : r.models) {
    std::string names;
    for (const auto& e : m.effects) names += (names.empty() ? "" : ", ") + e;
    s += "| " + (names.empty() ? std::string("base") : names) + " | " + (m.estimates.empty() ? std::string("–") : m.estimates) + " | " + m.summary + " |\n";
  }
  if (!r.bands.empty()) {
    s += "\nWhere the residual is not noise (0.1 % false-alarm rate per stretch):\n\n| probe | order | from (rpm) | to (rpm) | rows | RMS / noise |\n|---|---|---|---|---|---|\n";
    for (const auto& b : r.bands)
      s += "| " + (b.probe.empty() ? std::string("-") : b.probe) + " | " + std::to_string(b.order) + "X | " + format_fixed(b.from_rpm, 0) + " | " + format_fixed(b.to_rpm, 0) + " | " +
           std::to_string(b.rows) + " | " + format_digits(b.rms_over_noise, 3) + " |\n";
  }
  s += "\n## What such a table cannot show\n\n";
  for (const auto& c : r.cannot_see) s += "- " + c + "\n";
  return s;
}

json plot_data(const tracking_result& r) {
  json j;
  j["source"] = r.table.source;
  j["rpm"] = r.table.rpm;
  j["probes"] = json::array();
  for (std::size_t p = 0; p < r.after.probes.size(); ++p) {
    json probe;
    probe["name"] = r.after.probes[p];
    std::vector<double> dre, dim, bre, bim, are, aim, sre, sim;
    std::size_t order = 0;
    for (std::size_t o = 0; o < r.table.orders.size(); ++o)
      if (r.table.orders[o].order == 1 && r.table.orders[o].probe == r.after.probes[p]) order = o;
    for (std::size_t i = 0; i < r.table.rows(); ++i) {
      dre.push_back(r.table.orders[order].vector[i].real()), dim.push_back(r.table.orders[order].vector[i].imag());
      bre.push_back(r.before.model[p][i].real()), bim.push_back(r.before.model[p][i].imag());
      const auto a = r.rub && r.rub->named ? r.rub->fit.model[p][i] : r.after.model[p][i];
      are.push_back(a.real()), aim.push_back(a.imag());
      if (r.steady) sre.push_back(r.steady->model[p][i].real()), sim.push_back(r.steady->model[p][i].imag());
    }
    if (r.steady) probe["steady_re"] = sre, probe["steady_im"] = sim;
    probe["data_re"] = dre, probe["data_im"] = dim;
    probe["before_re"] = bre, probe["before_im"] = bim;
    probe["after_re"] = are, probe["after_im"] = aim;
    probe["noise_m"] = r.after.noise_m[p];
    if (r.two_x) {
      const std::vector<std::size_t> columns = two_x_columns(r.table, r.after);
      std::vector<double> d2re, d2im, b2re, b2im, a2re, a2im;
      for (std::size_t i = 0; i < r.table.rows(); ++i) {
        const auto d = r.table.orders[columns[p]].vector[i];
        d2re.push_back(d.real()), d2im.push_back(d.imag());
        b2re.push_back(r.two_x->before.model[p][i].real()), b2im.push_back(r.two_x->before.model[p][i].imag());
        a2re.push_back(r.two_x->after().model[p][i].real()), a2im.push_back(r.two_x->after().model[p][i].imag());
      }
      probe["two_x"] = {{"data_re", d2re}, {"data_im", d2im}, {"before_re", b2re}, {"before_im", b2im}, {"after_re", a2re}, {"after_im", a2im},
                        {"noise_m", r.two_x->after().noise_m[p]}};
    }
    j["probes"].push_back(probe);
  }
  j["effects"] = r.decision.chosen();
  return j;
}

}  // namespace rubref
