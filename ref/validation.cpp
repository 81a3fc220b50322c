#include "ref/validation.hpp"

#include <algorithm>
#include <boost/math/tools/minima.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <sstream>

#include "ref/errors.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

namespace {

std::string num(double v, int digits = 4) {
  std::ostringstream out;
  out.precision(digits);
  out << v;
  return out.str();
}

}  // namespace

candidate_data read_candidate(const golden_case& g, const record& c, const std::string& name) {
  candidate_data d;
  d.t = c.column("t_s");
  d.x = c.column("x_m");
  d.y = c.column("y_m");
  const auto& speed = c.column("speed_rpm");
  for (std::size_t i = 0; i < speed.size(); ++i)
    if (std::abs(speed[i] - g.request.rpm) > 1e-9 * g.request.rpm)
      throw input_error((c.source.empty() ? name + ": " : c.where_row(i)) + "speed_rpm is " + num(speed[i], 17) + " at t = " + num(d.t[i], 17) + " s, the case runs at " +
                        num(g.request.rpm, 17) + " rpm");
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

// The candidate's samples paired with the golden orbit at the same times of the case's run.
struct comparison_points {
  std::vector<double> t;       // s, in the case's run, ascending
  std::vector<double> x, y;    // m, the candidate
  std::vector<double> gx, gy;  // m, the golden orbit
  std::string note;
};

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
    throw numerical_error("integrating " + g.name + " again does not reproduce its samples (difference " + num(drift, 3) +
                          " m): the file was made by another rubref; compare at the case's own sample times");

  if (c.t.front() < 0.0) throw input_error(name + ": t_s starts at " + num(c.t.front(), 17) + " s; time is absolute, from rest at t = 0");
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
                 "; the golden orbit there integrated again with the golden method (it reproduces the file to " + num(drift, 2) + " m)";
    }
  }
  return out;
}

// Upward crossings of the clearance: contact episodes seen on the samples.
int episodes(const std::vector<double>& y, double delta) {
  int count = 0;
  for (std::size_t i = 1; i < y.size(); ++i)
    if (y[i - 1] <= delta && y[i] > delta) ++count;
  return count;
}

// RMS distance between the candidate and rubref's run of the case with `params` at the
// comparison times (rubref's default integration): infinite when that run fails.
double rms_against(const golden_case& g, const comparison_points& pts, const parameters& params) {
  const auto s = case_states_at(g, params, g.request.integration, pts.t);
  if (s.size() != pts.t.size()) return std::numeric_limits<double>::infinity();
  double sum = 0.0;
  for (std::size_t i = 0; i < s.size(); ++i) sum += std::pow(s[i][idx::x] - pts.x[i], 2) + std::pow(s[i][idx::y] - pts.y[i], 2);
  return std::sqrt(sum / static_cast<double>(s.size()));
}

struct coefficient_fit {
  double value, rms;
};

// The value of one coefficient in [lo, hi] with which rubref comes closest to the candidate: the
// best of a coarse grid, refined by Brent's method between its neighbours.
coefficient_fit fit_coefficient(const golden_case& g, const comparison_points& pts, double parameters::*member, double lo, double hi) {
  const auto error = [&](double v) {
    parameters p = g.request.params;
    p.*member = v;
    return rms_against(g, pts, p);
  };
  constexpr int kGrid = 10;
  int best = 0;
  double best_rms = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= kGrid; ++k) {
    const double e = error(lo + (hi - lo) * k / kGrid);
    if (e < best_rms) {
      best_rms = e;
      best = k;
    }
  }
  const double a = lo + (hi - lo) * std::max(0, best - 1) / kGrid, b = lo + (hi - lo) * std::min(kGrid, best + 1) / kGrid;
  std::uintmax_t iterations = 40;
  const auto [value, rms] = boost::math::tools::brent_find_minima(error, a, b, 30, iterations);
  return rms < best_rms ? coefficient_fit{value, rms} : coefficient_fit{lo + (hi - lo) * best / kGrid, best_rms};
}

