#include "ref/sweep/sweep_io.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>

#include "ref/analysis/orbit_io.hpp"
#include "ref/base/errors.hpp"
#include "ref/base/version.hpp"
#include "ref/format/record.hpp"
#include "ref/model/parameter_io.hpp"

namespace rubref {

const std::vector<order_column>& reported_orders() {
  static const std::vector<order_column> orders = [] {
    std::vector<order_column> out;
    const std::vector<std::pair<double, std::string>> magnitudes{
        {1.0 / 3.0, "1_3"}, {0.5, "1_2"}, {2.0 / 3.0, "2_3"}, {1, "1"}, {1.5, "3_2"}, {2, "2"}, {3, "3"}, {4, "4"}, {5, "5"}};
    for (auto it = magnitudes.rbegin(); it != magnitudes.rend(); ++it) out.push_back({-it->first, "amp_b" + it->second + "x_m"});
    out.push_back({0.0, "amp_0x_m"});
    for (const auto& [o, label] : magnitudes) out.push_back({o, "amp_f" + label + "x_m"});
    return out;
  }();
  return orders;
}

std::vector<std::pair<std::string, std::string>> sweep_metadata(const sweep_settings& s) {
  record meta;  // reuse the record's ordered key/value store
  meta.set("generator", "rubref " + std::string(version()) + " sweep");
  meta.set("commit", std::string(commit()));
  meta.set("variant", s.variant);
  write_parameters(meta, s.params);
  meta.set("from_rpm", s.from_rpm);
  meta.set("to_rpm", s.to_rpm);
  meta.set("step_rpm", s.step_rpm);
  meta.set("first_settle_revs", static_cast<double>(s.first_settle_revs));
  meta.set("settle_revs", static_cast<double>(s.settle_revs));
  if (s.start_from_orbit) meta.set("start", std::string("periodic orbit continued from the previous speed where stable"));
  meta.set("record_revs", static_cast<double>(s.record_revs));
  meta.set("samples_per_rev", static_cast<double>(s.samples_per_rev));
  meta.set("stepper", std::string(to_string(s.integration.stepper.kind)));
  meta.set("rtol", s.integration.stepper.rtol);
  meta.set("atol", s.integration.stepper.atol);
  return meta.metadata;
}

record orbit_record(const sweep_settings& s, const sweep_point& p) {
  orbit o;
  o.request = request_at(s, p.rpm);
  o.samples = p.samples;
  record r = to_record(o);
  r.set("generator", "rubref " + std::string(version()) + " sweep");
  r.set("initial_state", "continued from the previous speed of the sweep");
  return r;
}

record dwell_record(const sweep_settings& s, const sweep_branch& b) {
  record r;
  r.metadata = sweep_metadata(s);
  r.set("clearance_m", s.params.clearance);
  r.set("description", "rubref sweep, " + std::string(to_string(b.direction)) + ", one dwell per speed");
  orbit_columns cols;
  double t_end = -std::numeric_limits<double>::infinity();
  for (const auto& p : b.points) {
    if (p.samples.empty()) throw input_error("dwell_record needs the sweep's orbits (keep_orbits)");
    const double period = 60.0 / p.rpm;
    const double dt = period / s.samples_per_rev;
    // Whole periods of this speed: cos(w (t + n T)) = cos(w t).
    const double shift = std::max(0.0, std::ceil((t_end + dt - p.samples.front().t) / period)) * period;
    cols.append(p.samples, p.rpm, shift);
    t_end = cols.t.back();
  }
  cols.move_into(r);
  return r;
}

table sweep_table(const sweep_settings& s, const std::vector<sweep_branch>& branches) {
  table t;
  t.metadata = sweep_metadata(s);
  t.columns = {"direction", "speed_rpm", "peak_to_peak_x_m", "peak_to_peak_y_m", "max_y_m", "max_radius_m", "radius_spread_m", "max_penetration_m",
               "max_normal_force_N", "contact_episodes_per_rev", "contact_fraction", "regime", "period_revs", "whirl"};
  for (const auto& oc : reported_orders()) t.columns.push_back(oc.name);
  for (const auto& b : branches) {
    for (const auto& p : b.points) {
      const auto& m = p.summary;
      std::vector<std::string> row{std::string(to_string(b.direction)), format_number(p.rpm),
                                   format_number(m.peak_to_peak_x), format_number(m.peak_to_peak_y), format_number(m.max_y),
                                   format_number(m.max_radius), format_number(m.radius_spread), format_number(m.max_penetration),
                                   format_number(m.max_normal_force), format_number(m.contact_episodes_per_rev),
                                   format_number(m.contact_fraction), std::string(to_string(m.regime)), std::to_string(m.period_revs),
                                   m.backward_whirl() ? "backward" : "forward"};
      for (const auto& oc : reported_orders()) row.push_back(format_number(m.spectrum.amplitude(oc.order)));
      t.rows.push_back(std::move(row));
    }
  }
  return t;
}

table waterfall_table(const sweep_settings& s, const sweep_branch& b, double max_order) {
  table t;
  t.metadata = sweep_metadata(s);
  t.metadata.emplace_back("direction", std::string(to_string(b.direction)));
  t.metadata.emplace_back("spectrum", "full spectrum of x + j y, rectangular window over record_revs whole revolutions; negative orders are backward whirl");
  t.columns = {"speed_rpm", "order", "amplitude_m"};
  std::vector<const sweep_point*> ascending;
  for (const auto& p : b.points) ascending.push_back(&p);
  std::sort(ascending.begin(), ascending.end(), [](auto* a, auto* c) { return a->rpm < c->rpm; });
  for (const auto* p : ascending) {
    const auto& sp = p->summary.spectrum;
    for (std::size_t k = 0; k < sp.frequency.size(); ++k)
      if (std::abs(sp.frequency[k]) <= max_order + 1e-9)
        t.rows.push_back({format_number(p->rpm), format_number(sp.frequency[k]), format_number(std::abs(sp.coefficient[k]))});
  }
  return t;
}

namespace {
speed_ranges ranges_of(const sweep_branch& b, const std::function<bool(const orbit_summary&)>& holds) {
  std::map<double, const orbit_summary*> by_speed;
  for (const auto& p : b.points) by_speed[p.rpm] = &p.summary;
  std::vector<double> speeds;
  for (const auto& [rpm, summary] : by_speed) speeds.push_back(rpm);
  return contiguous_ranges(speeds, [&](double rpm) { return holds(*by_speed.at(rpm)); });
}
}  // namespace

speed_ranges backward_whirl_ranges(const sweep_branch& b) {
  return ranges_of(b, [](const orbit_summary& s) { return s.backward_whirl(); });
}

speed_ranges rub_ranges(const sweep_branch& b) {
  return ranges_of(b, [](const orbit_summary& s) { return s.regime != contact_regime::no_contact; });
}

nlohmann::ordered_json sweep_settings_json(const sweep_settings& s) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();
  for (const auto& [k, v] : sweep_metadata(s)) {
    // The metadata is text (a file header); in JSON a number is a number.
    double x = 0.0;
    const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
    if (ec == std::errc() && end == v.data() + v.size() && std::isfinite(x))
      j[k] = x;
    else
      j[k] = v;
  }
  return j;
}

