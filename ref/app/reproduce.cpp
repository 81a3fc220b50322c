#include "ref/app/reproduce.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <set>
#include <nlohmann/json.hpp>

#include "ref/analysis/orbit_io.hpp"
#include "ref/app/python_script.hpp"
#include "ref/app/reproduce_report.hpp"
#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/base/version.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/identification/identify.hpp"
#include "ref/identification/identify_io.hpp"
#include "ref/model/closed_form.hpp"
#include "ref/orbits/continuation.hpp"
#include "ref/orbits/continuation_io.hpp"
#include "ref/sweep/sweep_io.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

namespace {

using json = nlohmann::ordered_json;
using seconds = std::chrono::duration<double>;

// What the paper shows, and where (§5-6).
constexpr std::array<double, 3> kClearances{0.2e-3, 0.3e-3, 0.4e-3};     // m, Fig. 12
constexpr double kPaperClearance = 0.3e-3;                               // m, Figs. 6-11
constexpr std::array<double, 5> kFig12Speeds{1550, 1580, 1610, 1640, 1670};  // rpm, "1550 to 1670 rpm"
constexpr std::array<double, 5> kOrbitSpeeds{1500, 1550, 1600, 1650, 1700};  // rpm, Figs. 6 and 8
constexpr double kNoContactClearance = 1.0;  // m: Fig. 3 is measured with no protrusion in reach
// Tables 1-2 and Fig. 5: the identification run on rubref's own records of the identified law,
// sampled finely enough (1024 per revolution, ~50 samples per contact) for second derivatives.
constexpr double kIdentifyFromRpm = 1500, kIdentifyToRpm = 1700, kIdentifyStepRpm = 25;
constexpr int kIdentifySamplesPerRev = 1024;

// The speed range (docs/reproduce.md, "The speed range"). The contact-free closed form says where the
// orbit reaches each clearance; continuation of the period-1 branch from below that band says
// where the rubbing branch folds back (the run-up's jump). The sweeps then run from below the
// lowest grazing to above the highest fold, with kRangePad of that span on each side for the
// sweep to settle on the contact-free orbit before and after, on a grid of kSweepStepRpm.
constexpr double kSweepStepRpm = 5.0;
constexpr double kRangePad = 0.1;
constexpr double kRangeRoundRpm = 50.0;
// The closed form is scanned on a 1 rpm grid from half the lower critical speed to twice the
// upper one: far beyond any unbalance resonance of Eq. 1.
constexpr double kScanStepRpm = 1.0;
// Continuation starts this share of the touching band below it and first ends this many band
// widths above it; the traced span doubles (up to kMaxRangeDoublings times) until the branch is
// back on the contact-free orbit.
constexpr double kContinuationLowShare = 0.25, kContinuationHighWidths = 2.0;
constexpr int kMaxRangeDoublings = 3;
// Fig. 3: an ellipse "horizontal" or "vertical" has its major axis within kAxisTolDeg of that
// axis; of those, the most eccentric one is shown. A "circle" has minor/major >= kCircleRatio;
// the lowest such speed is shown.
constexpr double kAxisTolDeg = 10.0;
constexpr double kCircleRatio = 0.95;

std::string mm_label(double m) { return format_fixed(m * 1e3, 1) + "mm"; }
std::string rpm_label(double rpm) { return format_fixed(rpm, 0) + "rpm"; }

sweep_settings paper_sweep(const std::string& variant, double clearance, double from_rpm, double to_rpm) {
  sweep_settings s;
  s.variant = variant;
  s.params.clearance = clearance;
  s.from_rpm = from_rpm;
  s.to_rpm = to_rpm;
  s.step_rpm = kSweepStepRpm;
  s.keep_orbits = true;
  s.start_from_orbit = true;  // steady orbits by shooting; settling only where none is stable
  return s;
}

const sweep_point& point_at(const sweep_branch& b, double rpm) {
  for (const auto& p : b.points)
    if (std::abs(p.rpm - rpm) < 1e-9) return p;
  throw numerical_error("reproduce: speed " + format_fixed(rpm, 1) + " rpm is not on the sweep grid");
}

json ranges_json(const speed_ranges& r) {
  json j = json::array();
  for (const auto& [lo, hi] : r) j.push_back({lo, hi});
  return j;
}

std::vector<double> ascending_speeds(const sweep_branch& b) {
  std::vector<double> v;
  for (const auto& p : b.points) v.push_back(p.rpm);
  std::sort(v.begin(), v.end());
  return v;
}

// Ranges of a branch's speeds where the recorded orbit has `period` (0: none, non-periodic).
speed_ranges period_ranges(const sweep_branch& b, int period) {
  std::map<double, int> at;
  for (const auto& p : b.points) at[p.rpm] = p.summary.period_revs;
  return contiguous_ranges(ascending_speeds(b), [&](double rpm) { return at[rpm] == period; });
}

json period_bands_json(const sweep_branch& b) {
  json j = json::object();
  j["non_periodic_rpm"] = ranges_json(period_ranges(b, 0));
  std::set<int> periods;
  for (const auto& p : b.points)
    if (p.summary.period_revs > 1) periods.insert(p.summary.period_revs);
  j["subharmonic"] = json::array();
  for (const int n : periods) j["subharmonic"].push_back({{"period_revs", n}, {"rpm", ranges_json(period_ranges(b, n))}});
  return j;
}

// The contact-free closed form on the scan grid.
struct closed_form_scan {
  std::vector<double> rpm;
  std::vector<unbalance_response> response;
};

closed_form_scan scan_closed_form(const parameters& p) {
  const double lo = 0.5 * std::sqrt(p.k_x / p.m) * 60.0 / (2.0 * std::numbers::pi);
  const double hi = 2.0 * std::sqrt(p.k_y / p.m) * 60.0 / (2.0 * std::numbers::pi);
  closed_form_scan s;
  for (double rpm = std::floor(lo); rpm <= hi; rpm += kScanStepRpm) {
    s.rpm.push_back(rpm);
    s.response.emplace_back(p, rpm_to_rad_s(rpm));
  }
  return s;
}

// Where the contact-free orbit's top |Y| exceeds the clearance, on the scan grid.
speed_ranges touching_band(const closed_form_scan& scan, double clearance) {
  std::map<double, double> top;
  for (std::size_t i = 0; i < scan.rpm.size(); ++i) top[scan.rpm[i]] = std::abs(scan.response[i].y_phasor);
  return contiguous_ranges(scan.rpm, [&](double rpm) { return top[rpm] > clearance; });
}

// Fig. 3's three shapes, chosen from the closed form (rules at kAxisTolDeg, kCircleRatio).
json choose_fig03_speeds(const closed_form_scan& scan, const parameters& p) {
  const double rpm_x = std::sqrt(p.k_x / p.m) * 60.0 / (2.0 * std::numbers::pi);
  const auto deg_from = [](double tilt, double axis_deg) {
    const double d = std::abs(tilt * 180.0 / std::numbers::pi - axis_deg);
    return std::min(d, 180.0 - d);
  };
  std::ptrdiff_t horizontal = -1, vertical = -1, circle = -1;
  const auto ratio = [&](std::size_t i) {
    const whirl_ellipse e = ellipse_of(scan.response[i]);
    return e.semi_minor / e.semi_major;
  };
  for (std::size_t i = 0; i < scan.rpm.size(); ++i) {
    const whirl_ellipse e = ellipse_of(scan.response[i]);
    const auto idx = static_cast<std::ptrdiff_t>(i);
    if (scan.rpm[i] < rpm_x && deg_from(e.tilt, 0.0) <= kAxisTolDeg && (horizontal < 0 || ratio(i) < ratio(horizontal))) horizontal = idx;
    if (scan.rpm[i] > rpm_x && deg_from(e.tilt, 90.0) <= kAxisTolDeg && (vertical < 0 || ratio(i) < ratio(vertical))) vertical = idx;
    if (vertical >= 0 && circle < 0 && scan.rpm[i] > scan.rpm[static_cast<std::size_t>(vertical)] && ratio(i) >= kCircleRatio) circle = idx;
  }
  if (horizontal < 0 || vertical < 0 || circle < 0)
    throw numerical_error("reproduce: the contact-free closed form shows no horizontal ellipse, vertical ellipse and circle "
                          "(Fig. 3) between half the lower and twice the upper critical speed");
  json out = json::array();
  for (const auto& [role, i] : {std::pair{"horizontal ellipse", horizontal}, {"vertical ellipse", vertical}, {"circle", circle}}) {
    const auto k = static_cast<std::size_t>(i);
    const whirl_ellipse e = ellipse_of(scan.response[k]);
    out.push_back({{"role", role}, {"rpm", scan.rpm[k]}, {"semi_major_mm", e.semi_major * 1e3}, {"semi_minor_mm", e.semi_minor * 1e3},
                   {"axis_ratio", e.semi_minor / e.semi_major}, {"tilt_deg", e.tilt * 180.0 / std::numbers::pi},
                   {"whirl", e.forward ? "forward" : "backward"}});
  }
  return out;
}

// The period-1 branch of the identified law at one clearance, traced upward from below the
// touching band until it is contact-free again above it.
struct traced_branch {
  continuation_request request;
  continuation_result result;
};

traced_branch trace_branch(double clearance, const speed_ranges& touching) {
  const double lo = touching.front().first, hi = touching.back().second, width = hi - lo;
  traced_branch t;
  t.request.params.clearance = clearance;
  t.request.from = std::floor((lo - kContinuationLowShare * width) / kRangeRoundRpm) * kRangeRoundRpm;
  double to = std::ceil((hi + kContinuationHighWidths * width) / kRangeRoundRpm) * kRangeRoundRpm;
  for (int attempt = 0;; ++attempt) {
    t.request.to = to;
    validate(t.request);
    t.result = continue_branch(t.request);
    const bool back_off_the_stator = t.result.reached_end && !t.result.points.empty() && t.result.points.back().max_z < 0.0;
    if (back_off_the_stator) return t;
    if (attempt == kMaxRangeDoublings || !t.result.reached_end)
      throw numerical_error("reproduce: the period-1 branch at clearance " + format_fixed(clearance * 1e3, 1) + " mm does not return to the "
                            "contact-free orbit by " + format_fixed(to, 0) + " rpm (" + t.result.stopped + ")");
    to = t.request.from + 2.0 * (to - t.request.from);
  }
}

std::vector<double> special_rpm(const continuation_result& r, special_kind kind) {
  std::vector<double> v;
  for (const auto& s : r.special)
    if (s.kind == kind) v.push_back(s.rpm);
  return v;
}

json branch_numbers(const traced_branch& t) {
  const auto& r = t.result;
  json j;
  j["from_rpm"] = t.request.from;
  j["to_rpm"] = t.request.to;
  j["points"] = r.points.size();
  j["stopped"] = r.stopped;
  j["folds_rpm"] = special_rpm(r, special_kind::fold);
  j["grazings_rpm"] = special_rpm(r, special_kind::grazing);
  j["period_doublings_rpm"] = special_rpm(r, special_kind::period_doubling);
  j["neimark_sacker_rpm"] = special_rpm(r, special_kind::neimark_sacker);
  std::size_t unstable = 0;
  for (const auto& p : r.points) unstable += p.stable ? 0 : 1;
  j["unstable_points"] = unstable;
  // The speeds where the stable contact-free and stable rubbing orbits coexist: between the two
  // outermost folds of the branch (the rubbing branch's top and the contact-free branch's grazing).
  const auto folds = special_rpm(r, special_kind::fold);
  if (folds.size() >= 2) j["coexistence_rpm"] = {*std::min_element(folds.begin(), folds.end()), *std::max_element(folds.begin(), folds.end())};
  return j;
}

void run_plot_script(const reproduce_settings& s, const std::filesystem::path& dir) {
  run_python_script(s.python.empty() ? default_python() : s.python, s.plot_script.empty() ? script_path("plot_figures.py") : s.plot_script, dir);
}

using steady_clock = std::chrono::steady_clock;

std::string elapsed_since(steady_clock::time_point t0) { return format_fixed(seconds(steady_clock::now() - t0).count(), 1) + " s"; }

// The sweeps' speed range and what it rests on (stage 1).
struct speed_range {
  closed_form_scan scan;
  std::vector<speed_ranges> touching;  // per clearance (kClearances)
  std::vector<traced_branch> traced;   // per clearance
  double lowest = 0.0, highest = 0.0;  // rpm: the lowest grazing, the highest fold or grazing
  double from_rpm = 0.0, to_rpm = 0.0;
};

// 1. The range: the closed form's touching bands, then the period-1 branch at each clearance.
speed_range find_speed_range(const parameters& paper, const reproduce_settings& s) {
  speed_range r;
  r.scan = scan_closed_form(paper);
  for (const double clearance : kClearances) {
    r.touching.push_back(touching_band(r.scan, clearance));
    if (r.touching.back().empty())
      throw numerical_error("reproduce: the contact-free orbit never reaches the clearance " + format_fixed(clearance * 1e3, 1) + " mm");
  }
  s.progress("[1/6] periodic-orbit branches of the identified law at 0.2/0.3/0.4 mm (continuation in speed) ...");
  const auto t0 = steady_clock::now();
  r.traced.resize(kClearances.size());
  parallel_for(kClearances.size(), s.threads, [&](std::size_t i) { r.traced[i] = trace_branch(kClearances[i], r.touching[i]); });
  r.lowest = r.touching.front().front().first;
  for (std::size_t i = 0; i < kClearances.size(); ++i) {
    r.lowest = std::min(r.lowest, r.touching[i].front().first);
    r.highest = std::max(r.highest, r.touching[i].back().second);
    for (const double f : special_rpm(r.traced[i].result, special_kind::fold)) r.highest = std::max(r.highest, f);
  }
  const double pad = kRangePad * (r.highest - r.lowest);
  r.from_rpm = std::floor((r.lowest - pad) / kRangeRoundRpm) * kRangeRoundRpm;
  r.to_rpm = std::ceil((r.highest + pad) / kRangeRoundRpm) * kRangeRoundRpm;
  std::size_t branch_points = 0;
  for (const auto& t : r.traced) branch_points += t.result.points.size();
  s.progress("      done in " + elapsed_since(t0) + " (" + std::to_string(branch_points) + " orbits); sweep range " + format_fixed(r.from_rpm, 0) +
             "–" + format_fixed(r.to_rpm, 0) + " rpm");
  return r;
}

// Every sweep the figures need, and the branches they gave (stage 2).
struct paper_sweeps {
  std::vector<branch_task> tasks;
  std::vector<sweep_branch> branches;  // in the tasks' order
  sweep_settings frictionless;         // the identified law without friction
  std::size_t frictionless_task = 0;
  sweep_settings identification_record;  // the finely sampled record's (the last task)
  double paper_mu = 0.0;

