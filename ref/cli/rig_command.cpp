#include <filesystem>
#include <iostream>
#include <memory>

#include "ref/base/errors.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/rig/rig.hpp"

namespace rubref::cli {

namespace {
struct rig_state {
  rig_request req;
  parameter_options params;
  integration_cli integration;
  std::vector<std::string> effects;
  std::string out, truth, time_base;
  bool no_keyphasor = false;
  bool force = false;
};
}  // namespace

void add_rig(CLI::App& app) {
  auto st = std::make_shared<rig_state>();
  auto* sub = app.add_subcommand("rig", "virtual test rig: a measurement record of the model plus undeclared effects (docs/loop.md)");
  auto& r = st->req;
  sub->add_option("--variant", r.variant, "the truth's contact law (compliant): piecewise-linear, piecewise-nonlinear, identified")
      ->capture_default_str();
  sub->add_option("--speeds", r.speeds_rpm, "dwell speeds [rev/min], comma-separated")->delimiter(',')->capture_default_str();
  sub->add_option("--settle-revs", r.settle_revs, "revolutions from rest before each dwell is recorded")->capture_default_str();
  sub->add_option("--revs", r.record_revs, "revolutions recorded per dwell")->capture_default_str();
  sub->add_option("--effect", st->effects,
                  "an effect of the library, at its moderate level or as name:key=value,... (repeatable; `rubref effects` lists them)");
  const char* outside = "Outside the effect library";
  sub->add_option("--speed-fluctuation", r.unmodelled.drive.amplitude, "relative speed fluctuation eps, w(1 + eps sin 2 pi f t)")
      ->capture_default_str()
      ->group(outside);
  sub->add_option("--fluctuation-hz", r.unmodelled.drive.frequency, "its frequency f [Hz]")->capture_default_str()->group(outside);
  sub->add_option("--cubic-stiffness", r.unmodelled.cubic_stiffness, "hardening shaft supports: -k (x^3, y^3) [N/m^3]")
      ->capture_default_str()
      ->group(outside);
  sub->add_option("--probe-gain-x", r.unmodelled.probe_gain_x, "the x probe's sensitivity error g: it reads (1 + g) x [-]")
      ->capture_default_str()
      ->group(outside);
  sub->add_option("--sample-rate", r.probes.sample_rate, "probe sample rate [Hz]")->capture_default_str();
  sub->add_option("--noise", r.probes.noise, "probe white noise, standard deviation [m]")->capture_default_str();
  sub->add_option("--quantisation", r.probes.quantisation, "probe quantisation step [m]")->capture_default_str();
  sub->add_option("--keyphasor-angle", r.probes.keyphasor_angle, "the keyphasor notch's angle from the unbalance [rad]")->capture_default_str();
  sub->add_option("--seed", r.probes.seed, "noise seed")->capture_default_str();
  sub->add_flag("--no-keyphasor", st->no_keyphasor, "write no keyphasor column (t_s is then shaft-synchronous)");
  sub->add_option("--time-base", st->time_base,
                  "what t_s is: acquisition (the sampling clock, default with a keyphasor) or shaft (shaft angle w t_s; "
                  "the default without one)");
  sub->add_flag("--carry-over", r.carry_over, "each dwell settles from where the previous one ended (a run-up), not from rest");
  sub->add_flag("--minimal-header", r.minimal_header, "write only clearance_m, sample_rate_hz and description (a record from elsewhere)");
  sub->add_option("--out", st->out, "measurement record to write (docs/data-format.md)")->required();
  sub->add_flag("--force", st->force, "replace output files rubref did not write");
  sub->add_option("--truth", st->truth, "truth JSON to write (the effects; for tests); default: <out without .csv>.truth.json");
  st->params.add_to(*sub);
  st->integration.add_to(*sub);
  add_threads_option(*sub);
  sub->callback([st] {
    rig_request req = st->req;
    req.params = st->params.resolve();
    req.integration = st->integration.resolve();
    req.probes.keyphasor = !st->no_keyphasor;
    if (st->time_base.empty()) req.time_base = st->no_keyphasor ? rig_time_base::shaft : rig_time_base::acquisition;
    else if (st->time_base == "shaft") req.time_base = rig_time_base::shaft;
    else if (st->time_base == "acquisition") req.time_base = rig_time_base::acquisition;
    else throw input_error("--time-base must be acquisition or shaft (got '" + st->time_base + "')");
    for (const auto& e : st->effects) apply_effect(req.effects, e);
    std::string truth = st->truth;
    if (truth.empty()) {
      std::filesystem::path p(st->out);
      truth = (p.extension() == ".csv" ? p.replace_extension("") : p).string() + ".truth.json";
    }
    check_output_file(st->out, {st->params.file()}, st->force);  // before the work, not after it
    check_output_file(truth, {st->params.file(), st->out}, st->force);
    const rig_output o = run_rig(req);
    atomic_output files;
    files.stage(st->out, to_csv(o.measurement));
    files.stage(truth, o.truth.dump(2) + "\n");
    files.commit();
    std::cout << "wrote " << st->out << " (" << o.measurement.rows() << " samples, " << req.speeds_rpm.size() << " dwells) and " << truth << "\n";
  });
  auto json_out = std::make_shared<bool>(false);
  auto* effects = app.add_subcommand("effects", "list the effect library (docs/loop.md)");
  effects->add_flag("--json", *json_out, "as JSON: every parameter with its unit, moderate level, fit range and documented levels");
  effects->callback([json_out] {
    if (*json_out) {
      nlohmann::ordered_json all = nlohmann::ordered_json::array();
      for (const auto& e : effect_library()) {
        nlohmann::ordered_json params = nlohmann::ordered_json::array();
        for (const auto& q : e.parameters) {
          nlohmann::ordered_json j{{"key", q.key}, {"unit", q.unit}, {"switch", q.is_switch}, {"off", q.off},
                                   {"moderate", q.moderate}, {"fit_range", {q.lo, q.hi}}};
          if (q.is_switch) j["levels"] = {{"magnitude", {q.level_lo, q.level_hi}}, {"either_sign", q.signed_level}};
          else if (q.level_hi > q.level_lo) j["levels"] = {{"range", {q.level_lo, q.level_hi}}};
          params.push_back(j);
        }
        nlohmann::ordered_json row{{"name", e.name}, {"model", e.model}, {"reference", e.reference}, {"measurement_only", e.measurement_only},
                                   {"parameters", params}};
        nlohmann::ordered_json fit = nlohmann::ordered_json::array();
        for (const auto& f : e.fit) {
          if (f.form == fit_form::power_coefficient)  // its levels hold at this penetration for any exponent
            row["level_reference_penetration_m"] = power_reference_penetration;
          nlohmann::ordered_json j{{"key", f.key}, {"as", std::string(to_string(f.form))}};
          if (f.is_shape()) j["profiled_over"] = {f.range_lo, f.range_hi};
          fit.push_back(j);
        }
        row["fit"] = fit;
        all.push_back(row);
      }
      std::cout << all.dump(2) << "\n";
      return;
    }
    for (const auto& e : effect_library()) {
      std::cout << e.name << (e.measurement_only ? " (measurement)" : "") << ": " << e.model << "\n";
      for (const auto& q : e.parameters) {
        std::cout << "    " << q.key << " [" << q.unit << "] moderate " << q.moderate << ", range [" << q.lo << ", " << q.hi << "]";
        if (q.is_switch) std::cout << ", documented levels " << (q.signed_level ? "+-" : "") << "[" << q.level_lo << ", " << q.level_hi << "]";
        else if (q.level_hi > q.level_lo) std::cout << ", physical range [" << q.level_lo << ", " << q.level_hi << "]";
        std::cout << "\n";
      }
    }
  });
}

}  // namespace rubref::cli
