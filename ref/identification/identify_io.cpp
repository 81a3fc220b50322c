#include "ref/identification/identify_io.hpp"

#include <cmath>
#include <sstream>

#include "ref/base/number_text.hpp"

namespace rubref {

nlohmann::ordered_json to_json(const identification& id, const identify_settings& s) {
  using json = nlohmann::ordered_json;
  const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json j;
  j["settings"] = {{"library", s.library},
                   {"rho", s.frols.rho},
                   {"err_threshold", s.frols.err_threshold},
                   {"stop", id.stop == frols_stop::err_sum ? "err_sum" : id.stop == frols_stop::aic ? "aic"
                                     : id.stop == frols_stop::bic ? "bic" : "significance"},
                   {"err_floor", s.frols.err_floor},
                   {"derivative", {{"method", "Savitzky-Golay, windows split at y = clearance"},
                                   {"half_width", s.derivative.half_width}, {"degree", s.derivative.degree}}},
                   {"law_method", std::string(to_string(id.law_route))},
                   {"law_method_reason", id.law_route_reason},
                   {"weak_form", {{"test_functions", s.weak.test_functions}, {"bump_power", s.weak.bump_power},
                                  {"margin", s.weak.margin}, {"velocity_half_width", s.weak.velocity_half_width}}},
                   {"averaging", std::string(to_string(s.average))},
                   {"orbit_fit", s.orbit_fit},
                   {"intervals", id.orbit && id.orbit->converged ? "normal, from the orbit fit's Jacobian"
                                 : id.weak                     ? "Student t on the whitened weak-form rows"
                                                               : "episode bootstrap"},
                   {"bootstrap_resamples", s.bootstrap},
                   {"friction_force_share", kFrictionForceShare}};
  const auto& L = id.linear;
  j["linear"] = {{"source", id.linear_source}, {"method", id.linear_fitted ? std::string(to_string(id.linear_fitted->method)) : "given"},
                 {"m_kg", L.m}, {"c_x_kg_s", L.c_x}, {"c_y_kg_s", L.c_y}, {"k_x_N_m", L.k_x},
                 {"k_y_N_m", L.k_y}, {"e_m", L.e}, {"unbalance_phase_rad", L.phase}};
  if (id.linear_fitted) {
    const auto& se = id.linear_fitted->standard_error;
    j["linear"]["standard_error"] = {{"c_x_kg_s", se[0]}, {"c_y_kg_s", se[1]}, {"k_x_N_m", se[2]}, {"k_y_N_m", se[3]},
                                     {"e_m", se[4]}, {"unbalance_phase_rad", se[5]}};
    j["linear"]["dwells"] = id.linear_fitted->dwells;
    j["linear"]["residual_rms_m_s2"] = id.linear_fitted->residual_rms;
    j["linear"]["one_phase_test"] = {{"chi2", id.linear_fitted->phase_chi2}, {"dof", id.linear_fitted->phase_dof},
                                     {"limit_999", id.linear_fitted->phase_limit}};
    if (!id.linear_fitted->beyond_1x_rms.empty()) j["linear"]["beyond_1x_rms_m"] = id.linear_fitted->beyond_1x_rms;
    for (const auto& n : id.free_noise) j["linear"]["noise_m"].push_back(n.sigma);
    for (const auto& n : id.free_noise) j["linear"]["quantisation_m"].push_back(n.quantisation);
    j["linear"]["note"] = "m is not identifiable from displacements (Eq. 1 scales with it); it is taken as given";
  }
  j["friction"] = {{"mu", id.mu}, {"mu_standard_error", num(id.mu_standard_error)}, {"mu_mean", id.mu_mean},
                   {"mu_spread", id.mu_spread}, {"mu_slope", id.mu_slope}};
  for (const auto& d : id.dwells) {
    json jd = {{"speed_rpm", d.rpm}, {"clearance_m", d.clearance}, {"samples", d.samples}, {"contact_samples", d.contact_samples},
               {"episodes", d.episodes}, {"max_penetration_m", d.max_penetration},
               {"noise_m", d.noise.sigma}, {"white_noise_m", d.noise.white}, {"quantisation_m", d.noise.quantisation},
               {"averaged_revolutions", d.averaged_revolutions}, {"average_spread_m", d.average_spread}, {"averaging", d.averaging}};
    if (d.friction)
      jd["mu"] = {{"samples", d.friction->samples}, {"mean", d.friction->mean}, {"std", d.friction->std_dev},
                  {"median", d.friction->median}, {"slope", d.friction->slope}};
    for (const auto& sh : d.reference_shares) jd["reference_law_peak_share"][sh.term] = sh.peak_share;
    for (const auto& sh : d.identified_shares) jd["identified_law_peak_share"][sh.term] = sh.peak_share;
    j["dwells"].push_back(jd);
  }
  j["frols"]["contact_samples"] = id.contact_samples;
  j["frols"]["episodes"] = id.episodes;
  j["frols"]["force_rms_N"] = id.force_rms;
  for (std::size_t k = 0; k < id.frols.order.size(); ++k) {
    const auto& st = id.frols.order[k];
    j["frols"]["order"].push_back({{"step", k + 1}, {"term", id.candidates[st.candidate]}, {"err", st.err},
                                   {"err_sum", st.err_sum}, {"aic", st.aic}, {"bic", st.bic}});
  }
  for (std::size_t c = 0; c < id.candidates.size(); ++c) j["frols"]["first_step_err"][id.candidates[c]] = id.first_step_err[c];
  for (std::size_t c = 0; c < id.paper_order_err.size(); ++c) j["frols"]["paper_order_err"][id.candidates[c]] = id.paper_order_err[c];
  j["frols"]["steps_selected"] = id.frols.steps_selected;
  j["frols"]["err_sum_kept"] = id.frols.err_sum_kept;
  j["frols"]["residual_rms_N"] = id.residual_rms;
  for (const auto& e : id.estimates)
    j["estimates"].push_back({{"term", e.name}, {"value", e.value}, {"standard_error", e.standard_error},
                              {"bootstrap_95", {num(e.ci_low), num(e.ci_high)}}});
  for (const auto& t : id.validity)
    j["validity"].push_back({{"test", t.name}, {"band", t.band}, {"max_abs", t.max_abs},
                             {"outside_fraction", t.outside_fraction}, {"pass", t.pass}});
  if (id.weak)
    j["weak_form"] = {{"rows", id.weak->rows}, {"episodes", id.weak->episodes}, {"noise_m", id.weak->noise},
                      {"residual_rms_m", id.weak->residual_rms}, {"chi2_per_dof", num(id.weak->chi2_per_dof)},
                      {"chi2_limit", id.weak->chi2_limit}};
  if (id.orbit) {
    const auto& o = *id.orbit;
    j["orbit_fit"] = {{"converged", o.converged}, {"status", o.status}, {"iterations", o.iterations},
                      {"evaluations", o.evaluations}, {"failed_evaluations", o.failed_evaluations},
                      {"residuals", o.residuals}, {"unknowns", o.unknowns}, {"initial_chi2_per_dof", num(o.initial_chi2)},
                      {"final_chi2_per_dof", num(o.final_chi2)}, {"chi2_limit", orbit_fit_chi2_limit(o)},
                      {"final_rms_m", num(o.final_rms)}, {"correlation_factor", o.correlation_factor},
                      {"unbalance_e_m", o.e}, {"unbalance_phase_rad", o.phase}};
    for (const auto& p : o.parameters)
      j["orbit_fit"]["parameters"].push_back({{"name", p.name}, {"start", p.start}, {"value", p.value},
                                              {"standard_error", num(p.standard_error)}});
    for (const auto& e : id.weak_estimates)
      j["orbit_fit"]["weak_form_start"].push_back({{"term", e.name}, {"value", e.value}, {"standard_error", e.standard_error}});
    j["orbit_fit"]["weak_form_mu"] = num(id.weak_mu);
  }
  if (!id.structures.empty()) {
    j["structure"] = {{"verdict", id.structure ? to_json(*id.structure) : nlohmann::ordered_json(nullptr)}};
    for (const auto& c : id.structures)
      j["structure"]["candidates"].push_back({{"terms", c.terms}, {"fitted", c.fitted}, {"converged", c.converged},
                                              {"chi2_per_dof", num(c.chi2_per_dof)}, {"bic", num(c.bic)}, {"status", c.status}});
  }
  if (id.reid) {
    j["reidentification"] = {{"algorithm", id.reid->algorithm}, {"evaluations", id.reid->evaluations},
                             {"failed_evaluations", id.reid->failed_evaluations}, {"final_failed", id.reid->final_failed},
                             {"initial_rms_m", num(id.reid->initial_rms)}, {"final_rms_m", num(id.reid->final_rms)}};
    for (const auto& p : id.reid->parameters)
      j["reidentification"]["parameters"].push_back({{"name", p.name}, {"initial", p.initial}, {"value", p.value},
                                                     {"standard_error", num(p.standard_error)}, {"identifiable", p.identifiable},
                                                     {"at_bound", p.at_bound}});
  }
  j["probe_noise_m"] = id.probe_noise;
  j["notes"] = id.notes;
  j["warnings"] = id.warnings;
  return j;
}

std::string to_markdown(const identification& id) {
  std::ostringstream md;
  md.precision(4);
  md << "# Identification\n\n";
  if (!id.warnings.empty()) {
    md << "## Warnings\n\n";
    for (const auto& w : id.warnings) md << "- " << w << "\n";
    md << "\n";
  }
  md << "Probe noise (from the data, each dwell its own): RMS " << id.probe_noise << " m over the dwells that touch.\n\n";
  md << "Contact law by **" << to_string(id.law_route) << "** (" << id.law_route_reason << ").\n\n";
  if (!id.notes.empty()) {
    md << "## Notes\n\n";
    for (const auto& n : id.notes) md << "- " << n << "\n";
    md << "\n";
  }
  md << "## Dwells\n\n| speed [rpm] | noise [m] | quantisation [m] | averaging |\n|---|---|---|---|\n";
  for (const auto& d : id.dwells) md << "| " << d.rpm << " | " << d.noise.sigma << " | " << d.noise.quantisation << " | " << d.averaging << " |\n";
  md << "\n";
  md << "Linear part (" << id.linear_source << "): m = " << id.linear.m << " kg, c_x = " << id.linear.c_x << " kg/s, c_y = "
     << id.linear.c_y << " kg/s, k_x = " << id.linear.k_x << " N/m, k_y = " << id.linear.k_y << " N/m, e = " << id.linear.e
     << " m, unbalance phase = " << id.linear.phase << " rad.\n\n";
  md << "## ERR of each term (Table 1)\n\n| step | term | ERR | ERR alone |\n|---|---|---|---|\n";
  for (std::size_t k = 0; k < id.frols.order.size(); ++k) {
    const auto& st = id.frols.order[k];
    md << "| " << k + 1 << " | " << id.candidates_pretty[st.candidate] << " | " << st.err << " | " << id.first_step_err[st.candidate] << " |\n";
  }
  md << "\nSelected " << id.frols.steps_selected << " steps; kept " << (id.weak ? "(significant, §5)" : "(ERR ≥ threshold)") << ": ";
  for (const auto& e : id.estimates) md << e.pretty << " ";
  md << "(Σ ERR " << id.frols.err_sum_kept << ").\n\n## Estimates (Table 2)\n\n| term | value | standard error | "
     << (id.orbit && id.orbit->converged ? "95 % (orbit fit)" : id.weak ? "95 % (Student t)" : "bootstrap 95 %") << " |\n|---|---|---|---|\n";
  for (const auto& e : id.estimates)
    md << "| " << e.pretty << " | " << e.value << " | " << e.standard_error << " | [" << e.ci_low << ", " << e.ci_high << "] |\n";
  md << "\nResidual RMS " << id.residual_rms << " N against an RMS contact force of " << id.force_rms << " N over "
     << id.contact_samples << " contact samples in " << id.episodes << " episodes.\n\n";
  if (id.weak)
    md << "Weak form: " << id.weak->rows << " rows over " << id.weak->episodes << " episodes; whitened residual RMS "
       << id.weak->residual_rms << " m against a noise of " << id.weak->noise << " m (χ²/dof " << id.weak->chi2_per_dof
       << ", 99.9 % limit " << id.weak->chi2_limit << "). Intervals: Student t on the larger of the rows' and the re-perturbations' standard errors.\n\n";
  if (id.weak) {
    md << "## Friction per speed (Fig. 5; weak form: ratio of the integrals)\n\n| speed [rpm] | rows | μ | standard error |\n|---|---|---|---|\n";
    for (const auto& d : id.dwells)
      if (d.friction) md << "| " << d.rpm << " | " << d.friction->samples << " | " << d.friction->mean << " | " << d.friction->std_dev << " |\n";
  } else {
    md << "## Friction per speed (Fig. 5)\n\n| speed [rpm] | samples | mean μ | std | median | slope |\n|---|---|---|---|---|---|\n";
    for (const auto& d : id.dwells)
      if (d.friction)
        md << "| " << d.rpm << " | " << d.friction->samples << " | " << d.friction->mean << " | " << d.friction->std_dev << " | "
           << d.friction->median << " | " << d.friction->slope << " |\n";
  }
  if (id.orbit) {
    const auto& o = *id.orbit;
    md << "## Orbit fit (§5: the averaged cycles' periodic orbits, Levenberg-Marquardt)\n\n"
       << (o.converged ? "The estimates above and μ below are the orbit fit's. " : "Not converged: the estimates above are the weak form's. ")
       << o.status << "; " << o.iterations << " iterations, " << o.evaluations << " evaluations (" << o.failed_evaluations
       << " failed); χ²/dof " << o.initial_chi2 << " → " << o.final_chi2 << " (99.9 % limit " << orbit_fit_chi2_limit(o)
       << "), orbit RMS " << o.final_rms << " m.\n\n| parameter | weak form (start) | orbit fit | standard error |\n|---|---|---|---|\n";
    for (const auto& p : o.parameters)
      md << "| " << p.name << " | " << p.start << " | " << p.value << " | " << p.standard_error << " |\n";
    md << "\n";
  }
  if (!id.structures.empty()) {
    md << "## Structure (§5: every law of Eq. 5's family with a stiffness, by the orbit fit's BIC)\n\n";
    if (id.structure) md << to_markdown(*id.structure);
    md << "| terms | χ²/dof | BIC | status |\n|---|---|---|---|\n";
    for (const auto& c : id.structures) {
      md << "| ";
      for (std::size_t k = 0; k < c.terms.size(); ++k) md << (k ? ", " : "") << c.terms[k];
      md << " | " << c.chi2_per_dof << " | " << c.bic << " | " << c.status << " |\n";
    }
    md << "\n";
  }
  md << "\nμ = " << id.mu << " ± " << id.mu_standard_error << " ("
     << (id.orbit && id.orbit->converged ? "orbit fit" : id.weak ? "weak form, pooled over every row" : "mean over speeds")
     << "); per-speed mean " << id.mu_mean << ", spread " << id.mu_spread << "; pooled slope " << id.mu_slope << ".\n\n";
  if (!id.validity.empty()) {  // the samples route's (the weak form's check is its chi^2 above)
    md << "## Residual correlation tests\n\n| test | max |φ| | band | outside | pass |\n|---|---|---|---|---|\n";
    for (const auto& t : id.validity)
      md << "| " << t.name << " | " << t.max_abs << " | " << t.band << " | " << t.outside_fraction << " | " << (t.pass ? "yes" : "no") << " |\n";
  }
  if (id.reid) {
    md << "\n## Output-error re-identification (" << id.reid->algorithm << ", " << id.reid->evaluations << " evaluations)\n\n"
       << "Orbit RMS error " << id.reid->initial_rms << " m → " << id.reid->final_rms << " m.\n\n| parameter | start | estimate | standard error | identifiable |\n|---|---|---|---|---|\n";
    for (const auto& p : id.reid->parameters)
      md << "| " << p.name << " | " << p.initial << " | " << p.value << " | " << p.standard_error << " | " << (p.identifiable ? "yes" : "no") << " |\n";
  }
  return md.str();
}

}  // namespace rubref
