// rubref command line. Each subcommand validates all of its input before it integrates, and
// writes its outputs atomically: a failure prints one line "rubref: error: ..." and exits non-zero
// (2: bad input, 3: numerical failure) with no output file touched.

#include <CLI/CLI.hpp>
#include <array>
#include <iostream>
#include <optional>

#include "ref/atomic_output.hpp"
#include "ref/errors.hpp"
#include "ref/orbit_io.hpp"
#include "ref/parameter_io.hpp"
#include "ref/record.hpp"
#include "ref/simulate.hpp"
#include "ref/version.hpp"
#include "variants/all_variants.hpp"

namespace {

using namespace rubref;

std::string variant_names() {
  std::string out;
  for_each_variant([&](auto law) {
    if (!out.empty()) out += ", ";
    out += decltype(law)::name;
  });
  return out;
}

// --params FILE and one --<flag> per row of parameter_table; file first, flags override it.
class parameter_options {
 public:
  void add_to(CLI::App& app) {
    app.add_option("--params", file_, "JSON file of parameters (keys as in `rubref params`)")->check(CLI::ExistingFile);
    const parameters defaults;
    for (std::size_t i = 0; i < parameter_table.size(); ++i) {
      const auto& info = parameter_table[i];
      values_[i] = defaults.*info.member;
      options_[i] = app.add_option("--" + std::string(info.flag), values_[i],
                                   std::string(info.description) + " [" + std::string(info.unit) + "], " +
                                       std::string(describe(info.rule)))
                        ->capture_default_str()
                        ->group("Model parameters (SI units; paper defaults)");
    }
  }
  parameters resolve() const {
    parameters p;
    if (!file_.empty()) apply_parameter_file(p, file_);
    for (std::size_t i = 0; i < parameter_table.size(); ++i)
      if (options_[i]->count() > 0) p.*parameter_table[i].member = values_[i];
    return p;
  }

 private:
  std::string file_;
  std::array<double, parameter_table.size()> values_{};
  std::array<CLI::Option*, parameter_table.size()> options_{};
};

struct simulate_command {
  run_request req;
  parameter_options params;
  std::string stepper = "dopri5";
  std::vector<double> initial;
  std::string out, summary;

  void add_to(CLI::App& app) {
    auto* sub = app.add_subcommand("simulate", "steady-state orbit at one speed -> record CSV + JSON summary");
    sub->add_option("--variant", req.variant, "contact law: " + variant_names())->capture_default_str();
    sub->add_option("--rpm", req.rpm, "shaft speed [rev/min]")->capture_default_str();
    sub->add_option("--revs", req.record_revs, "revolutions recorded")->capture_default_str();
    sub->add_option("--settle-revs", req.settle_revs, "revolutions integrated and discarded first")->capture_default_str();
    sub->add_option("--samples-per-rev", req.samples_per_rev, "output samples per revolution")->capture_default_str();
    sub->add_option("--stepper", stepper, "rk4 (fixed dt), dopri5, rkf78, bulirsch-stoer")->capture_default_str();
    sub->add_option("--rtol", req.integration.stepper.rtol, "relative tolerance of adaptive steppers [-]")->capture_default_str();
    sub->add_option("--atol", req.integration.stepper.atol, "absolute tolerance of adaptive steppers [m, m/s]")->capture_default_str();
    sub->add_option("--dt", req.integration.stepper.dt, "rk4 step [s]; 0: period/1024")->capture_default_str();
    sub->add_option("--max-dt", req.integration.stepper.max_dt, "largest adaptive step [s]; 0: period/16")->capture_default_str();
    sub->add_option("--event-tol", req.integration.events.time_tolerance, "event location bracket [s]")->capture_default_str();
    sub->add_option("--stick-velocity", req.integration.events.stick_velocity,
                    "restitution: rebound speed below which chatter ends in sticking [m/s]")->capture_default_str();
    sub->add_option("--initial", initial, "initial state x y vx vy at t = 0 [m m m/s m/s]; default rest")->expected(4);
    sub->add_option("--out", out, "record CSV to write (docs/data-format.md)")->required();
    sub->add_option("--summary", summary, "summary JSON to write; default: <out without .csv>.summary.json");
    params.add_to(*sub);
    sub->callback([this] { run(); });
  }

  void run() {
    req.params = params.resolve();
    req.integration.stepper.kind = parse_stepper(stepper);
    if (!initial.empty()) req.initial_state = {initial[0], initial[1], initial[2], initial[3]};
    if (summary.empty()) {
      std::filesystem::path p(out);
      summary = (p.extension() == ".csv" ? p.replace_extension("") : p).string() + ".summary.json";
    }
    const orbit o = simulate(req);
    const orbit_summary s = summarize(o);
    atomic_output files;
    files.stage(out, to_csv(to_record(o)));
    files.stage(summary, to_json(s, o).dump(2) + "\n");
    files.commit();
    std::cout << "wrote " << out << " (" << o.samples.size() << " samples) and " << summary << "\n";
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"rubref " + std::string(version()) +
               ": numerical reference for partial rotor-stator rub (anisotropic Jeffcott rotor, Eq. 1-6)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "rubref " + std::string(version()) + " (" + std::string(commit()) + ")");

  simulate_command simulate_cmd;
  simulate_cmd.add_to(app);

  app.add_subcommand("params", "print the paper's default parameters as a JSON parameter file")->callback([] {
    std::cout << to_json(parameters{}).dump(2) << "\n";
  });
  app.add_subcommand("variants", "list the contact laws")->callback([] {
    for_each_variant([](auto law) {
      std::cout << decltype(law)::name << ": " << decltype(law)::equation << "\n";
    });
  });

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << "rubref: error: " << e.what() << "\n";
    return 2;
  } catch (const rubref::input_error& e) {
    std::cerr << "rubref: error: " << e.what() << "\n";
    return 2;
  } catch (const rubref::numerical_error& e) {
    std::cerr << "rubref: numerical failure: " << e.what() << "\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "rubref: error: " << e.what() << "\n";
    return 4;
  }
  return 0;
}
