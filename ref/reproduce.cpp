#include "ref/reproduce.hpp"

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ref/atomic_output.hpp"
#include "ref/closed_form.hpp"
#include "ref/errors.hpp"
#include "ref/identification/identify.hpp"
#include "ref/orbit_io.hpp"
#include "ref/parallel.hpp"
#include "ref/python_script.hpp"
#include "ref/sweep_io.hpp"
#include "ref/version.hpp"
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
// Fig. 3: horizontal ellipse (k_x < k_y, below both resonances), vertical ellipse (between
// and just above them, y resonance at 1569 rpm), near-circle (far above: |X| -> |Y| -> e).
constexpr std::array<double, 4> kFig3Speeds{1450, 1500, 1560, 2400};
constexpr double kNoContactClearance = 1.0;  // m: Fig. 3 is measured with no protrusion in reach
// Tables 1-2 and Fig. 5: the identification run on rubref's own records of the identified law,
// sampled finely enough (1024 per revolution, ~50 samples per contact) for second derivatives.
constexpr double kIdentifyFromRpm = 1500, kIdentifyToRpm = 1700, kIdentifyStepRpm = 25;
constexpr int kIdentifySamplesPerRev = 1024;
// The paper's Table 1 (ERR) and Table 2 (estimates).
const std::vector<std::pair<std::string, double>> kPaperTable1{
    {"z1", 0.39170}, {"z2", 0.00871}, {"z3", 0.56768}, {"z4", 0.00103},
    {"zd1", 0.00217}, {"zd2", 0.02636}, {"zd3", 0.00145}, {"zd4", 0.00090}};

std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}
std::string sig(double v, int digits = 4) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}
std::string mm_label(double m) { return fixed(m * 1e3, 1) + "mm"; }
std::string rpm_label(double rpm) { return fixed(rpm, 0) + "rpm"; }

sweep_settings paper_sweep(const std::string& variant, double delta) {
  sweep_settings s;
  s.variant = variant;
  s.params.delta = delta;
  s.keep_orbits = true;
  return s;
}

const sweep_point& point_at(const sweep_branch& b, double rpm) {
  for (const auto& p : b.points)
    if (std::abs(p.rpm - rpm) < 1e-9) return p;
  throw input_error("reproduce: speed " + fixed(rpm, 1) + " rpm is not on the sweep grid");
}

std::string range_text(const speed_ranges& ranges) {
  if (ranges.empty()) return "none";
  std::string out;
  for (const auto& [lo, hi] : ranges) out += (out.empty() ? "" : ", ") + fixed(lo, 0) + "–" + fixed(hi, 0) + " rpm";
  return out;
}

json ranges_json(const speed_ranges& r) {
  json j = json::array();
  for (const auto& [lo, hi] : r) j.push_back({lo, hi});
  return j;
}

void run_plot_script(const reproduce_settings& s, const std::filesystem::path& dir) {
  run_python_script(s.python.empty() ? default_python() : s.python, s.plot_script.empty() ? script_path("plot_figures.py") : s.plot_script, dir);
}

}  // namespace

