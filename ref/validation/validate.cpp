#include "ref/validation/validate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <sstream>

#include "ref/base/errors.hpp"
#include "ref/validation/diagnosis.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

namespace {


}  // namespace

candidate_data read_candidate(const golden_case& g, const record& c, const std::string& name) {
  candidate_data d;
  d.t = c.column("t_s");
  d.x = c.column("x_m");
  d.y = c.column("y_m");
  const auto has = [&](std::string_view n) { return std::find(c.columns.begin(), c.columns.end(), n) != c.columns.end(); };
  if (has("vx_m_s") && has("vy_m_s")) {
    d.vx = c.column("vx_m_s");
    d.vy = c.column("vy_m_s");
  }
  const auto& speed = c.column("speed_rpm");
  for (std::size_t i = 0; i < speed.size(); ++i)
    if (std::abs(speed[i] - g.request.rpm) > 1e-9 * g.request.rpm)
      throw input_error((c.source.empty() ? name + ": " : c.where_row(i)) + "speed_rpm is " + format_digits(speed[i], 17) + " at t = " + format_digits(d.t[i], 17) + " s, the case runs at " +
                        format_digits(g.request.rpm, 17) + " rpm");
  if (d.t.size() < 4) throw input_error(name + ": " + std::to_string(d.t.size()) + " samples; at least 4 are needed");
  return d;
}

namespace {

// Keeps the states at the requested output times.
struct state_keeper {
  std::vector<state_type> s;
  template <class System>
  void on_sample(double, const state_type& x, const System&) {
    s.push_back(x);
  }
  void on_event(const contact_event&) {}
};

// The case's orbit (with `params`, which are not validated: a diagnosis may try mu < 0) at the
// ascending times `t`, integrated with `opt`. Empty when that integration fails.
std::vector<state_type> case_states_at(const golden_case& g, const parameters& params, const integration_options& opt,
                                       std::span<const double> t) {
  state_keeper out;
  out.s.reserve(t.size());
  try {
    visit_variant(g.request.variant, [&]<class Law>() {
      const rotor_system<Law> model(params, g.omega());
      integrate_hybrid(model, start_state(model, g.request.initial_state, 0.0), t.back(), opt, sample_grid::at(t), out);
    });
  } catch (const numerical_error&) {
    return {};
  }
  return out.s;
}

comparison_points pair_with_golden(const golden_case& g, const candidate_data& c, const std::string& name) {
  comparison_points out;
  const std::size_t n = g.t.size();
  const double dt = g.t[1] - g.t[0], period = 60.0 / g.request.rpm;
  bool same = c.t.size() == n;
  for (std::size_t i = 0; same && i < n; ++i) same = std::abs(c.t[i] - g.t[i]) <= 1e-6 * dt;
  if (same) {
    out = {g.t, c.x, c.y, g.x, g.y, "the case's own " + std::to_string(n) + " sample times"};
    return out;
  }

  // The golden method must reproduce the file before it stands in for it between samples.
  const auto again = case_states_at(g, g.request.params, golden_method(), g.t);
  double drift = again.size() == n ? 0.0 : std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < again.size(); ++i) drift = std::max(drift, std::hypot(again[i][idx::x] - g.x[i], again[i][idx::y] - g.y[i]));
  if (!(drift <= kReintegrationTol))
    throw numerical_error("integrating " + g.name + " again does not reproduce its samples (difference " + format_digits(drift, 3) +
                          " m): the file was made by another rubref; compare at the case's own sample times");

