#include <filesystem>
#include <iostream>
#include <memory>
#include <vector>

#include "ref/analysis/orbit_io.hpp"
#include "ref/base/version.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "ref/orbits/periodic_orbit_io.hpp"

namespace rubref::cli {

namespace {
struct orbit_state {
  periodic_orbit_request req;
  parameter_options params;
  integration_cli integration;
  std::string out, summary;
  bool force = false;
  std::vector<double> initial;
};
}  // namespace

void add_orbit(CLI::App& app) {
  auto st = std::make_shared<orbit_state>();
  auto* sub = app.add_subcommand("orbit", "steady orbit by shooting (Newton on the n-revolution map) with its Floquet multipliers "
                                          "-> one period as a record CSV + JSON summary");
  sub->add_option("--variant", st->req.run.variant, "contact law: " + variant_names())->capture_default_str();
  sub->add_option("--rpm", st->req.run.rpm, "shaft speed [rev/min]")->capture_default_str();
  sub->add_option("--periods", st->req.periods, "revolutions per period (n > 1: a subharmonic orbit)")->capture_default_str();
  sub->add_option("--samples-per-rev", st->req.run.samples_per_rev, "output samples per revolution")->capture_default_str();
  sub->add_option("--tolerance", st->req.tolerance, "shooting tolerance |P(s) - s| [m]")->capture_default_str();
  sub->add_option("--out", st->out, "record CSV of one period to write (docs/data-format.md)")->required();
  sub->add_option("--initial", st->initial, "first Newton start x y vx vy at t = 0 [m m m/s m/s] (e.g. a row of "
                                            "continuation's branch.csv); default: the contact-free response")
      ->expected(4);
  sub->add_option("--summary", st->summary, "summary JSON to write; default: <out without .csv>.summary.json");
  sub->add_flag("--force", st->force, "replace output files rubref did not write");
  st->integration.add_to(*sub);
  st->params.add_to(*sub);
  sub->callback([st] {
    periodic_orbit_request req = st->req;
    req.run.params = st->params.resolve();
    req.run.integration = st->integration.resolve();
    if (!st->initial.empty()) req.initial_guess = state_type{st->initial[0], st->initial[1], st->initial[2], st->initial[3]};
    std::string summary = st->summary;
    if (summary.empty()) {
      std::filesystem::path p(st->out);
      summary = (p.extension() == ".csv" ? p.replace_extension("") : p).string() + ".summary.json";
    }
    check_output_file(st->out, {st->params.file()}, st->force);  // before the work, not after it
    check_output_file(summary, {st->params.file(), st->out}, st->force);
    const periodic_orbit_result r = find_periodic_orbit(req);
    if (!r.converged)
      std::cerr << "warning: Newton shooting did not converge (" << r.failure << "); the orbit written is the end of a "
                << req.fallback_settle_revs << "-revolution transient, with no Floquet multipliers\n";
    const record rec = periodic_orbit_record(req, r);
    const nlohmann::ordered_json j = periodic_orbit_json(req, r);
    atomic_output files;
    files.stage(st->out, to_csv(rec));
    files.stage(summary, j.dump(2) + "\n");
    files.commit();
    std::cout << "wrote " << st->out << " (" << r.samples.samples.size() << " samples, " << r.method;
    if (r.converged) std::cout << ", " << (r.stable ? "stable" : "unstable") << ", max |Floquet multiplier| " << r.max_multiplier_modulus;
    std::cout << ") and " << summary << "\n";
  });
}

}  // namespace rubref::cli