void reproduce(const reproduce_settings& s) {
  const auto t_start = std::chrono::steady_clock::now();
  const auto since = [](auto t0) { return fixed(seconds(std::chrono::steady_clock::now() - t0).count(), 1) + " s"; };
  staged_directory dir(s.out);
  const parameters paper;  // every number below comes from the paper's defaults
  json manifest, numbers;
  numbers["generator"] = "rubref " + std::string(version()) + " reproduce";
  numbers["commit"] = std::string(commit());

  // 1. Every sweep the figures need, one branch per task, on all cores.
  std::vector<branch_task> tasks;
  for (const double delta : kClearances)
    for (const auto dir_kind : {sweep_direction::up, sweep_direction::down}) tasks.push_back({paper_sweep("identified", delta), dir_kind});
  for (const std::string v : {"restitution", "piecewise-linear", "piecewise-nonlinear"})
    tasks.push_back({paper_sweep(v, kPaperClearance), sweep_direction::up});
  sweep_settings id_sweep = paper_sweep("identified", kPaperClearance);
  id_sweep.from_rpm = kIdentifyFromRpm;
  id_sweep.to_rpm = kIdentifyToRpm;
  id_sweep.step_rpm = kIdentifyStepRpm;
  id_sweep.samples_per_rev = kIdentifySamplesPerRev;
  tasks.push_back({id_sweep, sweep_direction::up});
  const sweep_settings& grid_settings = tasks.front().settings;
  const std::vector<double> grid = sweep_speeds(grid_settings);
  s.progress("[1/5] sweeps " + fixed(grid_settings.from_rpm, 0) + "–" + fixed(grid_settings.to_rpm, 0) + " rpm, step " +
             fixed(grid_settings.step_rpm, 0) + " rpm: identified at 0.2/0.3/0.4 mm up and down, restitution and both "
             "piecewise laws at 0.3 mm up, and a finely sampled record for identification (" + std::to_string(tasks.size()) +
             " branches) ...");
  auto t0 = std::chrono::steady_clock::now();
  const std::vector<sweep_branch> branches = run_branches(tasks, s.threads);
  std::size_t steps = 0;
  for (const auto& b : branches) steps += b.counts.steps;
  s.progress("      done in " + since(t0) + " (" + std::to_string(steps) + " steps)");

  const auto branch_of = [&](const std::string& variant, double delta, sweep_direction d) -> const sweep_branch& {
    for (std::size_t i = 0; i < tasks.size(); ++i)
      if (tasks[i].settings.variant == variant && tasks[i].settings.params.delta == delta && tasks[i].direction == d &&
          tasks[i].settings.samples_per_rev == grid_settings.samples_per_rev)
        return branches[i];
    throw input_error("reproduce: missing branch");
  };

  // 2. Identification (§4) on the finely sampled record: Tables 1-2, Fig. 5.
  s.progress("[2/5] identification (ERR/FROLS, friction, output error) on rubref's own identified-law record ...");
  t0 = std::chrono::steady_clock::now();
  json ident;
  {
    const record rec = dwell_record(id_sweep, branches.back());
    identify_settings is;
    is.linear = paper;
    is.reference = paper;
    is.law_route = law_method::samples;  // the paper's route, on a noise-free record (Table 1's ERRs)
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
    manifest["fig05"] = {{"file", "data/fig05_friction.csv"}, {"mu_paper", 0.24}, {"mu_mean", id.mu_mean}};
    ident = to_json(id, is);
    ident["mu_mean"] = id.mu_mean;
  }
  s.progress("      done in " + since(t0));

  // 3. Data files.
  s.progress("[3/5] data tables, orbits and the numbers of the report ...");
  t0 = std::chrono::steady_clock::now();
  for (const double delta : kClearances) {
    const auto& up = branch_of("identified", delta, sweep_direction::up);
    const auto& down = branch_of("identified", delta, sweep_direction::down);
    const std::string tag = "identified_" + mm_label(delta);
    dir.write("data/sweep_" + tag + ".csv", to_csv(sweep_table(paper_sweep("identified", delta), {up, down})));
    manifest["sweeps"].push_back({{"file", "data/sweep_" + tag + ".csv"}, {"variant", "identified"}, {"clearance_mm", delta * 1e3}});
    for (const auto& b : {&up, &down})
      if (delta == kPaperClearance) {
        const std::string f = "data/waterfall_" + tag + "_" + std::string(to_string(b->direction)) + ".csv";
        dir.write(f, to_csv(waterfall_table(paper_sweep("identified", delta), *b)));
        manifest["waterfall"][std::string(to_string(b->direction))] = f;
      }
    for (const double rpm : kFig12Speeds) {
      const std::string f = "data/orbits/fig12_" + mm_label(delta) + "_" + rpm_label(rpm) + ".csv";
      dir.write(f, to_csv(orbit_record(paper_sweep("identified", delta), point_at(up, rpm))));
      manifest["fig12"].push_back({{"file", f}, {"clearance_mm", delta * 1e3}, {"rpm", rpm}});
    }
  }
  for (const std::string v : {"restitution", "piecewise-linear", "piecewise-nonlinear"}) {
    const auto& up = branch_of(v, kPaperClearance, sweep_direction::up);
    const std::string f = "data/sweep_" + v + "_" + mm_label(kPaperClearance) + ".csv";
    dir.write(f, to_csv(sweep_table(paper_sweep(v, kPaperClearance), {up})));
    manifest["sweeps"].push_back({{"file", f}, {"variant", v}, {"clearance_mm", kPaperClearance * 1e3}});
    for (const double rpm : kOrbitSpeeds) {
      const std::string of = "data/orbits/" + std::string(v == "restitution" ? "fig06_" : "fig08_") + v + "_" + rpm_label(rpm) + ".csv";
      dir.write(of, to_csv(orbit_record(paper_sweep(v, kPaperClearance), point_at(up, rpm))));
      manifest[v == "restitution" ? "fig06" : "fig08"].push_back({{"file", of}, {"variant", v}, {"rpm", rpm}});
    }
  }
  // Fig. 3: contact-free orbits, simulated (not the closed form) so they share the code path.
  std::vector<orbit> free_orbits(kFig3Speeds.size());
  parallel_for(kFig3Speeds.size(), s.threads, [&](std::size_t i) {
    run_request req;
    req.params.delta = kNoContactClearance;
    req.rpm = kFig3Speeds[i];
    req.record_revs = 2;
    req.samples_per_rev = 256;
    free_orbits[i] = simulate(req);
  });
  for (const auto& o : free_orbits) {
    const std::string f = "data/orbits/fig03_" + rpm_label(o.request.rpm) + ".csv";
    dir.write(f, to_csv(to_record(o)));
    const orbit_summary sm = summarize(o);
    manifest["fig03"].push_back({{"file", f}, {"rpm", o.request.rpm}});
    numbers["fig03"].push_back({{"rpm", o.request.rpm},
                                {"peak_to_peak_x_mm", sm.peak_to_peak_x * 1e3},
                                {"peak_to_peak_y_mm", sm.peak_to_peak_y * 1e3}});
  }
  // Fig. 7: the two stiffness laws over a penetration range that shows the cubic term, and the
  // deepest penetration the 0.3 mm sweeps actually reach.
  double z_reached = 0.0;
  for (const std::string v : {"piecewise-linear", "piecewise-nonlinear"})
    for (const auto& p : branch_of(v, kPaperClearance, sweep_direction::up).points)
      z_reached = std::max(z_reached, p.summary.max_penetration);
  {
    table t;
    t.metadata = {{"generator", "rubref " + std::string(version()) + " reproduce"}, {"k1_N_m", format_number(paper.k1)}, {"k3_N_m3", format_number(paper.k3)}};
    t.columns = {"z_m", "fn_piecewise_linear_N", "fn_piecewise_nonlinear_N"};
    const auto pl = piecewise_linear::from(paper);
    const auto pnl = piecewise_nonlinear::from(paper);
    const double z_max = 0.5e-3;  // m: where k3 z^3 reaches ~1 % of k1 z
    for (int i = 0; i <= 200; ++i) {
      const double z = z_max * i / 200.0;
      t.rows.push_back({format_number(z), format_number(pl.normal_force(z, 0.0)), format_number(pnl.normal_force(z, 0.0))});
    }
    dir.write("data/fig07_normal_force.csv", to_csv(t));
    manifest["fig07"] = {{"file", "data/fig07_normal_force.csv"}, {"z_reached_mm", z_reached * 1e3}};
    numbers["fig07"] = {{"max_penetration_mm", z_reached * 1e3}, {"cubic_share_at_max_penetration", paper.k3 * z_reached * z_reached / paper.k1}};
  }
  // Fig. 8: how far apart the piecewise-linear and -nonlinear orbits are.
  for (const double rpm : kOrbitSpeeds) {
    const auto& a = point_at(branch_of("piecewise-linear", kPaperClearance, sweep_direction::up), rpm);
    const auto& b = point_at(branch_of("piecewise-nonlinear", kPaperClearance, sweep_direction::up), rpm);
    double diff = 0.0;
    for (std::size_t i = 0; i < a.samples.size(); ++i)
      diff = std::max(diff, std::hypot(a.samples[i].s[idx::x] - b.samples[i].s[idx::x], a.samples[i].s[idx::y] - b.samples[i].s[idx::y]));
    numbers["fig08"].push_back({{"rpm", rpm}, {"max_orbit_difference_nm", diff * 1e9}, {"max_radius_mm", a.summary.max_radius * 1e3}});
  }
  for (const double rpm : kOrbitSpeeds) {
    const auto& p = point_at(branch_of("restitution", kPaperClearance, sweep_direction::up), rpm);
    numbers["fig06"].push_back({{"rpm", rpm}, {"impacts_per_rev", p.summary.contact_episodes_per_rev},
                                {"whirl", p.summary.backward_whirl() ? "backward" : "forward"}, {"max_radius_mm", p.summary.max_radius * 1e3}});
  }
  // Per clearance: where the contact-free orbit reaches the stator, rub, whirl, jumps.
  for (const double delta : kClearances) {
    const auto& up = branch_of("identified", delta, sweep_direction::up);
    const auto& down = branch_of("identified", delta, sweep_direction::down);
    parameters p = paper;
    p.delta = delta;
    const auto touching = contiguous_ranges(grid, [&](double rpm) { return std::abs(unbalance_response(p, rpm_to_rad_s(rpm)).y_phasor) > delta; });
    const jump_report jr = detect_jumps(up, down, grid_settings.step_rpm);
    json c;
    c["clearance_mm"] = delta * 1e3;
    c["contact_free_orbit_reaches_stator_rpm"] = ranges_json(touching);
    c["rub_up_rpm"] = ranges_json(rub_ranges(up));
    c["rub_down_rpm"] = ranges_json(rub_ranges(down));
    c["backward_whirl_up_rpm"] = ranges_json(backward_whirl_ranges(up));
    c["backward_whirl_down_rpm"] = ranges_json(backward_whirl_ranges(down));
    c["hysteresis_bands_rpm"] = json::array();
    for (const auto& band : jr.bands) c["hysteresis_bands_rpm"].push_back({band.from_rpm, band.to_rpm});
    c["hysteresis_width_rpm"] = jr.total_width_rpm;
    c["jumps"] = json::array();
    for (const auto& j : jr.jumps)
      c["jumps"].push_back({{"sweep", to_string(j.sweep)}, {"from_rpm", j.from_rpm}, {"to_rpm", j.to_rpm},
                            {"amplitude_before_mm", j.amplitude_before * 1e3}, {"amplitude_after_mm", j.amplitude_after * 1e3}});
    for (const double rpm : kFig12Speeds) {
      const auto& pt = point_at(up, rpm);
      c["fig12"].push_back({{"rpm", rpm}, {"regime", to_string(pt.summary.regime)},
                            {"whirl", pt.summary.backward_whirl() ? "backward" : "forward"},
                            {"contacts_per_rev", pt.summary.contact_episodes_per_rev},
                            {"max_radius_mm", pt.summary.max_radius * 1e3},
                            {"forward_1x_mm", std::abs(pt.summary.forward_1x) * 1e3},
                            {"backward_1x_mm", std::abs(pt.summary.backward_1x) * 1e3}});
    }
    numbers["clearances"].push_back(c);
  }
  manifest["clearance_mm"] = kPaperClearance * 1e3;
  manifest["sweep_grid_rpm"] = {grid_settings.from_rpm, grid_settings.to_rpm, grid_settings.step_rpm};
  dir.write("data/figures.json", manifest.dump(2) + "\n");
  numbers["settings"] = json::object();
  for (const auto& [k, v] : sweep_metadata(grid_settings)) numbers["settings"][k] = v;
  s.progress("      done in " + since(t0));

  // 3. The report: every number in it comes from `numbers`.
  s.progress("[4/5] report.md ...");
  {
    const json& c3 = numbers["clearances"][1];
    const auto list = [](const json& ranges) {
      speed_ranges r;
      for (const auto& x : ranges) r.emplace_back(x[0].get<double>(), x[1].get<double>());
      return range_text(r);
    };
    std::ostringstream md;
    md << "# rubref reproduces the paper\n\n"
       << "Generated by `rubref reproduce` (" << numbers["generator"].get<std::string>() << ", commit "
       << numbers["commit"].get<std::string>() << ") with the paper's parameters (§3, Table 2, μ = 0.24, r = 0.86). "
       << "Quasi-static sweeps " << fixed(grid_settings.from_rpm, 0) << "–" << fixed(grid_settings.to_rpm, 0) << " rpm in "
       << fixed(grid_settings.step_rpm, 0) << " rpm steps with continuation; per speed " << grid_settings.settle_revs
       << " revolutions settle and " << grid_settings.record_revs << " are recorded at " << grid_settings.samples_per_rev
       << " samples per revolution; " << to_string(grid_settings.integration.stepper.kind) << " at rtol "
       << format_number(grid_settings.integration.stepper.rtol) << " with located contact events. "
       << "Nothing is tuned: where rubref and the paper differ, the difference is reported.\n\n";

    md << "## Paper vs rubref (identified law, Eq. 5)\n\n"
       << "| quantity | paper | rubref |\n|---|---|---|\n"
       << "| contact-free orbit reaches the stator (0.3 mm; closed form) | — | "
       << list(c3["contact_free_orbit_reaches_stator_rpm"]) << " |\n"
       << "| partial rub, run-up (0.3 mm) | about 1550–1700 rpm (§6) | " << list(c3["rub_up_rpm"]) << " |\n"
       << "| partial rub, run-down (0.3 mm) | — | " << list(c3["rub_down_rpm"]) << " |\n"
       << "| backward whirl dominates, run-up (Fig. 11) | 1550–1670 rpm | " << list(c3["backward_whirl_up_rpm"]) << " |\n"
       << "| backward whirl dominates, run-down | — | " << list(c3["backward_whirl_down_rpm"]) << " |\n"
       << "| forward whirl again | at 1700 rpm, where rub ends | ";
    {
      // First speed above the run-up's first backward range where the run-up whirls forward.
      const auto& up = branch_of("identified", kPaperClearance, sweep_direction::up);
      const auto bw = backward_whirl_ranges(up);
      std::string again = "not within the sweep";
      if (!bw.empty())
        for (const auto& p : up.points)
          if (p.rpm > bw.front().second && !p.summary.backward_whirl()) {
            again = "run-up: at " + fixed(p.rpm, 0) + " rpm";
            break;
          }
      const auto& down = branch_of("identified", kPaperClearance, sweep_direction::down);
      const auto bwd = backward_whirl_ranges(down);
      if (!bwd.empty()) again += "; run-down: forward above " + fixed(bwd.back().second, 0) + " rpm";
      md << again << " |\n";
    }
    md << "| jump (Fig. 10) | shown, speeds not given | ";
    {
      std::string j;
      for (const auto& jp : c3["jumps"])
        j += (j.empty() ? "" : "; ") + jp["sweep"].get<std::string>() + " sweep jumps between " + fixed(jp["from_rpm"].get<double>(), 0) +
             " and " + fixed(jp["to_rpm"].get<double>(), 0) + " rpm (max radius " + fixed(jp["amplitude_before_mm"].get<double>(), 3) +
             " → " + fixed(jp["amplitude_after_mm"].get<double>(), 3) + " mm)";
      md << (j.empty() ? "no jump: both sweeps agree everywhere" : j) << "; hysteresis " << list(c3["hysteresis_bands_rpm"]) << " |\n\n";
    }

    md << "## Orbit shapes per clearance (Fig. 12, run-up)\n\n| clearance | speed | regime | whirl | contacts/rev | max radius | forward 1X | backward 1X |\n|---|---|---|---|---|---|---|---|\n";
    for (const auto& c : numbers["clearances"])
      for (const auto& r : c["fig12"])
        md << "| " << fixed(c["clearance_mm"].get<double>(), 1) << " mm | " << fixed(r["rpm"].get<double>(), 0) << " rpm | "
           << r["regime"].get<std::string>() << " | " << r["whirl"].get<std::string>() << " | "
           << fixed(r["contacts_per_rev"].get<double>(), 2) << " | " << fixed(r["max_radius_mm"].get<double>(), 3) << " mm | "
           << fixed(r["forward_1x_mm"].get<double>(), 3) << " mm | " << fixed(r["backward_1x_mm"].get<double>(), 3) << " mm |\n";
    md << "\n| clearance | contact-free orbit reaches stator | rub (run-up) | backward whirl (run-up) | hysteresis |\n|---|---|---|---|---|\n";
    for (const auto& c : numbers["clearances"])
      md << "| " << fixed(c["clearance_mm"].get<double>(), 1) << " mm | " << list(c["contact_free_orbit_reaches_stator_rpm"]) << " | "
         << list(c["rub_up_rpm"]) << " | " << list(c["backward_whirl_up_rpm"]) << " | " << list(c["hysteresis_bands_rpm"]) << " |\n";

    md << "\n## The other contact laws (0.3 mm, run-up)\n\n"
       << "- Fig. 6, restitution r = 0.86: ";
    for (const auto& r : numbers["fig06"])
      md << fixed(r["rpm"].get<double>(), 0) << " rpm: " << fixed(r["impacts_per_rev"].get<double>(), 2) << " impacts/rev, "
         << r["whirl"].get<std::string>() << "; ";
    md << "\n- Fig. 7: the deepest penetration of either piecewise law in the sweep is "
       << fixed(numbers["fig07"]["max_penetration_mm"].get<double>() * 1e3, 1) << " µm, where k3 z³ is "
       << fixed(100.0 * numbers["fig07"]["cubic_share_at_max_penetration"].get<double>(), 4) << " % of k1 z.\n"
       << "- Fig. 8: largest distance between the piecewise-linear and piecewise-nonlinear orbits: ";
    for (const auto& r : numbers["fig08"])
      md << fixed(r["rpm"].get<double>(), 0) << " rpm: " << fixed(r["max_orbit_difference_nm"].get<double>(), 2) << " nm; ";
    md << "(the paper: \"hardly to find the large difference between them\").\n";

    // Whether the run-up keeps whirling backward past the paper's 1700 rpm decides the second point.
    const auto bw_up = backward_whirl_ranges(branch_of("identified", kPaperClearance, sweep_direction::up));
    constexpr double kPaperForwardAgainRpm = 1700.0;
    const bool backward_beyond = !bw_up.empty() && bw_up.back().second >= kPaperForwardAgainRpm;
    const std::string backward_text =
        backward_beyond
            ? "2. **Backward whirl persists on the run-up.** It dominates over " + range_text(bw_up) +
                  ", past the paper's 1700 rpm: the run-up stays on a rubbing, backward-whirling branch, while the "
                  "run-down starts on the contact-free orbit and keeps it until that orbit reaches the stator. Eq. 2 "
                  "makes friction f_x = +μ f_N push the rotor's top towards +x at every contact, which feeds backward "
                  "whirl, and nothing in the model removes it once established. The experiment most likely left that "
                  "branch through effects the model lacks (stator compliance, friction that falls with slip speed, "
                  "disturbances).\n"
            : "2. **Backward whirl** dominates on the run-up over " + range_text(bw_up) +
                  " (paper: 1550–1670 rpm); the difference at the ends of the range follows from point 1.\n";
    md << "\n## Identification (§4) from rubref's own records\n\n"
       << "Records of the identified law at 0.3 mm, " << fixed(kIdentifyFromRpm, 0) << "–" << fixed(kIdentifyToRpm, 0) << " rpm every "
       << fixed(kIdentifyStepRpm, 0) << " rpm, " << kIdentifySamplesPerRev << " samples per revolution, no noise, linear part known "
       << "(`rubref identify --linear`). FROLS with the paper's library (Eq. 4, L = 4), ρ = 0.01, 1 % threshold.\n\n"
       << "**Table 1 — ERR of each term.** rubref's FROLS ranks the terms by ERR; the paper's ranking puts z³ first. "
       << "\"alone\" is each term's ERR as the only regressor; \"paper's order\" recomputes ERR taking the terms in the paper's ranking.\n\n"
       << "| term | paper | rubref (FROLS order, step) | rubref alone | rubref in the paper's order |\n|---|---|---|---|---|\n";
    {
      std::map<std::string, std::pair<double, int>> frols_err;
      int step = 0;
      for (const auto& st : ident["frols"]["order"]) frols_err[st["term"].get<std::string>()] = {st["err"].get<double>(), ++step};
      for (const auto& [term, paper_err] : kPaperTable1) {
        const auto& [err, at] = frols_err[term];
        md << "| " << term << " | " << fixed(paper_err, 5) << " | " << sig(err) << " (" << at << ") | "
           << fixed(ident["frols"]["first_step_err"][term].get<double>(), 5) << " | "
           << (ident["frols"].contains("paper_order_err") ? fixed(ident["frols"]["paper_order_err"][term].get<double>(), 5) : "—") << " |\n";
      }
    }
    md << "\n**Table 2 — estimates.**\n\n| term | paper | rubref (FROLS) | standard error | output error (NLopt) |\n|---|---|---|---|---|\n";
    {
      const std::map<std::string, std::pair<std::string, double>> paper_t2{{"z1", {"k1", 3.946e6}}, {"z3", {"k3", 1.408e11}}, {"zd2", {"c2", 3.720e4}}};
      for (const auto& [term, named] : paper_t2) {
        std::string est = "not selected", se = "—", oe = "—";
        for (const auto& e : ident["estimates"])
          if (e["term"] == term) {
            est = sig(e["value"].get<double>(), 6);
            se = sig(e["standard_error"].get<double>(), 2);
          }
        if (ident.contains("reidentification"))
          for (const auto& p : ident["reidentification"]["parameters"])
            if (p["name"] == named.first) oe = sig(p["value"].get<double>(), 6) + (p["identifiable"].get<bool>() ? "" : " (not identifiable)");
        md << "| " << named.first << " (" << term << ") | " << sig(named.second) << " | " << est << " | " << se << " | " << oe << " |\n";
      }
      md << "| μ | 0.24 | " << fixed(ident["mu_mean"].get<double>(), 4) << " (Fig. 5) | — | ";
      std::string mu_oe = "—";
      if (ident.contains("reidentification"))
        for (const auto& p : ident["reidentification"]["parameters"])
          if (p["name"] == "mu") mu_oe = fixed(p["value"].get<double>(), 4);
      md << mu_oe << " |\n\n";
    }
    md << "**Share of the peak contact force carried by each term of Table 2's law** (the identifiability question):\n\n"
       << "| speed | max penetration | k1 z | k3 z³ | c2 ż² |\n|---|---|---|---|---|\n";
    for (const auto& d : ident["dwells"])
      md << "| " << fixed(d["speed_rpm"].get<double>(), 0) << " rpm | " << fixed(d["max_penetration_m"].get<double>() * 1e6, 1) << " µm | "
         << sig(d["reference_law_peak_share"]["z1"].get<double>(), 3) << " | " << sig(d["reference_law_peak_share"]["z3"].get<double>(), 3)
         << " | " << sig(d["reference_law_peak_share"]["zd2"].get<double>(), 3) << " |\n";
    md << "\nAt these penetrations k3 z³ carries a few millionths of the force, so no method can estimate k3 from such data; "
          "z³ still correlates with f_N on its own (\"alone\" above) because z³ and z are both monotone in the penetration. "
          "In the paper's order z³ therefore takes the share of variance that z would explain, which is how a Table 1 with "
          "z³ ahead of z can sit beside a Table 2 whose k3 term is negligible: ERR is a share of explained variance in a given "
          "order, not a share of the force. See docs/identification.md.\n";
    md << "\n## Where rubref differs from the paper, and the most likely reasons\n\n"
       << "1. **Rub range.** With the §3 parameters the contact-free unbalance orbit (closed form) already reaches 0.3 mm over "
       << list(c3["contact_free_orbit_reaches_stator_rpm"])
       << ", so partial rub cannot be avoided anywhere in that band, which is wider than the paper's 1550–1700 rpm. "
          "The rig's unbalance or clearance most likely differed from the nominal values used here (e and δ enter the "
          "rub range directly; the paper identified e, c and k in separate experiments).\n"
       << backward_text
       << "3. **Eq. 5's c2 ż² term** is not dissipative (docs/model.md); the identified law still gives orbits close to the "
          "piecewise laws because k1 dominates at the penetrations reached.\n\n";

    md << "## Figures\n\n";
    const std::vector<std::pair<std::string, std::string>> figs{
        {"fig03_orbits_no_rub", "Fig. 3 — orbits without rub: horizontal ellipse, vertical ellipse, circle"},
        {"fig05_friction", "Fig. 5 — friction coefficient f_x / f_N per speed, identified from rubref's own record"},
        {"fig06_restitution_orbits", "Fig. 6 — coefficient of restitution r = 0.86, 0.3 mm"},
        {"fig07_normal_force", "Fig. 7 — normal force vs penetration, piecewise-linear and piecewise-nonlinear"},
        {"fig08_piecewise_orbits", "Fig. 8 — orbits of the piecewise-linear and piecewise-nonlinear laws, 0.3 mm"},
        {"fig09_waterfall", "Fig. 9 — waterfall (full spectrum vs speed), identified law, 0.3 mm, run-up"},
        {"fig10_jump", "Fig. 10 — jump: orbit amplitude vs speed, run-up and run-down"},
        {"fig11_directional_spectrum", "Fig. 11 — forward and backward 1X vs speed"},
        {"fig12_clearances", "Fig. 12 — orbits at 0.2, 0.3 and 0.4 mm, 1550–1670 rpm, run-up"}};
    for (const auto& [file, caption] : figs) md << "### " << caption << "\n\n![" << caption << "](" << file << ".png)\n\n";
    md << "Data behind every figure: `data/` (record and table formats: docs/data-format.md); the numbers above: `reproduce.json`.\n";
    dir.write("report.md", md.str());
    dir.write("reproduce.json", numbers.dump(2) + "\n");
  }

  // 4. Figures.
  if (s.figures) {
    s.progress("[5/5] figures (matplotlib) ...");
    t0 = std::chrono::steady_clock::now();
    run_plot_script(s, dir.path());
    s.progress("      done in " + since(t0));
  } else {
    s.progress("[5/5] figures skipped");
  }
  dir.commit();
  s.progress("reproduce finished in " + since(t_start) + ": " + (dir.target() / "report.md").string());
}

}  // namespace rubref
