#include <iostream>
#include <memory>

#include "ref/base/errors.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/format/record.hpp"
#include "ref/identification/identify.hpp"
#include "ref/identification/identify_io.hpp"
#include "ref/model/parameter_io.hpp"

namespace rubref::cli {

namespace {
struct identify_state {
  identify_settings settings;
  std::vector<std::string> files;
  std::string linear_file, linear_method = "harmonic", law_method = "auto", averaging = "auto", stop = "err", reid_fit = "k1,k3,c2,mu", out;
};

std::vector<std::string> split_commas(const std::string& s) {
  std::vector<std::string> out;
  std::size_t pos = 0;
  while (pos <= s.size()) {
    const std::size_t comma = std::min(s.find(',', pos), s.size());
    out.push_back(s.substr(pos, comma - pos));
    pos = comma + 1;
  }
  return out;
}
}  // namespace

void add_identify(CLI::App& app) {
  auto st = std::make_shared<identify_state>();
  auto& s = st->settings;
  auto* sub = app.add_subcommand("identify", "contact law by ERR/FROLS (paper §4), friction per speed, optional NLopt re-identification");
  sub->add_option("records", st->files, "measurement records (docs/data-format.md)")->required()->check(CLI::ExistingFile);
  sub->add_option("--linear", st->linear_file, "JSON parameter file with the linear part (m, c, k, e, unbalance_phase_rad); default: fit it on dwells without contact")
      ->check(CLI::ExistingFile);
  sub->add_option("--linear-method", st->linear_method, "how the linear part is fitted: harmonic (1X balance, noise-robust) or equation-error (Savitzky-Golay derivatives)")
      ->check(CLI::IsMember({"harmonic", "equation-error"}))
      ->capture_default_str();
  sub->add_option("--law-method", st->law_method, "how the contact law is regressed: auto (from the probe noise), samples (the paper's, on second derivatives) or weak-form (integrals, noise-robust)")
      ->check(CLI::IsMember({"auto", "samples", "weak-form"}))
      ->capture_default_str();
  add_setting(*sub, s.mass, {"identify", "mass"});
  add_setting(*sub, s.clearance, {"identify", "clearance"});
  sub->add_option("--library", s.library, "candidate terms, e.g. z1..4,zd1..4,abszd1*zd1,z1.5,const")->capture_default_str();
  add_setting(*sub, s.frols.rho, {"frols", "rho"});
  add_setting(*sub, s.frols.err_threshold, {"frols", "err_threshold"});
  sub->add_option("--stop", st->stop, "stopping rule: err (rho), aic or bic")->check(CLI::IsMember({"err", "aic", "bic"}))->capture_default_str();
  add_setting(*sub, s.derivative.half_width, {"derivatives", "half_width"});
  add_setting(*sub, s.derivative.degree, {"derivatives", "degree"});
  sub->add_option("--averaging", st->averaging, "synchronous averaging of the dwells that touch: auto (each steady dwell, decided and reported per dwell), on (every dwell) or off")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
  // A callback, not CLI11's negated flag "!--no-orbit-fit", whose help shows "--no-orbit-fit{false}".
  sub->add_flag_callback("--no-orbit-fit", [st] { st->settings.orbit_fit = false; }, "report the weak form's estimates without refining them by the averaged cycles' periodic orbits");
  add_setting(*sub, s.bootstrap, {"identify", "bootstrap"});
  sub->add_flag("--reidentify", s.reidentify, "refine by output error (the least-squares solver on the simulated orbits)");
  sub->add_option("--reid-fit", st->reid_fit, "parameters to re-identify: any of k1,k3,c2,mu,e,clearance")->capture_default_str();
  sub->add_flag("--global", s.reid.global, "NLopt DIRECT-L global stage for the re-identification's start");
  sub->add_option("--out", st->out, "output directory: identification.json, identification.md")->required();
  add_threads_option(*sub);
  sub->callback([st] {
    identify_settings s = st->settings;
    s.frols.stop = st->stop == "aic" ? frols_stop::aic : st->stop == "bic" ? frols_stop::bic : frols_stop::err_sum;
    s.validate();  // every setting by its registry row, before any file is read (the messages name the flags)
    if (!st->linear_file.empty()) {
      parameters p;
      apply_parameter_file(p, st->linear_file);
      validate(p);
      s.linear = p;
    }
    s.reid.fit = split_commas(st->reid_fit);
    s.linear_route = parse_linear_method(st->linear_method);
    s.law_route = parse_law_method(st->law_method);
    s.average = parse_averaging(st->averaging);
    staged_directory dir(st->out);
    std::vector<std::pair<record, std::string>> records;
    for (const auto& f : st->files) records.emplace_back(read_record(f), f);
    const identification id = identify(records, s);
    dir.write("identification.json", to_json(id, s).dump(2) + "\n");
    dir.write("identification.md", to_markdown(id));
    dir.commit();
    for (const auto& w : id.warnings) std::cerr << "warning: " << w << "\n";
    std::cout << "kept:";
    for (const auto& e : id.estimates) std::cout << " " << e.name << " = " << e.value;
    std::cout << "; mu = " << id.mu << " (" << to_string(id.law_route) << ")" << "\nwrote " << dir.target().string() << "/{identification.json, identification.md}\n";
  });
}

}  // namespace rubref::cli
