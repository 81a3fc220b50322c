#include "ref/cli/options.hpp"

#include "ref/parameter_io.hpp"
#include "variants/all_variants.hpp"

namespace rubref::cli {

std::string variant_names() {
  std::string out;
  for_each_variant([&](auto law) {
    if (!out.empty()) out += ", ";
    out += decltype(law)::name;
  });
  return out;
}

void parameter_options::add_to(CLI::App& app) {
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

parameters parameter_options::resolve() const {
  parameters p;
  if (!file_.empty()) apply_parameter_file(p, file_);
  for (std::size_t i = 0; i < parameter_table.size(); ++i)
    if (options_[i]->count() > 0) p.*parameter_table[i].member = values_[i];
  return p;
}

void integration_cli::add_to(CLI::App& app) {
  const char* group = "Integration";
  app.add_option("--stepper", stepper_, "rk4 (fixed dt), dopri5, rkf78, bulirsch-stoer")->capture_default_str()->group(group);
  app.add_option("--rtol", opt_.stepper.rtol, "relative tolerance of adaptive steppers [-]")->capture_default_str()->group(group);
  app.add_option("--atol", opt_.stepper.atol, "absolute tolerance of adaptive steppers [m, m/s]")->capture_default_str()->group(group);
  app.add_option("--dt", opt_.stepper.dt, "rk4 step [s]; 0: period/1024")->capture_default_str()->group(group);
  app.add_option("--max-dt", opt_.stepper.max_dt, "largest adaptive step [s]; 0: period/16")->capture_default_str()->group(group);
  app.add_option("--event-tol", opt_.events.time_tolerance, "event location bracket [s]")->capture_default_str()->group(group);
  app.add_option("--stick-velocity", opt_.events.stick_velocity,
                 "restitution: rebound speed below which chatter ends in sticking [m/s]")
      ->capture_default_str()
      ->group(group);
}

integration_options integration_cli::resolve() const {
  integration_options out = opt_;
  out.stepper.kind = parse_stepper(stepper_);
  return out;
}

}  // namespace rubref::cli
