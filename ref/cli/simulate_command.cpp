#include <filesystem>
#include <iostream>
#include <memory>

#include "ref/analysis/orbit_io.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/run/simulate.hpp"

namespace rubref::cli {

namespace {
struct simulate_state {
  run_request req;
  parameter_options params;
  integration_cli integration;
  std::vector<double> initial;
  std::string out, summary;
  bool force = false;
};
}  // namespace

void add_simulate(CLI::App& app) {
  auto st = std::make_shared<simulate_state>();
  auto* sub = app.add_subcommand("simulate", "steady-state orbit at one speed -> record CSV + JSON summary");
  sub->add_option("--variant", st->req.variant, "contact law: " + variant_names())->capture_default_str();
  sub->add_option("--rpm", st->req.rpm, "shaft speed [rev/min]")->capture_default_str();
  sub->add_option("--revs", st->req.record_revs, "revolutions recorded")->capture_default_str();
  sub->add_option("--settle-revs", st->req.settle_revs, "revolutions integrated and discarded first")->capture_default_str();
  sub->add_option("--samples-per-rev", st->req.samples_per_rev, "output samples per revolution")->capture_default_str();
  sub->add_option("--initial", st->initial, "initial state x y vx vy at t = 0 [m m m/s m/s]; default rest")->expected(4);
  sub->add_option("--out", st->out, "record CSV to write (docs/data-format.md)")->required();
  sub->add_option("--summary", st->summary, "summary JSON to write; default: <out without .csv>.summary.json");
  sub->add_flag("--force", st->force, "replace output files rubref did not write");
  st->integration.add_to(*sub);
  st->params.add_to(*sub);
  sub->callback([st] {
    run_request req = st->req;
    req.params = st->params.resolve();
    req.integration = st->integration.resolve();
    if (!st->initial.empty()) req.initial_state = {st->initial[0], st->initial[1], st->initial[2], st->initial[3]};
    std::string summary = st->summary;
    if (summary.empty()) {
      std::filesystem::path p(st->out);
      summary = (p.extension() == ".csv" ? p.replace_extension("") : p).string() + ".summary.json";
    }
    validate(req);
    check_output_file(st->out, {st->params.file()}, st->force);  // before the work, not after it
    check_output_file(summary, {st->params.file(), st->out}, st->force);
    const orbit o = simulate(req);
    const orbit_summary s = summarize(o, summary_spectrum::one_x);  // to_json writes the 1X alone
    atomic_output files;
    files.stage(st->out, to_csv(to_record(o)));
    files.stage(summary, to_json(s, o).dump(2) + "\n");
    files.commit();
    std::cout << "wrote " << st->out << " (" << o.samples.size() << " samples) and " << summary << "\n";
    if (const std::string w = coarse_contact_warning(o.counts); !w.empty()) std::cerr << with_flags(w) << "\n";
  });
}

}  // namespace rubref::cli
