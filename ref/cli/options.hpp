#pragma once
// Option groups shared by the subcommands: every model parameter, and the integration settings.

#include <CLI/CLI.hpp>
#include <array>
#include <string>

#include "ref/integrate/hybrid_integrator.hpp"
#include "ref/model/parameters.hpp"
#include "ref/model/settings.hpp"

namespace rubref::cli {

std::string variant_names();  // "restitution, piecewise-linear, ..."

// A library message with its settings (`from_rpm`, `clearance`: ref/base/errors.hpp, setting)
// spelled as this command line's flags (--from, --clearance).
std::string with_flags(std::string_view message);

// --<flag> for a setting of the registry (ref/model/settings.hpp): flag, help and unit from its
// row; the library's validate() checks the value (its message names the setting, with_flags
// spells it as the flag).
CLI::Option* add_setting(CLI::App& app, double& value, setting_key key);
CLI::Option* add_setting(CLI::App& app, int& value, setting_key key);

// --params FILE and one --<flag> per row of parameter_table; the file first, flags override it.
// A length parameter of a rotor kit's implausible size gets a warning (unit_warnings).

class parameter_options {
 public:
  void add_to(CLI::App& app);
  parameters resolve() const;
  const std::string& file() const { return file_; }  // the --params file ("" when none)

 private:
  std::string file_;
  std::array<double, parameter_table.size()> values_{};
  std::array<CLI::Option*, parameter_table.size()> options_{};
};

// --threads for a command whose library calls run tasks in parallel: sets the process's default
// thread count (ref/base/parallel.hpp); 0 keeps RUBREF_THREADS, else every core.
void add_threads_option(CLI::App& app);

// --stepper, --rtol, --atol, --dt, --max-dt, --event-tol, --stick-time.
class integration_cli {
 public:
  void add_to(CLI::App& app);
  integration_options resolve() const;  // input_error on an unknown stepper

 private:
  integration_options opt_;
  std::string stepper_ = "dopri5";
};

}  // namespace rubref::cli
