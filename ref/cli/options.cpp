#include "ref/cli/options.hpp"

#include <algorithm>
#include <array>
#include <iostream>
#include <sstream>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/base/setting_names.hpp"
#include "ref/cli/commands.hpp"
#include "ref/model/parameter_io.hpp"
#include "variants/all_variants.hpp"

namespace rubref::cli {

std::string with_flags(std::string_view message) {
  // A numeric setting's flag is the registry's (ref/model/settings.hpp); of the others, those
  // whose flag is not their name with dashes.
  static const std::array<std::pair<std::string_view, std::string_view>, 2> renamed{{{"probe_angles", "--probe-angle"}, {"effects", "--effect"}}};
  return spell_settings(message, [](std::string_view field) {
    if (const setting_info* row = setting_with_name(field)) return "--" + std::string(row->flag);
    for (const auto& [name, flag] : renamed)
      if (name == field) return std::string(flag);
    std::string flag = "--" + std::string(field);
    std::replace(flag.begin(), flag.end(), '_', '-');
    return flag;
  });
}

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
                                     describe(info.row->range))
                      ->capture_default_str()
                      ->group("Model parameters (SI units; paper defaults)");
  }
}

parameters parameter_options::resolve() const {
  parameters p;
  if (!file_.empty()) apply_parameter_file(p, file_);
  for (std::size_t i = 0; i < parameter_table.size(); ++i)
    if (options_[i]->count() > 0) p.*parameter_table[i].member = values_[i];
  for (const auto& w : unit_warnings(p)) std::cerr << "warning: " << w << "\n";
  return p;
}

namespace {
template <class T>
CLI::Option* add_registry_option(CLI::App& app, T& value, setting_key key) {
  const setting_info& s = *key.row;
  const std::string unit = s.unit == "-" ? std::string() : " [" + std::string(s.unit) + "]";
  return app.add_option("--" + std::string(s.flag), value, std::string(s.description) + unit)->capture_default_str();
}
}  // namespace

CLI::Option* add_setting(CLI::App& app, double& value, setting_key key) { return add_registry_option(app, value, key); }
CLI::Option* add_setting(CLI::App& app, int& value, setting_key key) { return add_registry_option(app, value, key); }

void integration_cli::add_to(CLI::App& app) {
  const char* group = "Integration";
  app.add_option("--stepper", stepper_, "rk4 (fixed dt), dopri5, rkf78, bulirsch-stoer")->capture_default_str()->group(group);
  // Flag, help and unit from the registry (ref/model/settings.hpp): the command line only spells them.
  const auto add = [&](double& value, setting_key key) {
    const setting_info& s = *key.row;
    app.add_option("--" + std::string(s.flag), value, std::string(s.description) + " [" + std::string(s.unit) + "]")->capture_default_str()->group(group);
  };
  add(opt_.stepper.rtol, {"integration", "rtol"});
  add(opt_.stepper.atol, {"integration", "atol"});
  add(opt_.stepper.dt, {"integration", "dt"});
  add(opt_.stepper.max_dt, {"integration", "max_dt"});
  add(opt_.events.time_tolerance, {"integration", "event_tol"});
  add(opt_.events.stick_time, {"integration", "stick_time"});
}

integration_options integration_cli::resolve() const {
  integration_options out = opt_;
  out.stepper.kind = parse_stepper(stepper_);
  return out;
}

void add_threads_option(CLI::App& app) {
  app.add_option_function<unsigned>("--threads", [](const unsigned& n) { set_default_threads(n); },
                                    "threads for independent tasks; 0: RUBREF_THREADS, else all cores (results do not depend on it)")
      ->check(CLI::Range(0u, 4096u));
}

std::string suggestion(CLI::App& app, const CLI::ParseError& e) {
  // CLI11 names the unexpected arguments after the message's last ": " (ExtrasError) or the
  // first unknown subcommand; the candidates are the subcommands, or the active one's options.
  std::vector<std::string> words;
  if (app.get_subcommands().empty()) {
    words = app.remaining();  // "A subcommand is required": the mistyped one is left over
  } else {
    const std::string msg = e.what();
    const auto colon = msg.rfind(": ");
    if (colon == std::string::npos) return {};
    std::istringstream rest(msg.substr(colon + 2));
    for (std::string w; rest >> w;) words.push_back(w);
  }
  if (words.empty()) return {};
  const auto active = app.get_subcommands();
  // With no command recognised, the mistyped command is the first word that is not an option
  // (`rubref simluate --out a.csv`); else the first option is the mistyped one.
  std::string word = words.front();
  for (const auto& w : words)
    if (active.empty() ? w.rfind("-", 0) != 0 : w.rfind("-", 0) == 0) {
      word = w.substr(0, w.find('='));
      break;
    }
  std::vector<std::string> names;
  if (active.empty() || word.rfind("-", 0) != 0) {
    for (const CLI::App* sub : app.get_subcommands({})) names.push_back(sub->get_name());
  } else {
    for (const CLI::Option* o : active.back()->get_options())
      for (const auto& l : o->get_lnames()) names.push_back("--" + l);
  }
  return did_you_mean(word, names);
}

}  // namespace rubref::cli