  const sweep_settings& grid_settings() const { return tasks.front().settings; }
  // A sweep on the range's grid with the paper's friction.
  const sweep_branch& branch_of(const std::string& variant, double clearance, sweep_direction d) const {
    for (std::size_t i = 0; i < tasks.size(); ++i)
      if (tasks[i].settings.variant == variant && tasks[i].settings.params.clearance == clearance && tasks[i].direction == d &&
          tasks[i].settings.samples_per_rev == grid_settings().samples_per_rev && tasks[i].settings.params.mu == paper_mu)
        return branches[i];
    throw numerical_error("reproduce: missing branch");
  }
};

// 2. Every sweep the figures need, one branch per task, on all cores.
paper_sweeps run_paper_sweeps(const speed_range& range, const parameters& paper, const reproduce_settings& s) {
  const double from_rpm = range.from_rpm, to_rpm = range.to_rpm;
  paper_sweeps sw;
  sw.paper_mu = paper.mu;
  for (const double clearance : kClearances)
    for (const auto dir_kind : {sweep_direction::up, sweep_direction::down})
      sw.tasks.push_back({paper_sweep("identified", clearance, from_rpm, to_rpm), dir_kind});
  for (const std::string v : {"restitution", "piecewise-linear", "piecewise-nonlinear"})
    sw.tasks.push_back({paper_sweep(v, kPaperClearance, from_rpm, to_rpm), sweep_direction::up});
  // The identified law without friction: what friction adds to the backward whirl.
  sw.frictionless = paper_sweep("identified", kPaperClearance, from_rpm, to_rpm);
  sw.frictionless.params.mu = 0.0;
  sw.frictionless_task = sw.tasks.size();
  sw.tasks.push_back({sw.frictionless, sweep_direction::up});
  sw.identification_record = paper_sweep("identified", kPaperClearance, kIdentifyFromRpm, kIdentifyToRpm);
  sw.identification_record.step_rpm = kIdentifyStepRpm;
  sw.identification_record.samples_per_rev = kIdentifySamplesPerRev;
  sw.tasks.push_back({sw.identification_record, sweep_direction::up});
  s.progress("[2/6] sweeps " + format_fixed(from_rpm, 0) + "–" + format_fixed(to_rpm, 0) + " rpm, step " + format_fixed(kSweepStepRpm, 0) +
             " rpm: identified at 0.2/0.3/0.4 mm up and down, restitution, both piecewise laws and the identified law without friction "
             "at 0.3 mm up, and a finely "
             "sampled record for identification (" + std::to_string(sw.tasks.size()) + " branches) ...");
  const auto t0 = steady_clock::now();
  sw.branches = run_branches(sw.tasks, s.threads);
  std::size_t steps = 0, shot = 0, points = 0;
  for (const auto& b : sw.branches) {
    steps += b.counts.steps;
    shot += b.orbit_starts;
    points += b.points.size();
  }
  s.progress("      done in " + elapsed_since(t0) + " (" + std::to_string(steps) + " steps; " + std::to_string(shot) + " of " +
             std::to_string(points) + " speeds started on a shot periodic orbit)");
  return sw;
}

// 3. Identification (§4) on the finely sampled record: Tables 1-2, Fig. 5. Returns its numbers.
json identify_own_record(const paper_sweeps& sw, const parameters& paper, staged_directory& dir, json& manifest) {
  const record rec = dwell_record(sw.identification_record, sw.branches.back());
  identify_settings is;
  is.linear = paper;
  is.reference = paper;
  is.law_route = law_method::samples;  // the paper's route, on a noise-free record (Table 1's ERRs)
  is.average = averaging::never;       // the paper's samples as recorded, every revolution
  is.reidentify = true;
  const identification id = identify({{rec, "identified_0.3mm.csv"}}, is);
  dir.write("data/identification_record_0.3mm.csv", to_csv(rec));
  dir.write("data/identification.json", to_json(id, is).dump(2) + "\n");
  table fig5;
  fig5.metadata = {{"generator", "rubref " + std::string(version()) + " reproduce"}, {"source", "data/identification_record_0.3mm.csv"}};
  fig5.columns = {"speed_rpm", "samples", "mu_mean", "mu_std", "mu_median", "max_penetration_m", "share_k1_z", "share_k3_z3", "share_c2_zd2"};
  for (const auto& d : id.dwells) {
    if (!d.friction) continue;
    fig5.rows.push_back({format_number(d.rpm), std::to_string(d.friction->samples), format_number(d.friction->mean),
                         format_number(d.friction->std_dev), format_number(d.friction->median), format_number(d.max_penetration),
                         format_number(d.reference_shares[0].peak_share), format_number(d.reference_shares[1].peak_share),
                         format_number(d.reference_shares[2].peak_share)});
  }
  dir.write("data/fig05_friction.csv", to_csv(fig5));
  manifest["fig05"] = {{"file", "data/fig05_friction.csv"}, {"mu_input", paper.mu}, {"mu_mean", id.mu_mean}};
  json ident = to_json(id, is);
  ident["mu_mean"] = id.mu_mean;
  ident["record"] = {{"from_rpm", kIdentifyFromRpm}, {"to_rpm", kIdentifyToRpm}, {"step_rpm", kIdentifyStepRpm},
                     {"samples_per_rev", kIdentifySamplesPerRev}, {"clearance_mm", kPaperClearance * 1e3}};
  ident["inputs"] = {{"k1", paper.k1}, {"k3", paper.k3}, {"c2", paper.c2}, {"mu", paper.mu}};
  return ident;
}

// The contact-free closed form: critical speeds, the whirl sense everywhere (its numbers), and its
// response over the sweep range (data/contact_free_response.csv).
json contact_free_response(const speed_range& range, const parameters& paper, staged_directory& dir, json& manifest) {
  const closed_form_scan& scan = range.scan;
  json cf;
  cf["critical_rpm_x"] = std::sqrt(paper.k_x / paper.m) * 60.0 / (2.0 * std::numbers::pi);
  cf["critical_rpm_y"] = std::sqrt(paper.k_y / paper.m) * 60.0 / (2.0 * std::numbers::pi);
  cf["scan_rpm"] = {scan.rpm.front(), scan.rpm.back()};
  cf["backward_whirl_rpm"] = ranges_json(contiguous_ranges(scan.rpm, [&](double rpm) {
    return !ellipse_of(unbalance_response(paper, rpm_to_rad_s(rpm))).forward;
  }));
  table t;
  t.metadata = {{"generator", "rubref " + std::string(version()) + " reproduce"},
                {"description", "contact-free unbalance response of Eq. 1 (closed form, ref/model/closed_form.hpp)"}};
  t.columns = {"speed_rpm", "x_amplitude_m", "y_amplitude_m", "max_radius_m", "forward_1x_m", "backward_1x_m", "tilt_rad"};
  for (std::size_t i = 0; i < scan.rpm.size(); ++i) {
    if (scan.rpm[i] < range.from_rpm || scan.rpm[i] > range.to_rpm) continue;
    const auto& r = scan.response[i];
    const whirl_ellipse e = ellipse_of(r);
    t.rows.push_back({format_number(scan.rpm[i]), format_number(std::abs(r.x_phasor)), format_number(std::abs(r.y_phasor)),
                      format_number(e.semi_major), format_number(std::abs(r.forward())), format_number(std::abs(r.backward())),
                      format_number(e.tilt)});
  }
  dir.write("data/contact_free_response.csv", to_csv(t));
  manifest["contact_free"] = "data/contact_free_response.csv";
  return cf;
}

// Fig. 3: contact-free orbits at the chosen speeds, simulated (not the closed form) so they share the code path.
void write_fig03_orbits(const json& fig03, unsigned threads, staged_directory& dir, json& manifest) {
  std::vector<orbit> free_orbits(fig03.size());
  parallel_for(free_orbits.size(), threads, [&](std::size_t i) {
    run_request req;
    req.params.clearance = kNoContactClearance;
    req.rpm = fig03[i]["rpm"].get<double>();
    req.record_revs = 2;
    req.samples_per_rev = 256;
    free_orbits[i] = simulate(req);
  });
  for (std::size_t i = 0; i < free_orbits.size(); ++i) {
    const std::string f = "data/orbits/fig03_" + rpm_label(free_orbits[i].request.rpm) + ".csv";
    dir.write(f, to_csv(to_record(free_orbits[i])));
    manifest["fig03"].push_back({{"file", f}, {"rpm", free_orbits[i].request.rpm}, {"role", fig03[i]["role"]}});
  }
}

// The identified law's sweeps and branches at every clearance, its waterfalls at the paper's and
// the orbits of Fig. 12.
void write_identified_sweeps(const speed_range& range, const paper_sweeps& sw, staged_directory& dir, json& manifest) {
  for (std::size_t c = 0; c < kClearances.size(); ++c) {
    const double clearance = kClearances[c];
    const auto& up = sw.branch_of("identified", clearance, sweep_direction::up);
    const auto& down = sw.branch_of("identified", clearance, sweep_direction::down);
    const std::string tag = "identified_" + mm_label(clearance);
    const sweep_settings settings = paper_sweep("identified", clearance, range.from_rpm, range.to_rpm);
    const traced_branch& traced = range.traced[c];
    dir.write("data/sweep_" + tag + ".csv", to_csv(sweep_table(settings, {up, down})));
    dir.write("data/branch_" + tag + ".csv", to_csv(branch_table(traced.request, traced.result)));
    dir.write("data/branch_" + tag + ".json", branch_summary_json(traced.request, traced.result).dump(2) + "\n");
    manifest["sweeps"].push_back({{"file", "data/sweep_" + tag + ".csv"}, {"variant", "identified"}, {"clearance_mm", clearance * 1e3}});
    manifest["branches"].push_back({{"file", "data/branch_" + tag + ".csv"}, {"summary", "data/branch_" + tag + ".json"},
                                    {"clearance_mm", clearance * 1e3}});
    if (clearance == kPaperClearance)
      for (const auto* b : {&up, &down}) {
        const std::string f = "data/waterfall_" + tag + "_" + std::string(to_string(b->direction)) + ".csv";
        dir.write(f, to_csv(waterfall_table(settings, *b)));
        manifest["waterfall"][std::string(to_string(b->direction))] = f;
      }
    for (const double rpm : kFig12Speeds) {
      const std::string f = "data/orbits/fig12_" + mm_label(clearance) + "_" + rpm_label(rpm) + ".csv";
      dir.write(f, to_csv(orbit_record(settings, point_at(up, rpm))));
      manifest["fig12"].push_back({{"file", f}, {"clearance_mm", clearance * 1e3}, {"rpm", rpm}, {"period_revs", point_at(up, rpm).summary.period_revs}});
    }
  }
}

// The other laws' sweeps at the paper's clearance and their orbits (Figs. 6, 8). Returns their numbers.
json other_laws(const speed_range& range, const paper_sweeps& sw, staged_directory& dir, json& manifest) {
  json numbers = json::object();
  for (const std::string v : {"restitution", "piecewise-linear", "piecewise-nonlinear"}) {
    const auto& up = sw.branch_of(v, kPaperClearance, sweep_direction::up);
    const sweep_settings settings = paper_sweep(v, kPaperClearance, range.from_rpm, range.to_rpm);
    const std::string f = "data/sweep_" + v + "_" + mm_label(kPaperClearance) + ".csv";
    dir.write(f, to_csv(sweep_table(settings, {up})));
    manifest["sweeps"].push_back({{"file", f}, {"variant", v}, {"clearance_mm", kPaperClearance * 1e3}});
    for (const double rpm : kOrbitSpeeds) {
      const std::string of = "data/orbits/" + std::string(v == "restitution" ? "fig06_" : "fig08_") + v + "_" + rpm_label(rpm) + ".csv";
      dir.write(of, to_csv(orbit_record(settings, point_at(up, rpm))));
      manifest[v == "restitution" ? "fig06" : "fig08"].push_back(
          {{"file", of}, {"variant", v}, {"rpm", rpm}, {"period_revs", point_at(up, rpm).summary.period_revs}});
    }
    numbers[v] = {{"friction", v != "restitution"},
                  {"rub_up_rpm", ranges_json(rub_ranges(up))},
                  {"backward_whirl_up_rpm", ranges_json(backward_whirl_ranges(up))},
                  {"periods_up", period_bands_json(up)}};
  }
  return numbers;
}

// The identified law without friction at the paper's clearance. Returns its numbers.
json frictionless_sweep(const paper_sweeps& sw, staged_directory& dir) {
  const sweep_branch& b = sw.branches[sw.frictionless_task];
  const std::string f = "data/sweep_identified_" + mm_label(kPaperClearance) + "_mu0.csv";
  dir.write(f, to_csv(sweep_table(sw.frictionless, {b})));
  return {{"variant", "identified"}, {"mu", 0.0}, {"file", f}, {"rub_up_rpm", ranges_json(rub_ranges(b))},
          {"backward_whirl_up_rpm", ranges_json(backward_whirl_ranges(b))}};
}

// Fig. 7: the stiffness laws over the penetrations reached, and the sizes of k3 z^3 and c2 zdot^2
// there: at the paper's speeds (Figs. 6, 8) and over the whole run-up (up to its fold).
// zdot is the fastest penetration rate among the recorded contact samples.
json fig07_normal_force(const speed_range& range, const paper_sweeps& sw, const parameters& paper, staged_directory& dir, json& manifest) {
  const auto reached = [&](double lo_rpm, double hi_rpm) {
    double z = 0.0, zdot = 0.0;
    for (const std::string v : {"piecewise-linear", "piecewise-nonlinear", "identified"})
      for (const auto& p : sw.branch_of(v, kPaperClearance, sweep_direction::up).points) {
        if (p.rpm < lo_rpm || p.rpm > hi_rpm) continue;
        z = std::max(z, p.summary.max_penetration);
        for (const auto& smp : p.samples)
          if (smp.s[idx::y] > kPaperClearance) zdot = std::max(zdot, std::abs(smp.s[idx::vy]));
      }
    return json{{"from_rpm", lo_rpm}, {"to_rpm", hi_rpm}, {"max_penetration_um", z * 1e6},
                {"cubic_share_at_max_penetration", paper.k3 * z * z / paper.k1}, {"k1_z_at_max_penetration_N", paper.k1 * z},
                {"max_penetration_rate_m_s", zdot}, {"c2_zdot2_at_max_rate_N", paper.c2 * zdot * zdot}};
  };
  table t;
  t.metadata = {{"generator", "rubref " + std::string(version()) + " reproduce"},
                {"k1_N_m", format_number(paper.k1)}, {"k3_N_m3", format_number(paper.k3)}, {"c2_kg_m", format_number(paper.c2)}};
  t.columns = {"z_m", "k1_z_N", "k3_z3_N", "fn_piecewise_linear_N", "fn_piecewise_nonlinear_N"};
  const auto pl = piecewise_linear::from(paper);
  const auto pnl = piecewise_nonlinear::from(paper);
  // Log-spaced from 1e-8 m to 1e-3 m: below the finest probe resolution to past the clearance.
  for (int i = 0; i <= 250; ++i) {
    const double z = std::pow(10.0, -8.0 + 5.0 * i / 250.0);
    t.rows.push_back({format_number(z), format_number(paper.k1 * z), format_number(paper.k3 * z * z * z),
                      format_number(pl.normal_force(z, 0.0)), format_number(pnl.normal_force(z, 0.0))});
  }
  dir.write("data/fig07_normal_force.csv", to_csv(t));
  manifest["fig07"] = {{"file", "data/fig07_normal_force.csv"}};
  return {{"paper_speeds", reached(kOrbitSpeeds.front(), kOrbitSpeeds.back())},
          {"whole_run_up", reached(range.from_rpm, range.to_rpm)},
          {"z_cubic_one_percent_um", std::sqrt(0.01 * paper.k1 / paper.k3) * 1e6}};
}

// Fig. 8: how far apart the piecewise-linear and -nonlinear orbits are.
json fig08_orbit_differences(const paper_sweeps& sw) {
  json out = json::array();
  for (const double rpm : kOrbitSpeeds) {
    const auto& a = point_at(sw.branch_of("piecewise-linear", kPaperClearance, sweep_direction::up), rpm);
    const auto& b = point_at(sw.branch_of("piecewise-nonlinear", kPaperClearance, sweep_direction::up), rpm);
    double diff = 0.0;
    for (std::size_t i = 0; i < a.samples.size(); ++i)
      diff = std::max(diff, std::hypot(a.samples[i].s[idx::x] - b.samples[i].s[idx::x], a.samples[i].s[idx::y] - b.samples[i].s[idx::y]));
    out.push_back({{"rpm", rpm}, {"max_orbit_difference_nm", diff * 1e9}, {"max_radius_mm", a.summary.max_radius * 1e3},
                   {"max_penetration_um", b.summary.max_penetration * 1e6}});
  }
  return out;
}

// Fig. 6: the restitution law's orbits at the paper's speeds.
json fig06_impacts(const paper_sweeps& sw) {
  json out = json::array();
  for (const double rpm : kOrbitSpeeds) {
    const auto& p = point_at(sw.branch_of("restitution", kPaperClearance, sweep_direction::up), rpm);
    out.push_back({{"rpm", rpm}, {"impacts_per_rev", p.summary.contact_episodes_per_rev}, {"period_revs", p.summary.period_revs},
                   {"whirl", p.summary.backward_whirl() ? "backward" : "forward"}, {"max_radius_mm", p.summary.max_radius * 1e3}});
  }
  return out;
}

// Per clearance: where the contact-free orbit reaches the stator, rub, whirl, periods, jumps, branch.
json clearance_numbers(const speed_range& range, const paper_sweeps& sw) {
  json out = json::array();
  for (std::size_t ci = 0; ci < kClearances.size(); ++ci) {
    const double clearance = kClearances[ci];
    const auto& up = sw.branch_of("identified", clearance, sweep_direction::up);
    const auto& down = sw.branch_of("identified", clearance, sweep_direction::down);
    const jump_report jr = detect_jumps(up, down, kSweepStepRpm);
    json c;
    c["clearance_mm"] = clearance * 1e3;
    c["contact_free_orbit_reaches_stator_rpm"] = ranges_json(range.touching[ci]);
    c["rub_up_rpm"] = ranges_json(rub_ranges(up));
    c["rub_down_rpm"] = ranges_json(rub_ranges(down));
    c["backward_whirl_up_rpm"] = ranges_json(backward_whirl_ranges(up));
    c["backward_whirl_down_rpm"] = ranges_json(backward_whirl_ranges(down));
    c["periods_up"] = period_bands_json(up);
    c["periods_down"] = period_bands_json(down);
    c["hysteresis_bands_rpm"] = json::array();
    for (const auto& band : jr.bands) c["hysteresis_bands_rpm"].push_back({band.from_rpm, band.to_rpm});
    c["hysteresis_width_rpm"] = jr.total_width_rpm;
    c["jumps"] = json::array();
    for (const auto& j : jr.jumps)
      c["jumps"].push_back({{"sweep", to_string(j.sweep)}, {"from_rpm", j.from_rpm}, {"to_rpm", j.to_rpm},
                            {"amplitude_before_mm", j.amplitude_before * 1e3}, {"amplitude_after_mm", j.amplitude_after * 1e3}});
    c["branch"] = branch_numbers(range.traced[ci]);
    // Both rub boundaries inside the range: the run-up ends clear of the stator and the run-down starts so.
    const auto rub = rub_ranges(up);
    c["range_brackets_rub"] = !rub.empty() && rub.front().first > range.from_rpm && rub.back().second < range.to_rpm &&
                              !rub_ranges(down).empty() && rub_ranges(down).front().first > range.from_rpm;
    for (const double rpm : kFig12Speeds) {
      const auto& pt = point_at(up, rpm);
      c["fig12"].push_back({{"rpm", rpm}, {"regime", to_string(pt.summary.regime)}, {"period_revs", pt.summary.period_revs},
                            {"whirl", pt.summary.backward_whirl() ? "backward" : "forward"},
                            {"contacts_per_rev", pt.summary.contact_episodes_per_rev},
                            {"max_radius_mm", pt.summary.max_radius * 1e3},
                            {"forward_1x_mm", std::abs(pt.summary.forward_1x) * 1e3},
                            {"backward_1x_mm", std::abs(pt.summary.backward_1x) * 1e3}});
    }
    out.push_back(c);
  }
  return out;
}

// 4. Data files and the numbers of the report.
void write_data(const speed_range& range, const paper_sweeps& sw, const parameters& paper, const reproduce_settings& s, staged_directory& dir,
                json& manifest, json& numbers) {
  numbers["settings"] = sweep_settings_json(sw.grid_settings());
  numbers["settings"]["settle_rounds"] = kSettleRounds;
  numbers["range"] = {{"from_rpm", range.from_rpm}, {"to_rpm", range.to_rpm}, {"step_rpm", kSweepStepRpm}, {"lowest_grazing_rpm", range.lowest},
                      {"highest_fold_or_grazing_rpm", range.highest}, {"pad_share", kRangePad}};
  numbers["closed_form"] = contact_free_response(range, paper, dir, manifest);
  numbers["fig03"] = choose_fig03_speeds(range.scan, paper);
  write_fig03_orbits(numbers["fig03"], s.threads, dir, manifest);
  write_identified_sweeps(range, sw, dir, manifest);
  numbers["other_laws"] = other_laws(range, sw, dir, manifest);
  numbers["frictionless"] = frictionless_sweep(sw, dir);
  numbers["fig07"] = fig07_normal_force(range, sw, paper, dir, manifest);
  numbers["fig08"] = fig08_orbit_differences(sw);
  numbers["fig06"] = fig06_impacts(sw);
  numbers["clearances"] = clearance_numbers(range, sw);
  manifest["clearance_mm"] = kPaperClearance * 1e3;
  manifest["sweep_grid_rpm"] = {range.from_rpm, range.to_rpm, kSweepStepRpm};
  dir.write("data/figures.json", manifest.dump(2) + "\n");
}

}  // namespace