  // An orbit that repeats is compared by phase, whatever the time origin (a shifted origin is
  // diagnosed); one that does not is compared at absolute times.
  if (g.period_revs == 0 && c.t.front() < 0.0) throw input_error(name + ": t_s starts at " + format_digits(c.t.front(), 17) + " s; time is absolute, from rest at t = 0");
  const double t0 = g.t.front(), window = g.period_revs * period;
  double best = std::numeric_limits<double>::infinity();
  for (int shift = 0; shift < std::max(1, g.period_revs); ++shift) {
    // Times in the case's run: modulo the period into the record, `shift` revolutions on.
    std::vector<std::pair<double, std::size_t>> order;
    for (std::size_t i = 0; i < c.t.size(); ++i) {
      double tau = c.t[i];
      if (g.period_revs > 0) {
        tau = std::fmod(tau - t0 + shift * period, window);
        if (tau < 0.0) tau += window;
        tau += t0;
      }
      order.emplace_back(tau, i);
    }
    std::sort(order.begin(), order.end());
    comparison_points p;
    for (const auto& [tau, i] : order) {
      p.t.push_back(tau);
      p.x.push_back(c.x[i]);
      p.y.push_back(c.y[i]);
    }
    const auto ref = case_states_at(g, g.request.params, golden_method(), p.t);
    if (ref.size() != p.t.size()) throw numerical_error("integrating " + g.name + " at the candidate's times failed");
    double sum = 0.0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      p.gx.push_back(ref[i][idx::x]);
      p.gy.push_back(ref[i][idx::y]);
      sum += std::pow(p.x[i] - p.gx[i], 2) + std::pow(p.y[i] - p.gy[i], 2);
    }
    if (sum < best) {
      best = sum;
      out = std::move(p);
      out.note = "its own " + std::to_string(c.t.size()) + " sample times" +
                 (g.period_revs > 0 ? ", taken modulo the orbit's period (" + std::to_string(g.period_revs) + " rev)" +
                                          (g.period_revs > 1 ? " " + std::to_string(shift) + " rev on" : "") + " into the case's record"
                                    : "") +
                 "; the golden orbit there integrated again with the golden method (it reproduces the file to " + format_digits(drift, 2) + " m)";
    }
  }
  return out;
}

}  // namespace

validation_result validate_candidate(const golden_case& g, const record& candidate, const std::string& candidate_name) {
  validation_result r;
  r.case_name = g.name;
  r.candidate_name = candidate_name;
  r.variant = g.request.variant;
  r.clearance = g.request.params.clearance;
  r.rpm = g.request.rpm;
  r.comparison = g.comparison;
  r.period_revs = g.period_revs;
  const candidate_data c = read_candidate(g, candidate, candidate_name);
  const double omega = g.omega();

  orbit_statistics got, want = g.statistics;
  comparison_points pts;
  if (g.comparison == comparison_kind::orbit) {
    pts = pair_with_golden(g, c, candidate_name);
    r.sampling = pts.note;
    r.tolerance = g.orbit_tolerance;
    double sum = 0.0;
    for (std::size_t i = 0; i < pts.t.size(); ++i) {
      const double e = std::hypot(pts.x[i] - pts.gx[i], pts.y[i] - pts.gy[i]);
      sum += e * e;
      if (e > r.max_error || i == 0) {
        r.max_error = e;
        r.worst_t = pts.t[i];
        r.worst_golden[0] = pts.gx[i];
        r.worst_golden[1] = pts.gy[i];
        r.worst_candidate[0] = pts.x[i];
        r.worst_candidate[1] = pts.y[i];
      }
    }
    r.rms_error = std::sqrt(sum / static_cast<double>(pts.t.size()));
    // Both sides' statistics on the same times (on the case's own, the golden's are the file's).
    got = statistics_of(pts.t, pts.x, pts.y, omega, g.request.params.clearance);
    want = statistics_of(pts.t, pts.gx, pts.gy, omega, g.request.params.clearance);
  } else {
    r.sampling = "its own " + std::to_string(c.t.size()) + " samples (statistics only: this case is chaotic)";
    const double nan = std::numeric_limits<double>::quiet_NaN();
    r.max_error = r.rms_error = r.tolerance = r.worst_t = nan;
    got = statistics_of(c.t, c.x, c.y, omega, g.request.params.clearance);
  }
  for (const auto& info : statistic_table)
    r.statistics.push_back({std::string(info.key), want.*info.member, got.*info.member, g.statistics_tolerance.*info.member});

  r.spanned_revs = spanned_revolutions(g, c);
  r.candidate_period_revs = candidate_period(g, c);
  r.pass = std::all_of(r.statistics.begin(), r.statistics.end(), [](const statistic_check& s) { return s.pass(); });
  if (g.comparison == comparison_kind::orbit) r.pass = r.pass && r.max_error <= r.tolerance;
  // Less than one period passes nothing, however well its samples agree.
  r.covered = r.spanned_revs >= required_revolutions(g) * (1.0 - 1e-6);
  r.pass = r.pass && r.covered;
  if (!r.pass) r.causes = diagnose(g, c, candidate, g.comparison == comparison_kind::orbit ? &pts : nullptr);
  return r;
}

