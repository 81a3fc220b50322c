#include "ref/loop/loop.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
#include <optional>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/inference/evidence.hpp"
#include "ref/loop/paper_fit.hpp"

namespace rubref {

namespace {

void exclude(loop_result& out, std::size_t k, std::string reason, const loop_settings& s) {
  const loop_dwell& d = out.dwells[k];
  s.progress("warning: " + d.data.source + " (" + format_digits(d.data.rpm) + " rpm) left out: " + reason);
  out.excluded.push_back({d.record, d.data.rpm, d.contact, 0.0, std::move(reason)});
}

// Dwells where the model's orbit cannot be computed at any start of the before-fit are left out,
// and so are period-n dwells where it has no period-n orbit there (held out: the final model is
// checked on them after the fit, held_out_check).
void exclude_uncomputable(loop_result& out, double noise, const loop_settings& s, std::vector<std::pair<loop_dwell, std::size_t>>& held_out) {
  const auto starts = before_fit_starts(out.initial, out.initial_weak_form);
  const auto failed = uncomputable_dwells(out.dwells, noise, starts, s.orbits);
  const auto orbitless = dwells_without_their_orbit(out.dwells, noise, starts, s.orbits);
  std::vector<loop_dwell> kept;
  std::vector<double> shifts;
  for (std::size_t k = 0; k < out.dwells.size(); ++k) {
    if (std::binary_search(failed.begin(), failed.end(), k)) {
      exclude(out, k, "the model's orbit cannot be computed there (Newton shooting and a transient from the measured state both fail at every start of the fit)", s);
    } else if (std::binary_search(orbitless.begin(), orbitless.end(), k)) {
      const std::string n = std::to_string(out.dwells[k].periods);
      exclude(out, k, "it repeats every " + n + " revolutions, and the model has no period-" + n + " orbit there at any start of the fit", s);
      held_out.emplace_back(out.dwells[k], out.excluded.size() - 1);
    } else {
      kept.push_back(out.dwells[k]);
      shifts.push_back(out.initial.shift[k]);
    }
  }
  out.dwells = std::move(kept);
  out.initial.shift = std::move(shifts);
}

// The final model on a held-out period-n dwell: whether it now has that orbit, and how close it
// comes (said in the dwell's `excluded` entry: a check of the model on data it was not fitted to).
void held_out_check(loop_result& out, const std::pair<loop_dwell, std::size_t>& h, double noise, const fit_orbit_options& orbits) {
  const std::vector<loop_dwell> one{h.first};
  orbit_predictor predictor(one, noise, orbits);
  model_point m = out.after;
  m.shift.assign(1, 0.0);
  const auto r = predictor.residuals(m);
  std::string& reason = out.excluded[h.second].reason;
  if (!r || predictor.kinds()[0] != orbit_kind::periodic) {
    reason += "; the final model has none either";
    return;
  }
  const double rms = std::sqrt(r->head(static_cast<Eigen::Index>(predictor.orbit_rows())).squaredNorm() / static_cast<double>(predictor.orbit_rows()));
  reason += "; the final model has one, " + format_digits(rms * 1e6) + " um RMS from the data (noise " + format_digits(noise * 1e6) + " um)";
}

// Errors, validity, spectrum and the plot dwell of the final model against the before-fit.
void measure(loop_result& out, orbit_predictor& predictor, double noise, const loop_settings& s, const trace_result& traced) {
  // Each on its own orbits (the validity checks read the predictor's states of the last call).
  predictor.anchor(out.before, traced.before_orbits);
  const auto r_before = predictor.residuals(out.before);
  if (r_before)
    out.validity_before = validity(out.dwells, predictor, out.before, *r_before, noise, s.orders, s.whiteness_lags,
                                   residual_error_of(*r_before, traced.before_uncertainty));
  predictor.anchor(out.after, traced.after_orbits);
  const auto r = predictor.residuals(out.after);
  if (!r_before || !r) throw numerical_error("the loop's model cannot be computed at its own fit");
  const std::vector<orbit_kind> kinds = predictor.kinds();  // the final model's
  out.validity_after =
      validity(out.dwells, predictor, out.after, *r, noise, s.orders, s.whiteness_lags, residual_error_of(*r, traced.after_uncertainty));
  const synchronous_energy sync_before = synchronous_part(out.dwells, predictor, out.before, *r_before, s.orders);
  const synchronous_energy sync_after = synchronous_part(out.dwells, predictor, out.after, *r, s.orders);
  out.decision.explained_share = explained_share(sync_before.excess(noise), sync_after.energy - noise * noise * sync_after.dof);
  // The synchronous energies are parts of |r|^2: each moves by at most its model's |r|^2 uncertainty.
  if (const double excess = sync_before.excess(noise); excess > 0.0)
    out.explained_share_uncertainty = (traced.before_uncertainty + traced.after_uncertainty) / excess;
  const error_totals eb = errors_of(out.dwells, predictor, *r_before), ea = errors_of(out.dwells, predictor, *r);
  out.error_before = eb.nrmse_contact;
  out.error_after = ea.nrmse_contact;
  for (std::size_t k = 0; k < out.dwells.size(); ++k) {
    const auto& ld = out.dwells[k];
    out.errors.push_back({ld.record, ld.data.rpm, ld.contact, ld.data.size(), std::string(to_string(kinds[k])), ld.periods, eb.rms[k],
                          ea.rms[k], eb.nrmse[k], ea.nrmse[k]});
  }

  // Spectrum by order, RMS over contact dwells, and the plot dwell (largest error before).
  for (int k = -s.orders; k <= s.orders; ++k) out.spectrum.orders.push_back(k);
  out.spectrum.before.assign(out.spectrum.orders.size(), 0.0);
  out.spectrum.after.assign(out.spectrum.orders.size(), 0.0);
  double contact_dwells = 0.0, worst = -1.0;
  for (std::size_t k = 0; k < out.dwells.size(); ++k) {
    if (!out.dwells[k].contact) continue;
    contact_dwells += 1.0;
    const auto cb = order_coefficients(out.dwells[k].data, *r_before, predictor.offset(k), out.before.shift[k], s.orders);
    const auto ca = order_coefficients(out.dwells[k].data, *r, predictor.offset(k), out.after.shift[k], s.orders);
    for (std::size_t j = 0; j < cb.size(); ++j) out.spectrum.before[j] += std::norm(cb[j]), out.spectrum.after[j] += std::norm(ca[j]);
    if (eb.rms[k] > worst) worst = eb.rms[k], out.plot_dwell = k;
  }
  for (auto* v : {&out.spectrum.before, &out.spectrum.after})
    for (double& x : *v) x = std::sqrt(x / std::max(contact_dwells, 1.0));
  const std::size_t k = out.plot_dwell;
  const dwell& d = out.dwells[k].data;
  const double period = 60.0 / d.rpm;
  for (std::size_t i = 0; i < d.size(); ++i) {
    out.plot_phase.push_back(360.0 * phase_in_period(d.t[i] + out.after.shift[k], period) / period);
    out.plot_x.push_back(d.x[i]);
    out.plot_y.push_back(d.y[i]);
    const auto at = static_cast<Eigen::Index>(predictor.offset(k) + 2 * i);
    out.plot_x_before.push_back(d.x[i] + (*r_before)[at]);
    out.plot_y_before.push_back(d.y[i] + (*r_before)[at + 1]);
    out.plot_x_after.push_back(d.x[i] + (*r)[at]);
    out.plot_y_after.push_back(d.y[i] + (*r)[at + 1]);
  }
}

// The estimates outside what the library describes, one line each.
std::vector<std::string> implausible_estimates(const loop_result& out) {
  std::vector<std::string> implausible;
  for (const auto& e : out.effects)
    if (const auto* q = outside_fit_range(find_effect(e.effect), out.after))
      implausible.push_back(e.effect + "'s " + std::string(q->key) + " = " + format_digits(out.after.fx.*q->member) + " " + std::string(q->unit) +
                            " is outside the library's range [" + format_digits(q->lo) + ", " + format_digits(q->hi) + "]");
  return implausible;
}

// Loud, never silent: an estimate outside what the library describes, or a law without stiffness.
void warn_unphysical(loop_result& out, const loop_settings& s) {
  const auto warn = [&](const std::string& w) {
    out.warnings.push_back(w);
    s.progress("warning: " + w);
  };
  for (const auto& w : implausible_estimates(out)) warn(w);
  if (!(out.after.p.k1 > 0.0)) warn("the law's k1 is 0: the contact has no linear stiffness (an effect the library lacks may carry it)");
  if (!(out.after.p.mu > 0.0)) warn("mu is 0: no friction at the contact");
}

// What is claimed, by the evidence rules' claim rule. The effects are claimed together or not at
// all: they were fitted together. `check_reason`: why the verdict's check disagrees (empty: it does
// not), `check` its verdict (nullptr: it failed).
void claim(loop_result& out, const loop_settings& s, const std::string& check_reason = {}, const verdict* check = nullptr) {
  claim_inputs in;
  in.residual_is_noise = out.validity_after.pass;
  in.explained_share = out.decision.explained_share;
  in.explained_share_uncertainty = out.explained_share_uncertainty;
  in.plausible = first_implausible(implausible_estimates(out)).empty();
  std::vector<std::string> names, reasons;
  std::string rival;  // the decisive-choice rule: an effect in the model with a rival is not decided
  for (const auto& e : out.effects) {
    names.push_back(e.effect);
    if (!e.rival.empty()) rival += (rival.empty() ? "" : "; ") + e.rival + " in place of " + e.effect;
  }
  if (!in.plausible) reasons.push_back("an estimate lies outside the library's range (warnings): the effects are tentative, not claimed");
  // A decision on its margin (added or left out within its statistics' numerical uncertainty):
  // nothing is claimed, and the effect is named among the tentative ones whichever way it went.
  in.on_margin = !out.on_margin.empty();
  // Whether the residual is noise decides a full claim against a partial one.
  if (!names.empty() && out.validity_after.on_margin) {
    in.on_margin = true;
    reasons.push_back("the residual's noise test lies within its numerical uncertainty of its limit (validity checks, after)");
  }
  std::vector<std::string> left_out;
  for (const auto& e : out.on_margin)
    if (std::find(names.begin(), names.end(), e) == names.end()) left_out.push_back(e);
  // The verdict's check disagrees (`check_reason` says how): the orbits' accuracy, not the data,
  // decided between the two, so nothing is claimed and what the check chose is tentative too.
  if (!check_reason.empty()) {
    in.on_margin = true;
    reasons.push_back(check_reason);
    const std::vector<std::string> more = chosen_by_check_only(names, check, left_out);
    left_out.insert(left_out.end(), more.begin(), more.end());
  }
  if (!left_out.empty()) reasons.push_back("left out on the margin (tentative): " + joined(left_out));
  if (names.empty() && in.on_margin) names = std::move(left_out), left_out.clear();  // nothing chosen: the margin's effects are the tentative ones
  out.decision = decide("effects", std::move(names), in, s.rules, std::move(rival), std::move(reasons));
  out.decision.tentative.insert(out.decision.tentative.end(), left_out.begin(), left_out.end());
}

bool any_contact(const std::vector<loop_dwell>& dwells) {
  return std::any_of(dwells.begin(), dwells.end(), [](const loop_dwell& d) { return d.contact; });
}

}  // namespace

void loop_settings::validate() const {
  trace_settings::validate();
  check({"loop", "mass"}, mass);
  check({"loop", "clearance"}, clearance);
  check({"loop", "check_tolerance_scale"}, check_tolerance_scale);
  if (check_tolerance_scale > 0.0 && check_tolerance_scale * orbits.tolerance_scale < 1e-3)
    throw input_error("check_tolerance_scale " + format_digits(check_tolerance_scale) + " times orbit_tolerance_scale " + format_digits(orbits.tolerance_scale) +
                      " is below 1e-3, where the steppers reach rounding: loosen one, or set check_tolerance_scale to 0 (no check)");
}

namespace {

// Stage 1 and the staged start of stage 2, which take no orbit setting: the fit and its check
// share them (the staged start's orbit fit, the costliest part before the trace, runs once, on
// every thread). `fitted` is false where nothing can be fitted (`out` then says why).
struct loop_start {
  loop_result out;
  bool fitted = false;
};

// The result for records that leave nothing to fit, with why.
loop_result& nothing_to_fit(loop_result& out, const loop_settings& s, const std::string& why) {
  out.decision = decide("effects", {}, claim_inputs{}, s.rules, {}, {why});
  out.error_before = out.error_after = std::numeric_limits<double>::quiet_NaN();
  out.notes.push_back(why);
  return out;
}

// `announce` goes to progress once the records are found fit to fit (an input error is then the
// run's only line).
loop_start start_loop(const std::vector<std::pair<record, std::string>>& records, const loop_settings& s, const std::string& announce) {
  loop_start start;
  loop_result& out = start.out;
  // 1. The dwells.
  prepared_dwells prep = prepare_dwells(records, s.mass, s.clearance);
  out.noise = prep.noise;
  out.mass_source = prep.mass_source;
  out.notes = std::move(prep.notes);
  out.dwells = std::move(prep.dwells);
  for (const auto& e : prep.excluded) s.progress("warning: " + e.record + " (" + format_digits(e.rpm) + " rpm) left out: " + e.reason);
  out.excluded = std::move(prep.excluded);
  if (!any_contact(out.dwells)) {
    if (out.excluded.empty()) throw input_error("no dwell reaches its clearance: there is no contact for the loop to fit");
    nothing_to_fit(out, s, "no synchronous dwell with contact: the loop cannot fit these records");
    return start;
  }
  if (!announce.empty()) s.progress(announce);
  // 2. The paper's model: staged (here), then every coordinate on every dwell's orbit (fit_and_claim).
  staged_start staged = staged_model(out.dwells, prep.mass, out.notes);
  out.initial = std::move(staged.model);
  out.initial_weak_form = std::move(staged.weak_form);
  start.fitted = true;
  return start;
}

// The loop itself from its start (stages 2-4 of loop.hpp), without its check.
loop_result fit_and_claim(loop_result out, const loop_settings& s) {
  const double noise = std::max(out.noise, 1e-12);
  std::vector<std::pair<loop_dwell, std::size_t>> held_out;
  exclude_uncomputable(out, noise, s, held_out);
  if (!any_contact(out.dwells)) return nothing_to_fit(out, s, "the model's orbit cannot be computed in any dwell with contact");
  s.progress("      every coordinate together (Levenberg-Marquardt) ...");
  orbit_predictor predictor(out.dwells, noise, s.orbits);
  const multistart_result before = fit_paper_model(predictor, out.dwells, out.initial, out.initial_weak_form, noise, s.max_jacobians, [&](const fit_result& f) {
    return validity(out.dwells, predictor, f.at, f.r, noise, s.orders, s.whiteness_lags).pass;
  });
  if (!before.best.ok) throw numerical_error("the paper's model cannot be computed at any start of its fit");
  out.starts = before.starts;
  out.start_winner = before.winner;
  out.start_tie = before.tie;
  s.progress("      before: from the start '" + before.winner + "', residual " +
             format_digits(std::sqrt(before.best.rss / static_cast<double>(predictor.orbit_rows())) * 1e6) + " um against noise " +
             format_digits(noise * 1e6) + " um");

  // 3. The trace.
  trace_result traced = trace(out.dwells, predictor, noise, out.initial, before.best, s);
  out.before = traced.before;
  out.after = traced.after;
  out.effects = std::move(traced.effects);
  out.removed = std::move(traced.removed);
  out.last_round = std::move(traced.last_round);
  out.on_margin = traced.on_margin;
  out.notes.insert(out.notes.end(), traced.notes.begin(), traced.notes.end());

  // 4. Before and after, and what is claimed.
  measure(out, predictor, noise, s, traced);
  out.model_evaluations = predictor.evaluations();
  out.sensitivity_evaluations = predictor.sensitivity_evaluations();
  for (const auto& h : held_out) held_out_check(out, h, noise, s.orbits);
  warn_unphysical(out, s);
  claim(out, s);
  return out;
}

}  // namespace

void apply_check(loop_result& out, std::optional<verdict> check, const std::string& failure, const loop_settings& s) {
  std::string what;
  std::tie(out.check, what) = checked(out.decision, check, s.orbits.tolerance_scale * s.check_tolerance_scale, s.check_tolerance_scale, failure);
  if (out.check->agrees) return;
  claim(out, s, what, check ? &out.check->decision : nullptr);
  s.progress("warning: " + what);
}

// The loop and its check side by side on the machine's threads (each fit deterministic, so the
// pair is the same whatever the thread count). The check is the stability test (docs/loop.md) run
// on every call: with every orbit tolerance check_tolerance_scale times the fit's, the loop must
// name the same effects, or the verdict is tentative.
loop_result run_loop(const std::vector<std::pair<record, std::string>>& records, const loop_settings& s) {
  s.validate();
  const bool checked = s.check_tolerance_scale != 0.0;
  std::mutex lines;  // the two fits' progress, a whole line at a time
  const auto say = [&](std::string prefix) {
    return [&lines, &s, prefix = std::move(prefix)](const std::string& line) {
      const std::lock_guard lock(lines);
      s.progress(prefix + line);
    };
  };
  const std::string announce = checked ? "the verdict's check: the same loop with orbit tolerances " + format_digits(s.check_tolerance_scale) +
                                             " times these, beside it ([check] lines); an effect the two do not both name is tentative"
                                       : std::string();
  loop_start start = start_loop(records, s, announce);
  if (!start.fitted) return std::move(start.out);
  if (!checked) return fit_and_claim(std::move(start.out), s);
  loop_settings fit = s, check = s;
  fit.progress = say("");
  check.orbits.tolerance_scale *= s.check_tolerance_scale;
  check.progress = say("[check] ");
  std::array<std::optional<loop_result>, 2> runs;
  std::string check_failed;
  parallel_for(2, 0, [&](std::size_t i) {
    if (i == 0) return void(runs[0] = fit_and_claim(start.out, fit));
    try {
      runs[1] = fit_and_claim(start.out, check);
    } catch (const numerical_error& e) {
      check_failed = e.what();
    }
  });
  loop_result out = std::move(*runs[0]);
  apply_check(out, runs[1] ? std::optional<verdict>(runs[1]->decision) : std::nullopt, check_failed, s);
  return out;
}

}  // namespace rubref
