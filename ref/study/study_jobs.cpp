// The per-point jobs of a study (docs/studies.md, "Jobs"): each is a pure function of the point.

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "ref/analysis/orbit_summary.hpp"
#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"
#include "ref/model/closed_form.hpp"
#include "ref/orbits/continuation.hpp"
#include "ref/loop/loop.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "ref/study/study.hpp"

namespace rubref::study {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// A shot orbit returns to its state to the shooting tolerance (1e-12 m) plus the recording's
// integration error (~1e-10 of its size); a true period-2 orbit differs between revolutions by
// far more, except within 1e-7 of its size from the period doubling, where the two are one.
constexpr double kSamePointRelTol = 1e-7;

std::string num(double v) { return std::isfinite(v) ? format_number(v) : "nan"; }

// A reason inside a CSV cell: one line, no separator.
std::string cell_text(std::string s) {
  s = one_line(std::move(s));
  std::replace(s.begin(), s.end(), ',', ';');
  std::replace(s.begin(), s.end(), '"', '\'');
  return s;
}

const std::vector<std::string> kOrbitColumns = {"status", "response", "period_revs", "stable", "max_floquet_modulus", "max_y_m",
                                                "max_radius_m", "peak_force_N", "contacts_per_rev", "backward_whirl", "forward_1x_m",
                                                "backward_1x_m", "x_m", "y_m", "vx_m_s", "vy_m_s", "note"};
const std::vector<std::string> kSimulateColumns = {"status", "response", "period_revs", "max_y_m", "max_radius_m", "peak_force_N",
                                                   "contacts_per_rev", "backward_whirl", "forward_1x_m", "backward_1x_m",
                                                   "x_m", "y_m", "vx_m_s", "vy_m_s", "note"};
const std::vector<std::string> kRunUpColumns = {"status", "onset_rpm", "jump_rpm", "peak_force_N", "peak_force_rpm", "max_y_m",
                                                "first_unstable_rpm", "unstable_width_rpm", "folds", "reached_end", "note"};

const std::vector<std::string> kLoopColumns = {"status", "truth", "claimed", "tentative", "match", "error_before", "error_after",
                                               "unexplained", "noise_estimate_m", "warnings", "note"};

const std::vector<std::string>& job_columns(job_kind k) {
  switch (k) {
    case job_kind::orbit: return kOrbitColumns;
    case job_kind::simulate: return kSimulateColumns;
    case job_kind::run_up: return kRunUpColumns;
    case job_kind::loop: return kLoopColumns;
  }
  return kOrbitColumns;
}

// A row of the job's width with 'status' and 'note', every other cell "nan".
std::vector<std::string> blank_row(job_kind k, const std::string& status, const std::string& note) {
  std::vector<std::string> cells(job_columns(k).size(), "nan");
  cells.front() = status;
  cells.back() = cell_text(note);
  if (k == job_kind::orbit || k == job_kind::simulate) cells[1] = "none";
  return cells;
}

// The state at t = 0 a point starts from.
state_type start_state(const job_settings& job, const point& p) {
  if (job.start == "rest") return state_type{};
  if (job.start == "state") {
    // The protrusion fills y > delta: a start there is no state of the rotor (and the identified
    // law's c2 zdot^2, which pushes out on both halves, blows up from it).
    require(p.initial[idx::y] <= p.params.clearance, "the start y0 = " + format_number(p.initial[idx::y]) + " m is inside the stator (y > clearance " +
                                                     format_number(p.params.clearance) + " m)");
    return p.initial;
  }
  state_type s = unbalance_response(p.params, rpm_to_rad_s(p.rpm)).at(0.0);  // contact_free
  s[idx::y] = std::min(s[idx::y], p.params.clearance);  // outside the stator, as an impact law needs
  return s;
}

// The orbit's cells from response on (the summary of its recorded period or revolutions).
void summary_cells(std::vector<std::string>& c, std::size_t from, const orbit_summary& s, const state_type& st) {
  c[from + 0] = num(s.max_y);
  c[from + 1] = num(s.max_radius);
  c[from + 2] = num(s.max_normal_force);
  c[from + 3] = num(s.contact_episodes_per_rev);
  c[from + 4] = s.backward_whirl() ? "1" : "0";
  c[from + 5] = num(std::abs(s.forward_1x));
  c[from + 6] = num(std::abs(s.backward_1x));
  for (std::size_t i = 0; i < 4; ++i) c[from + 7 + i] = num(st[i]);
}

// The point's model at its speed, sampled as the job says: the run both orbit jobs start from.
run_request run_at(const spec& sp, const point& p) {
  run_request run;
  run.variant = sp.variant;
  run.params = p.params;
  run.rpm = p.rpm;
  run.samples_per_rev = sp.job.samples_per_rev;
  return run;
}

std::vector<std::string> orbit_job(const spec& sp, const point& p) {
  const job_settings& job = sp.job;
  run_request run = run_at(sp, p);
  run.settle_revs = 0;
  run.record_revs = 1;
  validate(run);
  std::vector<std::string> c = blank_row(job_kind::orbit, "ok", "");

  const auto accept = [&](periodic_orbit_result r, int n, const std::string& how) {
    const state_type on_orbit = r.samples.request.initial_state;
    orbit o = record_periods(run, on_orbit, n);
    // A period read off a transient can be a multiple of the orbit's own (a decaying complex
    // Floquet mode repeats every few revolutions): the shot fixed point of the n-revolution map
    // is then one of the d-revolution map, d | n, which returns to its state after d T.
    const double scale = kSamePointRelTol * std::max(summarize(o).max_radius, 1e-9);
    const double w = rpm_to_rad_s(run.rpm);
    for (int d = 1; d < n; ++d) {
      if (n % d != 0) continue;
      const state_type& back = o.samples[static_cast<std::size_t>(d) * static_cast<std::size_t>(run.samples_per_rev)].s;
      double gap = 0.0;
      for (std::size_t k = 0; k < 4; ++k) gap = std::max(gap, std::abs(back[k] - on_orbit[k]) / (k < 2 ? 1.0 : w));
      if (gap <= scale) {
        n = d;
        o = record_periods(run, on_orbit, n);
        // The d-revolution map's own multipliers (the n-map's are their n/d-th powers).
        if (const periodic_orbit_result rd = shoot_from(run, on_orbit, n); rd.converged) r = rd;
        break;
      }
    }
    const orbit_summary s = summarize(o);
    c[1] = std::string(to_string(s.regime));
    c[2] = std::to_string(n);
    c[3] = r.stable ? "1" : "0";
    c[4] = num(r.max_multiplier_modulus);
    summary_cells(c, 5, s, on_orbit);
    c.back() = cell_text(how);
    return c;
  };

  state_type state = start_state(job, p);
  std::string tried;
  if (job.start == "contact_free") {
    const periodic_orbit_result r = shoot_from(run, state, 1);
    if (r.converged && r.stable) return accept(r, 1, "shot from the contact-free response");
    tried = r.converged ? "the orbit shot from the contact-free response is unstable" : "shooting from the contact-free response failed";
  }
  // Settle and shoot again: the period is read off the recorded revolutions (kRepeatRelTol).
  std::optional<orbit> last;
  orbit_summary last_summary;
  for (int round = 1; round <= job.settle_rounds; ++round) {
    run_request settle = run;
    settle.initial_state = state;
    settle.settle_revs = job.settle_revs;
    settle.record_revs = job.record_revs;
    last = simulate(settle);
    last_summary = summarize(*last);
    state = last->end.s;  // at a whole number of revolutions: a state at t = 0 of the T-periodic system
    const int n = last_summary.period_revs;
    if (n > job.max_period) tried = "period " + std::to_string(n) + " seen after round " + std::to_string(round) + ": longer than max_period";
    if (n >= 1 && n <= job.max_period) {
      const periodic_orbit_result r = shoot_from(run, state, n);
      if (r.converged && r.stable)
        return accept(r, n, "shot after " + std::to_string(round * (job.settle_revs + job.record_revs)) + " revolutions settled");
      tried = "period " + std::to_string(n) + " seen after round " + std::to_string(round) + " but its shot orbit " +
              (r.converged ? "is unstable" : "did not converge (" + r.failure + ")");
    }
  }
  // No stable periodic orbit: what the last recorded revolutions show, said as such.
  const bool periodic = last_summary.period_revs >= 1;
  c[0] = periodic ? "unconverged" : "ok";
  c[1] = periodic ? std::string(to_string(last_summary.regime)) : "non_periodic";
  c[2] = std::to_string(std::max(0, last_summary.period_revs));
  c[3] = "0";
  c[4] = "nan";
  summary_cells(c, 5, last_summary, state);
  c.back() = cell_text(periodic ? tried : "no period of at most " + std::to_string(job.max_period) + " revolutions after " +
                                              std::to_string(job.settle_rounds * (job.settle_revs + job.record_revs)) + " revolutions");
  return c;
}

std::vector<std::string> simulate_job(const spec& sp, const point& p) {
  const job_settings& job = sp.job;
  run_request run = run_at(sp, p);
  run.settle_revs = job.settle_revs;
  run.record_revs = job.record_revs;
  run.initial_state = start_state(job, p);
  const orbit o = simulate(run);
  const orbit_summary s = summarize(o);
  std::vector<std::string> c = blank_row(job_kind::simulate, "ok", "");
  c[1] = s.period_revs >= 1 ? std::string(to_string(s.regime)) : "non_periodic";
  c[2] = std::to_string(std::max(0, s.period_revs));
  summary_cells(c, 3, s, o.end.s);
  return c;
}

// The run-up along the period-1 branch: from 'from_rpm' up to its first fold (where a run-up
// jumps off) or the end of the range. Unstable stretches before the fold (a sweep there is
// subharmonic or non-periodic) are measured, not walked through as if steady.
std::vector<std::string> run_up_job(const spec& sp, const point& p) {
  continuation_request req;
  req.variant = sp.variant;
  req.params = p.params;
  req.parameter = continuation_parameter::speed;
  req.from = sp.job.from_rpm;
  req.to = sp.job.to_rpm;
  req.samples_per_rev = sp.job.samples_per_rev;
  validate(req);
  const continuation_result branch = continue_branch(req);

  std::size_t end = branch.points.size();  // the walk stops at the first fold
  double jump = kNaN;
  std::size_t folds = 0;
  for (const auto& sp_point : branch.special)
    if (sp_point.kind == special_kind::fold) {
      if (folds++ == 0) {
        jump = sp_point.rpm;
        end = std::min(end, sp_point.after_point + 1);
      }
    }
  double onset = kNaN, peak = 0.0, peak_rpm = kNaN, max_y = 0.0, first_unstable = kNaN, unstable_width = 0.0;
  bool rubs_from_start = false;
  for (const auto& g : branch.special)
    if (g.kind == special_kind::grazing && g.after_point < end && std::isnan(onset)) onset = g.rpm;
  for (std::size_t i = 0; i < end; ++i) {
    const branch_point& b = branch.points[i];
    if (!b.stable) {
      if (std::isnan(first_unstable)) first_unstable = b.rpm;
      if (i + 1 < end) unstable_width += branch.points[i + 1].rpm - b.rpm;
      continue;
    }
    if (b.max_z > 0.0 && std::isnan(onset)) onset = b.rpm, rubs_from_start = i == 0;  // in contact from the start of the range
    if (b.summary.max_normal_force > peak) peak = b.summary.max_normal_force, peak_rpm = b.rpm;
    max_y = std::max(max_y, b.summary.max_y);
  }
  const std::string note = branch.reached_end || folds > 0 ? (rubs_from_start ? "in contact at from_rpm already: the onset is at or below it" : "")
                                                            : branch.stopped;
  std::vector<std::string> c = blank_row(job_kind::run_up, "ok", note);
  if (!branch.reached_end && folds == 0) c[0] = "unconverged";  // the branch ended before the range or a fold
  c[1] = num(onset);
  c[2] = num(jump);
  c[3] = num(peak);
  c[4] = num(peak_rpm);
  c[5] = num(max_y);
  c[6] = num(first_unstable);
  c[7] = num(unstable_width);
  c[8] = std::to_string(folds);
  c[9] = branch.reached_end ? "1" : "0";
  return c;
}

// Effect names as one cell: sorted, ';'-joined, "none" for none.
std::string name_set(std::vector<std::string> names) {
  if (names.empty()) return "none";
  std::sort(names.begin(), names.end());
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ";") + n;
  return out;
}

