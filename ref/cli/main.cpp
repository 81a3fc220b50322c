// rubref command line. Each subcommand validates all of its input before it integrates, and
// writes its outputs atomically: a failure prints one line "rubref: error: ..." and exits non-zero
// (2: bad input, 3: numerical failure) with no output touched. `validate` exits 1 when a candidate
// fails its case.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <functional>
#include <iostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ref/app/python_script.hpp"
#include "ref/app/study_mpi.hpp"
#include "ref/base/errors.hpp"
#include "ref/base/interrupt.hpp"
#include "ref/base/parallel.hpp"
#include "ref/base/version.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/model/parameter_io.hpp"
#include "variants/all_variants.hpp"

int main(int argc, char** argv) {
  using namespace rubref;
  try {
    study::hand_over_to_mpi_engine(argv);  // under mpirun: rubref-mpi (ref/app/study_mpi.hpp)
  } catch (const input_error& e) {
    std::cerr << "rubref: error: " << e.what() << "\n";
    return 2;
  }
  CLI::App app{"rubref " + std::string(version()) +
                   ": numerical reference for partial rotor-stator rub (anisotropic Jeffcott rotor, Eq. 1-6)",
               "rubref"};
  app.require_subcommand(1);
  // The version, and where the figures' scripts are found (an installed rubref: next to it).
  app.set_version_flag("--version", std::function<std::string()>([] {
    std::string scripts;
    try {
      scripts = script_path("plot_figures.py").parent_path().string();
    } catch (const input_error& e) {
      scripts = e.what();
    }
    return "rubref " + std::string(version()) + " (" + std::string(commit()) + ")\nplot scripts: " + scripts;
  }));

  // Every command and what adds it (rig adds `effects` too, study `study-merge`). A command line
  // that names one builds only that one: CLI11 builds options eagerly, and all of them cost about
  // a millisecond of start (docs/performance.md, "Process start"). Anything else (help, --version,
  // a mistyped command, which the suggestion needs every name for) builds them all.
  int exit_status = 0;
  const std::vector<std::pair<std::vector<std::string_view>, std::function<void()>>> commands{
      {{"reproduce"}, [&] { cli::add_reproduce(app); }},
      {{"simulate"}, [&] { cli::add_simulate(app); }},
      {{"orbit"}, [&] { cli::add_orbit(app); }},
      {{"continuation"}, [&] { cli::add_continuation(app); }},
      {{"sweep"}, [&] { cli::add_sweep(app); }},
      {{"identify"}, [&] { cli::add_identify(app); }},
      {{"rig", "effects"}, [&] { cli::add_rig(app); }},
      {{"loop"}, [&] { cli::add_loop(app); }},
      {{"study", "study-merge"}, [&] { cli::add_study(app); }},
      {{"validate"}, [&] { cli::add_validate(app, exit_status); }},
      {{"params"},
       [&] {
         app.add_subcommand("params", "print the paper's default parameters as a JSON parameter file")->callback([] {
           std::cout << to_json(parameters{}).dump(2) << "\n";
         });
       }},
      {{"variants"},
       [&] {
         app.add_subcommand("variants", "list the contact laws")->callback([] {
           for_each_variant([](auto law) { std::cout << decltype(law)::name << ": " << decltype(law)::equation << "\n"; });
         });
       }},
  };
  const auto named = [&](const std::vector<std::string_view>& names) {
    return argc > 1 && std::find(names.begin(), names.end(), std::string_view(argv[1])) != names.end();
  };
  const auto chosen = std::find_if(commands.begin(), commands.end(), [&](const auto& c) { return named(c.first); });
  if (chosen != commands.end())
    chosen->second();
  else if (!(argc == 2 && std::string_view(argv[1]) == "--version"))
    for (const auto& c : commands) c.second();
  // Ctrl-C removes a command's partial outputs (ref/base/interrupt.hpp; before any thread starts).
  // Help, the version, params and variants write none, and start faster without its thread.
  if (chosen != commands.end() && !named({"params", "variants"})) install_interrupt_cleanup();

  if (argc == 1) {  // bare `rubref`: what it can do
    std::cout << app.help();
    return 0;
  }
  try {
    threads_from_environment();  // a bad RUBREF_THREADS is bad input before any work
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // A mistyped command: CLI11 says "A subcommand is required"; name the word it did not know.
    std::string what = e.what();
    if (const auto rest = app.remaining(); app.get_subcommands().empty() && !rest.empty() && rest.front().rfind("-", 0) != 0)
      what = "unknown command '" + one_line(rest.front()) + "'";
    std::cerr << "rubref: error: " << what << cli::suggestion(app, e) << "\n";
    return 2;
  } catch (const input_error& e) {
    std::cerr << "rubref: error: " << cli::with_flags(e.what()) << "\n";
    return 2;
  } catch (const numerical_error& e) {
    std::cerr << "rubref: numerical failure: " << cli::with_flags(e.what()) << "\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "rubref: error: " << e.what() << "\n";
    return 4;
  }
  return exit_status;
}
