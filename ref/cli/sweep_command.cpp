#include <iostream>
#include <memory>

#include "ref/analysis/orbit_io.hpp"
#include "ref/base/parallel.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/sweep/sweep_io.hpp"

namespace rubref::cli {

namespace {
struct sweep_state {
  sweep_settings settings;
  parameter_options params;
  integration_cli integration;
  std::string direction = "both";
  unsigned threads = 0;
  bool orbits = false;
  std::string out;
};

}  // namespace

void add_sweep(CLI::App& app) {
  auto st = std::make_shared<sweep_state>();
  auto& s = st->settings;
  auto* sub = app.add_subcommand("sweep", "quasi-static run-up / run-down with continuation -> tables, waterfall, jumps");
  sub->add_option("--variant", s.variant, "contact law: " + variant_names())->capture_default_str();
  sub->add_option("--from", s.from_rpm, "lowest speed [rev/min]")->capture_default_str();
  sub->add_option("--to", s.to_rpm, "highest speed [rev/min]")->capture_default_str();
  sub->add_option("--step", s.step_rpm, "speed step [rev/min]")->capture_default_str();
  sub->add_option("--direction", st->direction, "up, down or both")->check(CLI::IsMember({"up", "down", "both"}))->capture_default_str();
  sub->add_option("--first-settle-revs", s.first_settle_revs, "revolutions settled at the first speed")->capture_default_str();
  sub->add_option("--settle-revs", s.settle_revs, "revolutions settled at every later speed")->capture_default_str();
  sub->add_flag("--start-from-orbit", s.start_from_orbit,
                "start each speed on the periodic orbit shot from its neighbour's state where it is stable "
                "(no settling there; docs/orbits.md)");
  sub->add_option("--revs", s.record_revs, "revolutions recorded per speed (a multiple of 6)")->capture_default_str();
  sub->add_option("--samples-per-rev", s.samples_per_rev, "samples per revolution")->capture_default_str();
  sub->add_option("--threads", st->threads, "threads for independent branches; 0: RUBREF_THREADS, else all cores")
      ->capture_default_str()
      ->check(CLI::Range(0u, 4096u));
  sub->add_flag("--orbits", st->orbits,
                "also write every recorded orbit (orbits/<direction>_<rpm>rpm.csv) and each branch as one "
                "multi-dwell measurement record (record_<direction>.csv, input for `rubref identify`)");
  sub->add_option("--out", st->out, "output directory (created, or an empty one filled; replaced if an earlier rubref run made it)")->required();
  st->integration.add_to(*sub);
  st->params.add_to(*sub);
  sub->callback([st] {
    set_default_threads(st->threads);
    sweep_settings s = st->settings;
    s.params = st->params.resolve();
    s.integration = st->integration.resolve();
    s.keep_orbits = st->orbits;
    validate(s);
    staged_directory dir(st->out);
    std::vector<branch_task> tasks;
    if (st->direction != "down") tasks.push_back({s, sweep_direction::up});
    if (st->direction != "up") tasks.push_back({s, sweep_direction::down});
    std::cout << "sweep " << s.variant << " " << s.from_rpm << " -> " << s.to_rpm << " rpm, step " << s.step_rpm
              << " rpm, " << st->direction << " ..." << std::flush;
    const auto branches = run_branches(tasks, st->threads);
    std::cout << " done\n";
    dir.write("sweep.csv", to_csv(sweep_table(s, branches)));
    for (const auto& b : branches) {
      dir.write("waterfall_" + std::string(to_string(b.direction)) + ".csv", to_csv(waterfall_table(s, b)));
      if (st->orbits) dir.write("record_" + std::string(to_string(b.direction)) + ".csv", to_csv(dwell_record(s, b)));
      if (st->orbits)
        for (const auto& p : b.points)
          dir.write("orbits/" + std::string(to_string(b.direction)) + "_" + format_number(p.rpm) + "rpm.csv",
                    to_csv(orbit_record(s, p)));
    }
    dir.write("summary.json", sweep_summary_json(s, branches).dump(2) + "\n");
    dir.commit();
    std::cout << "wrote " << dir.target().string() << "/{sweep.csv, waterfall_*.csv, summary.json}\n";
    for (const auto& b : branches)
      if (const std::string w = coarse_contact_warning(b.counts); !w.empty())
        std::cerr << to_string(b.direction) << " branch, first at " << format_number(b.first_coarse_contact_rpm) << " rpm: " << with_flags(w) << "\n";
  });
}

}  // namespace rubref::cli
