#include <cmath>
#include <iostream>
#include <memory>

#include "ref/app/python_script.hpp"
#include "ref/base/errors.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/format/record.hpp"
#include "ref/loop/loop.hpp"
#include "ref/loop/report.hpp"

namespace rubref::cli {

namespace {
struct loop_state {
  loop_settings settings;
  std::vector<std::string> files;
  std::string out;
  bool figures = true;
};
}  // namespace

void add_loop(CLI::App& app) {
  auto st = std::make_shared<loop_state>();
  auto& s = st->settings;
  auto* sub = app.add_subcommand("loop", "fit the paper's model to records, trace the residual to library effects, report before/after (docs/loop.md)");
  sub->add_option("records", st->files, "measurement records (docs/data-format.md), with a keyphasor column if the rig has one")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--out", st->out, "report folder (report.json, report.md, figures)")->required();
  sub->add_option("--mass", s.mass, "rotor mass [kg]; default: the records' m_kg, else the paper's");
  sub->add_option("--clearance", s.clearance, "clearance for records without clearance_m metadata [m]");
  sub->add_option("--max-effects", s.max_effects, "trace rounds (effects added at most)")->capture_default_str()->check(CLI::Range(0, 11));
  sub->add_option("--refit", s.refit_candidates, "effects refitted per round (best scores)")->capture_default_str()->check(CLI::Range(1, 11));
  sub->add_flag("!--no-figures", st->figures, "write the report without drawing figures");
  add_threads_option(*sub);
  sub->callback([st] {
    staged_directory dir(st->out);  // the output folder is checked before the work, not after it
    std::vector<std::pair<record, std::string>> records;
    for (const auto& f : st->files) records.emplace_back(read_record(f), f);
    loop_settings settings = st->settings;
    settings.progress = [](const std::string& line) { std::cerr << line << std::endl; };
    const loop_result r = run_loop(records, settings);
    dir.write("report.json", to_json(r).dump(2) + "\n");
    dir.write("report.md", to_markdown(r));
    dir.write("plot_data.json", plot_data(r).dump() + "\n");
    if (st->figures && !r.plot_x.empty()) run_python_script(default_python(), script_path("plot_loop.py"), dir.path());
    dir.commit();
    if (std::isfinite(r.error_before))
      std::cout << "error before " << r.error_before << ", after " << r.error_after << "; effects:";
    else  // every dwell with contact was left out (the warnings above say why): nothing to score
      std::cout << "no dwell with contact was usable (see the warnings): nothing fitted; effects:";
    for (const auto& e : r.effects) std::cout << " " << e.effect;
    if (r.effects.empty()) std::cout << " none";
    if (!r.tentative.empty()) {
      std::cout << " (tentative:";
      for (const auto& e : r.tentative) std::cout << " " << e.effect;
      std::cout << ")";
    }
    std::cout << (r.claim == "partial" ? "; named, partial: " + format_digits(100.0 * std::max(0.0, 1.0 - r.explained_share), 3) +
                                             " % of the excess remains"
                  : r.unexplained ? "; residual unexplained"
                                  : "; residual is noise")
              << "\nwrote " << st->out << "/report.json, report.md\n";
  });
}

}  // namespace rubref::cli
