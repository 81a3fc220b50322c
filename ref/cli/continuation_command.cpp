#include <algorithm>
#include <iostream>
#include <memory>

#include "ref/base/errors.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/format/record.hpp"
#include "ref/format/table.hpp"
#include "ref/orbits/continuation.hpp"
#include "ref/orbits/continuation_io.hpp"

namespace rubref::cli {

namespace {
struct continuation_state {
  continuation_request req;
  parameter_options params;
  integration_cli integration;
  std::string parameter = "speed";
  std::string direction = "up";
  std::string out;
};

}  // namespace

void add_continuation(CLI::App& app) {
  auto st = std::make_shared<continuation_state>();
  auto& r = st->req;
  auto* sub = app.add_subcommand("continuation", "a branch of periodic orbits by pseudo-arclength continuation with Floquet "
                                                 "stability, folds (jumps), grazings, period doublings -> branch.csv, summary.json");
  sub->add_option("--variant", r.variant, "contact law: " + variant_names())->capture_default_str();
  sub->add_option("--parameter", st->parameter, "continuation parameter: speed [rpm], clearance [m], unbalance [m] or mu")
      ->capture_default_str();
  sub->add_option("--from", r.from, "start of the range (the parameter's unit)")->capture_default_str();
  sub->add_option("--to", r.to, "end of the range")->capture_default_str();
  sub->add_option("--direction", st->direction, "up: trace from --from to --to; down: from --to to --from")
      ->capture_default_str()
      ->check(CLI::IsMember({"up", "down"}));
  sub->add_option("--rpm", r.rpm, "shaft speed when the parameter is not the speed [rev/min]")->capture_default_str();
  sub->add_option("--periods", r.periods, "revolutions per period of the orbits followed")->capture_default_str();
  sub->add_option("--samples-per-rev", r.samples_per_rev, "samples per revolution of each point's recorded period")->capture_default_str();
  sub->add_option("--max-step", r.max_step, "largest arclength step (1 spans the range)")->capture_default_str();
  sub->add_option("--max-points", r.max_points, "most points on the branch")->capture_default_str();
  sub->add_option("--tolerance", r.tolerance, "shooting tolerance |P(s) - s| [m]")->capture_default_str();
  sub->add_option("--out", st->out, "output directory (created, or an empty one filled; replaced if an earlier rubref run made it)")->required();
  st->integration.add_to(*sub);
  st->params.add_to(*sub);
  sub->callback([st, sub] {
    continuation_request req = st->req;
    req.parameter = parse_continuation_parameter(st->parameter);
    // The default range is in rpm: another parameter needs its own.
    if (req.parameter != continuation_parameter::speed && (sub->count("--from") == 0 || sub->count("--to") == 0))
      throw input_error("--parameter " + st->parameter + " needs --from and --to (in " +
                        std::string(column_name(req.parameter)) + "'s unit)");
    req.downward = st->direction == "down";
    req.params = st->params.resolve();
    req.integration = st->integration.resolve();
    req.initial_step = std::min(req.initial_step, req.max_step);
    validate(req);
    staged_directory dir(st->out);
    const continuation_result res = continue_branch(req);
    dir.write("branch.csv", to_csv(branch_table(req, res)));
    dir.write("summary.json", branch_summary_json(req, res).dump(2) + "\n");
    dir.commit();
    std::cout << "wrote " << dir.target().string() << "/{branch.csv, summary.json}: " << res.points.size() << " points, "
              << res.stopped << "\n";
    if (!res.reached_end)
      std::cerr << "warning: the branch ended before " << column_name(req.parameter) << " = "
                << format_digits(req.downward ? req.from : req.to, 10) << ": " << res.stopped << "\n";
  });
}

}  // namespace rubref::cli