nlohmann::ordered_json sweep_summary_json(const sweep_settings& s, const std::vector<sweep_branch>& branches) {
  nlohmann::ordered_json j;
  j["settings"] = sweep_settings_json(s);
  const sweep_branch* up = nullptr;
  const sweep_branch* down = nullptr;
  for (const auto& b : branches) {
    nlohmann::ordered_json jb;
    jb["direction"] = to_string(b.direction);
    jb["speeds"] = b.points.size();
    jb["steps"] = b.counts.steps;
    jb["events"] = b.counts.events;
    if (s.start_from_orbit) jb["orbit_starts"] = b.orbit_starts;
    if (b.counts.coarse_contact_steps > 0) {
      jb["coarse_contact_steps"] = b.counts.coarse_contact_steps;
      jb["max_contact_rate_dt"] = b.counts.max_contact_rate_dt;
      jb["first_coarse_contact_rpm"] = b.first_coarse_contact_rpm;
    }
    for (const auto& [lo, hi] : backward_whirl_ranges(b)) jb["backward_whirl_rpm"].push_back({lo, hi});
    if (!jb.contains("backward_whirl_rpm")) jb["backward_whirl_rpm"] = nlohmann::json::array();
    j["branches"].push_back(jb);
    (b.direction == sweep_direction::up ? up : down) = &b;
  }
  if (up && down) {
    const jump_report rep = detect_jumps(*up, *down, s.step_rpm);
    auto& jj = j["jumps"];
    jj["response"] = "max_radius_m";
    jj["coexistence_relative_tolerance"] = rep.relative_tolerance;
    jj["hysteresis_bands_rpm"] = nlohmann::json::array();
    for (const auto& band : rep.bands) jj["hysteresis_bands_rpm"].push_back({band.from_rpm, band.to_rpm});
    jj["hysteresis_width_rpm"] = rep.total_width_rpm;
    jj["jumps"] = nlohmann::json::array();
    for (const auto& jp : rep.jumps)
      jj["jumps"].push_back({{"sweep", to_string(jp.sweep)},
                             {"from_rpm", jp.from_rpm},
                             {"to_rpm", jp.to_rpm},
                             {"amplitude_before_m", jp.amplitude_before},
                             {"amplitude_after_m", jp.amplitude_after},
                             {"kind", jp.amplitude_after > jp.amplitude_before ? "jump_up" : "jump_down"}});
  }
  return j;
}

}  // namespace rubref
