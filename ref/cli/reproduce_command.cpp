#include <iostream>
#include <memory>

#include "ref/app/reproduce.hpp"
#include "ref/base/parallel.hpp"
#include "ref/cli/commands.hpp"

namespace rubref::cli {

void add_reproduce(CLI::App& app) {
  auto st = std::make_shared<reproduce_settings>();
  auto* sub = app.add_subcommand("reproduce", "the paper's Figs. 3, 6-12 and report.md from its default parameters (the main job)");
  sub->add_option("--out", st->out, "output directory (created, or an empty one filled; replaced if an earlier rubref run made it)")->capture_default_str();
  sub->add_option("--threads", st->threads, "threads; 0: RUBREF_THREADS, else all cores (results do not depend on it)")
      ->capture_default_str()
      ->check(CLI::Range(0u, 4096u));
  // A callback, not CLI11's negated flag "!--no-figures", whose help shows "--no-figures{false}".
  sub->add_flag_callback("--no-figures", [st] { st->figures = false; }, "write data and report only, without drawing the figures");
  sub->callback([st] {
    set_default_threads(st->threads);
    reproduce_settings s = *st;
    s.progress = [](std::string_view line) { std::cout << line << std::endl; };
    reproduce(s);
  });
}

}  // namespace rubref::cli