// A campaign point: the virtual rig's records of the point's truth (model, effects, noise with
// the point's own seed), the loop on them, and whether it named exactly the truth's effects.
std::vector<std::string> loop_job(const spec& sp, const point& p) {
  const rig_request rig = rig_request_for(sp, p);
  validate(rig);
  const rig_output out = run_rig(rig);
  const loop_result r = run_loop({{out.measurement, "rig"}}, loop_settings{});
  std::vector<std::string> truth, claimed, tentative;
  for (const auto& e : effect_library())
    if (has_effect(p.effects, e)) truth.emplace_back(e.name);
  claimed = r.decision.named;
  tentative = r.decision.tentative;
  std::vector<std::string> c = blank_row(job_kind::loop, "ok", r.warnings.empty() ? "" : r.warnings.front());
  c[1] = name_set(truth);
  c[2] = name_set(claimed);
  c[3] = name_set(tentative);
  c[4] = name_set(truth) == name_set(claimed) ? "1" : "0";
  c[5] = num(r.error_before);
  c[6] = num(r.error_after);
  c[7] = r.decision.unexplained ? "1" : "0";
  c[8] = num(r.noise);
  c[9] = std::to_string(r.warnings.size());
  return c;
}

}  // namespace

rig_request rig_request_for(const spec& sp, const point& p) {
  rig_request rig;
  rig.variant = sp.variant;
  rig.params = p.params;
  rig.effects = p.effects;
  if (!sp.job.speeds_rpm.empty()) rig.speeds_rpm = sp.job.speeds_rpm;
  rig.settle_revs = sp.job.settle_revs;
  rig.record_revs = sp.job.record_revs;
  rig.probes.noise = p.noise;
  rig.probes.keyphasor = sp.job.keyphasor;
  // Without a keyphasor the record's time is shaft-synchronous, as `rubref rig --no-keyphasor`.
  rig.time_base = sp.job.keyphasor ? rig_time_base::acquisition : rig_time_base::shaft;
  // The noise's seed from the point's stream, past the draws of its random variables.
  rig.probes.seed = static_cast<unsigned>(uniform_draw(sp.seed, p.index, sp.random.size()) * 4294967296.0);
  return rig;
}

std::vector<std::string> columns(const spec& s) {
  std::vector<std::string> cols{"index"};
  for (const auto& n : varied_names(s)) cols.push_back(n);
  for (const auto& n : job_columns(s.job.kind)) cols.push_back(n);
  return cols;
}

std::vector<std::string> evaluate(const spec& s, std::size_t index) {
  const point p = point_at(s, index);
  std::vector<std::string> row{std::to_string(index)};
  for (double v : p.values) row.push_back(format_number(v));
  std::vector<std::string> cells;
  try {
    validate(p.params);
    switch (s.job.kind) {
      case job_kind::orbit: cells = orbit_job(s, p); break;
      case job_kind::simulate: cells = simulate_job(s, p); break;
      case job_kind::run_up: cells = run_up_job(s, p); break;
      case job_kind::loop: cells = loop_job(s, p); break;
    }
  } catch (const input_error& e) {
    cells = blank_row(s.job.kind, "invalid", e.what());
  } catch (const numerical_error& e) {
    cells = blank_row(s.job.kind, "failed", e.what());
  }
  row.insert(row.end(), cells.begin(), cells.end());
  return row;
}

}  // namespace rubref::study