std::string to_text(const validation_result& r) {
  std::ostringstream out;
  out << "case      " << r.case_name << " (" << r.variant << ", clearance " << format_digits(r.clearance * 1e3) << " mm, " << format_digits(r.rpm)
      << " rpm; compared as " << to_string(r.comparison);
  if (r.period_revs > 0) out << ", period " << r.period_revs << " rev";
  out << ")\n";
  out << "candidate " << r.candidate_name << ": " << r.sampling << "\n";
  if (r.comparison == comparison_kind::orbit) {
    const double phase = std::fmod(r.worst_t * r.rpm / 60.0, 1.0) * 360.0;
    out << "orbit     max error " << format_digits(r.max_error, 3) << " m (t = " << format_digits(r.worst_t, 10) << " s, " << format_digits(phase, 3)
        << " deg: golden (" << format_digits(r.worst_golden[0], 6) << ", " << format_digits(r.worst_golden[1], 6) << "), candidate ("
        << format_digits(r.worst_candidate[0], 6) << ", " << format_digits(r.worst_candidate[1], 6) << ") m), RMS " << format_digits(r.rms_error, 3)
        << " m; tolerance " << format_digits(r.tolerance, 3) << " m: " << (r.max_error <= r.tolerance ? "ok" : "FAIL") << "\n";
  }
  for (const auto& s : r.statistics)
    out << "          " << s.key << std::string(s.key.size() < 18 ? 18 - s.key.size() : 1, ' ') << "golden " << format_digits(s.golden, 6)
        << ", candidate " << format_digits(s.candidate, 6) << ", error " << format_digits(std::abs(s.candidate - s.golden), 3) << " (tolerance "
        << format_digits(s.tolerance, 3) << "): " << (s.pass() ? "ok" : "FAIL") << "\n";
  out << "coverage  " << format_digits(r.spanned_revs, 4) << " revolution(s)";
  if (r.candidate_period_revs > 0) out << ", repeats every " << r.candidate_period_revs << " rev";
  if (r.candidate_period_revs == 0) out << ", does not repeat";
  out << (r.covered ? "" : ": FAIL (less than one period of the case)") << "\n";
  for (const auto& c : r.causes) out << "cause     " << to_string(c.code) << " (" << to_string(c.confidence) << "): " << c.detail << "\n";
  out << "result    " << (r.pass ? "PASS" : "FAIL") << "\n";
  return out.str();
}

nlohmann::ordered_json to_json(const validation_result& r) {
  nlohmann::ordered_json j;
  j["case"] = r.case_name;
  j["candidate"] = r.candidate_name;
  j["variant"] = r.variant;
  j["clearance_m"] = r.clearance;
  j["speed_rpm"] = r.rpm;
  j["comparison"] = to_string(r.comparison);
  j["period_revs"] = r.period_revs;
  j["sampling"] = r.sampling;
  if (r.comparison == comparison_kind::orbit) {
    j["orbit"] = {{"max_error_m", r.max_error},
                  {"rms_error_m", r.rms_error},
                  {"tolerance_m", r.tolerance},
                  {"pass", r.max_error <= r.tolerance},
                  {"worst", {{"t_s", r.worst_t},
                             {"golden_x_m", r.worst_golden[0]},
                             {"golden_y_m", r.worst_golden[1]},
                             {"candidate_x_m", r.worst_candidate[0]},
                             {"candidate_y_m", r.worst_candidate[1]}}}};
  }
  nlohmann::ordered_json stats = nlohmann::ordered_json::array();
  for (const auto& s : r.statistics)
    stats.push_back({{"name", s.key},
                     {"golden", s.golden},
                     {"candidate", s.candidate},
                     {"error", std::abs(s.candidate - s.golden)},
                     {"tolerance", s.tolerance},
                     {"pass", s.pass()}});
  j["statistics"] = stats;
  j["spanned_revs"] = r.spanned_revs;
  j["candidate_period_revs"] = r.candidate_period_revs;
  j["causes"] = nlohmann::ordered_json::array();
  for (const auto& c : r.causes) j["causes"].push_back(to_json(c));
  j["pass"] = r.pass;
  return j;
}

}  // namespace rubref