void diagnose(const golden_case& g, const candidate_data& c, const comparison_points* pts, validation_result& r) {
  const parameters& p = g.request.params;
  const double delta = p.delta, scale = kGoldenOrbitRelTol * g.statistics.max_radius;
  const bool rigid = visit_variant(g.request.variant, []<class V>() { return impact_law<V>; });

  // A rigid stator cannot be entered.
  std::size_t deepest = 0;
  for (std::size_t i = 1; i < c.y.size(); ++i)
    if (c.y[i] > c.y[deepest]) deepest = i;
  const double depth = c.y[deepest] - delta;
  double golden_depth = 0.0;
  for (const double y : g.y) golden_depth = std::max(golden_depth, y - delta);
  if (rigid && depth > scale)
    r.likely_causes.push_back("missed impacts: the candidate goes " + num(depth) + " m into the stator at t = " + num(c.t[deepest], 10) +
                              " s, which the restitution law (Eq. 6) never allows; impacts are detected late (only at step "
                              "ends?) or missed between steps");
  if (!rigid && golden_depth > 0.0 && depth > 1.5 * golden_depth + scale)
    r.likely_causes.push_back("late contact force: the candidate penetrates " + num(depth) + " m where the golden's deepest sample is " +
                              num(golden_depth) + " m; contact onsets are detected late or missed between steps");
  if (pts) {
    const int want = episodes(pts->gy, delta), got = episodes(pts->y, delta);
    if (got < want)
      r.likely_causes.push_back("missed contact events: " + std::to_string(got) + " contact episodes on the compared samples where the golden has " +
                                std::to_string(want) + "; short or grazing contacts are missed between steps");
  }
  if (!pts) return;

  // One coefficient that, put into rubref, reproduces the candidate.
  if (rigid) {
    const coefficient_fit f = fit_coefficient(g, *pts, &parameters::r, 0.0, 1.0);
    if (f.rms <= g.orbit_tolerance && std::abs(f.value - p.r) > 1e-3) {
      std::string why;
      if (std::abs(f.value - std::sqrt(p.r)) <= 2e-3) why = " (sqrt(" + num(p.r) + ") = " + num(std::sqrt(p.r)) + ": r applied to the kinetic energy instead of the velocity?)";
      if (std::abs(f.value - p.r * p.r) <= 2e-3) why = " (" + num(p.r) + "^2 = " + num(p.r * p.r) + ": r applied twice, or to the energy?)";
      r.likely_causes.push_back("wrong coefficient of restitution: rubref with r = " + num(f.value) + " instead of " + num(p.r) +
                                " reproduces the candidate to " + num(f.rms, 2) + " m RMS" + why);
    }
  } else if (p.mu > 0.0) {
    const coefficient_fit f = fit_coefficient(g, *pts, &parameters::mu, -1.0, 1.0);
    if (f.rms <= g.orbit_tolerance && std::abs(f.value - p.mu) > 1e-3 * p.mu + 1e-4) {
      if (f.value < 0.0)
        r.likely_causes.push_back("wrong friction sign: rubref with f_x = -mu f_N (mu = " + num(-f.value) + ") reproduces the candidate to " +
                                  num(f.rms, 2) + " m RMS; for a shaft spinning counter-clockwise (x towards y) the stator pushes "
                                  "the rotor's top towards +x, f_x = +mu f_N (docs/model.md)");
      else
        r.likely_causes.push_back("wrong friction coefficient: rubref with mu = " + num(f.value) + " instead of " + num(p.mu) +
                                  " reproduces the candidate to " + num(f.rms, 2) + " m RMS");
    }
  }
}

}  // namespace

validation_result validate_candidate(const golden_case& g, const record& candidate, const std::string& candidate_name) {
  validation_result r;
  r.case_name = g.name;
  r.candidate_name = candidate_name;
  r.variant = g.request.variant;
  r.clearance = g.request.params.delta;
  r.rpm = g.request.rpm;
  r.comparison = g.comparison;
  r.period_revs = g.period_revs;
  const candidate_data c = read_candidate(g, candidate, candidate_name);
  const double omega = g.omega(), period = 60.0 / g.request.rpm;

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
    got = statistics_of(pts.t, pts.x, pts.y, omega, g.request.params.delta);
    want = statistics_of(pts.t, pts.gx, pts.gy, omega, g.request.params.delta);
  } else {
    if (c.t.back() - c.t.front() < period * (1.0 - 1e-9))
      throw input_error(candidate_name + ": covers " + num((c.t.back() - c.t.front()) / period) +
                        " revolutions; a statistics case needs at least one whole revolution (the golden has " +
                        std::to_string(g.request.record_revs) + ")");
    r.sampling = "its own " + std::to_string(c.t.size()) + " samples (statistics only: this case is chaotic)";
    const double nan = std::numeric_limits<double>::quiet_NaN();
    r.max_error = r.rms_error = r.tolerance = r.worst_t = nan;
    got = statistics_of(c.t, c.x, c.y, omega, g.request.params.delta);
  }
  for (const auto& info : statistic_table)
    r.statistics.push_back({std::string(info.key), want.*info.member, got.*info.member, g.statistics_tolerance.*info.member});

  r.pass = std::all_of(r.statistics.begin(), r.statistics.end(), [](const statistic_check& s) { return s.pass(); });
  if (g.comparison == comparison_kind::orbit) r.pass = r.pass && r.max_error <= r.tolerance;
  if (!r.pass) diagnose(g, c, g.comparison == comparison_kind::orbit ? &pts : nullptr, r);
  return r;
}

std::string to_text(const validation_result& r) {
  std::ostringstream out;
  out << "case      " << r.case_name << " (" << r.variant << ", clearance " << num(r.clearance * 1e3) << " mm, " << num(r.rpm)
      << " rpm; compared as " << to_string(r.comparison);
  if (r.period_revs > 0) out << ", period " << r.period_revs << " rev";
  out << ")\n";
  out << "candidate " << r.candidate_name << ": " << r.sampling << "\n";
  if (r.comparison == comparison_kind::orbit) {
    const double phase = std::fmod(r.worst_t * r.rpm / 60.0, 1.0) * 360.0;
    out << "orbit     max error " << num(r.max_error, 3) << " m (t = " << num(r.worst_t, 10) << " s, " << num(phase, 3)
        << " deg: golden (" << num(r.worst_golden[0], 6) << ", " << num(r.worst_golden[1], 6) << "), candidate ("
        << num(r.worst_candidate[0], 6) << ", " << num(r.worst_candidate[1], 6) << ") m), RMS " << num(r.rms_error, 3)
        << " m; tolerance " << num(r.tolerance, 3) << " m: " << (r.max_error <= r.tolerance ? "ok" : "FAIL") << "\n";
  }
  for (const auto& s : r.statistics)
    out << "          " << s.key << std::string(s.key.size() < 18 ? 18 - s.key.size() : 1, ' ') << "golden " << num(s.golden, 6)
        << ", candidate " << num(s.candidate, 6) << ", error " << num(std::abs(s.candidate - s.golden), 3) << " (tolerance "
        << num(s.tolerance, 3) << "): " << (s.pass() ? "ok" : "FAIL") << "\n";
  for (const auto& cause : r.likely_causes) out << "cause     " << cause << "\n";
  if (!r.pass && r.likely_causes.empty()) out << "cause     no single cause found\n";
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
  j["likely_causes"] = r.likely_causes;
  j["pass"] = r.pass;
  return j;
}

}  // namespace rubref
