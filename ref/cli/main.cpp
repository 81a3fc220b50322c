// rubref command line. Each subcommand validates all of its input before it integrates, and
// writes its outputs atomically: a failure prints one line "rubref: error: ..." and exits non-zero
// (2: bad input, 3: numerical failure) with no output touched. `validate` exits 1 when a candidate
// fails its case.

#include <CLI/CLI.hpp>
#include <functional>
#include <iostream>

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
  install_interrupt_cleanup();  // before any thread starts (ref/base/interrupt.hpp)
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

  cli::add_reproduce(app);
  cli::add_simulate(app);
  cli::add_orbit(app);
  cli::add_continuation(app);
  cli::add_sweep(app);
  cli::add_identify(app);
  cli::add_rig(app);
  cli::add_loop(app);
  cli::add_study(app);
  int exit_status = 0;
  cli::add_validate(app, exit_status);
  app.add_subcommand("params", "print the paper's default parameters as a JSON parameter file")->callback([] {
    std::cout << to_json(parameters{}).dump(2) << "\n";
  });
  app.add_subcommand("variants", "list the contact laws")->callback([] {
    for_each_variant([](auto law) { std::cout << decltype(law)::name << ": " << decltype(law)::equation << "\n"; });
  });

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
    std::cerr << "rubref: error: " << e.what() << cli::suggestion(app, e) << "\n";
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