void reproduce(const reproduce_settings& s) {
  const auto t_start = steady_clock::now();
  staged_directory dir(s.out);
  const parameters paper;  // every number below comes from the paper's defaults
  json manifest, numbers;
  numbers["generator"] = "rubref " + std::string(version()) + " reproduce";
  numbers["commit"] = std::string(commit());

  const speed_range range = find_speed_range(paper, s);
  const paper_sweeps sweeps = run_paper_sweeps(range, paper, s);

  s.progress("[3/6] identification (ERR/FROLS, friction, output error) on rubref's own identified-law record ...");
  auto t0 = steady_clock::now();
  numbers["identification"] = identify_own_record(sweeps, paper, dir, manifest);
  s.progress("      done in " + elapsed_since(t0));

  s.progress("[4/6] data tables, orbits and the numbers of the report ...");
  t0 = steady_clock::now();
  write_data(range, sweeps, paper, s, dir, manifest, numbers);
  s.progress("      done in " + elapsed_since(t0));
  for (const auto& c : numbers["clearances"])
    if (!c["range_brackets_rub"].get<bool>())
      s.progress("warning: at clearance " + format_fixed(c["clearance_mm"].get<double>(), 1) + " mm a sweep still rubs at an end of " +
                 format_fixed(range.from_rpm, 0) + "–" + format_fixed(range.to_rpm, 0) + " rpm: the range does not bracket both rub boundaries");

  // 5. The report: every number in it comes from `numbers` (reproduce.json).
  s.progress("[5/6] report.md ...");
  dir.write("report.md", report_markdown(numbers));
  dir.write("reproduce.json", numbers.dump(2) + "\n");

  // 6. Figures.
  if (s.figures) {
    s.progress("[6/6] figures (matplotlib, 300 dpi PNG and SVG) ...");
    t0 = steady_clock::now();
    run_plot_script(s, dir.path());
    s.progress("      done in " + elapsed_since(t0));
  } else {
    s.progress("[6/6] figures skipped");
  }
  dir.commit();
  s.progress("reproduce finished in " + elapsed_since(t_start) + ": " + (dir.target() / "report.md").string());
}

}  // namespace rubref
