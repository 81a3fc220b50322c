#include <cmath>
#include <iostream>
#include <memory>
#include <sstream>

#include "ref/app/python_script.hpp"
#include "ref/base/errors.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/format/order_table.hpp"
#include "ref/format/record.hpp"
#include "ref/loop/loop.hpp"
#include "ref/loop/report.hpp"
#include "ref/tracking/tracking_loop.hpp"
#include "ref/tracking/tracking_report.hpp"

namespace rubref::cli {

namespace {
struct loop_state {
  loop_settings settings;
  std::vector<std::string> files;
  std::string out;
  bool figures = true;
  order_conventions conventions;        // order-tracked tables only
  std::vector<std::string> probe_angles;  // "DEG" or "NAME=DEG"
  double scale = 0.0;
  double revolutions_per_row = 0.0;
  double sweep_rate = 0.0;
};

// The one line a run ends with: the errors, then the verdict (ref/inference/verdict.hpp), records
// and tables alike.
void print_result(const std::string& errors, const verdict& v, const std::string& out) {
  std::cout << errors << "; " << summary_line(v) << "\nwrote " << out << "/report.json, report.md\n";
}

// `rubref loop TABLE`: an order-tracked table (docs/real-data.md).
void run_on_table(const loop_state& st, staged_directory& dir) {
  if (st.files.size() != 1) throw input_error("an order-tracked table is fitted alone: give one table, not " + std::to_string(st.files.size()) + " files");
  const loop_settings defaults;
  if (st.settings.mass != defaults.mass || st.settings.clearance != defaults.clearance || st.settings.max_effects != defaults.max_effects ||
      st.settings.refit_candidates != defaults.refit_candidates)
    throw input_error("--mass, --clearance, --max-effects and --refit are settings of the loop on time records; " + st.files.front() +
                      " is an order-tracked table (docs/real-data.md)");
  order_conventions c = st.conventions;
  if (st.scale != 0.0) c.scale_mV_per_um = st.scale;
  for (const auto& a : st.probe_angles) {
    const auto eq = a.find('=');
    const std::string name = eq == std::string::npos ? "" : a.substr(0, eq), value = eq == std::string::npos ? a : a.substr(eq + 1);
    double deg = 0.0;
    try {
      std::size_t used = 0;
      deg = std::stod(value, &used);
      if (used != value.size()) throw std::invalid_argument(value);
    } catch (const std::exception&) {
      throw input_error("--probe-angle '" + a + "': expected DEG or NAME=DEG");
    }
    c.probe_angles_deg.emplace_back(name, deg);
  }
  const order_table table = read_order_table(st.files.front(), c);
  tracking_settings settings;  // the rub fits' orbits and the verdict's check, as on records
  settings.orbits = st.settings.orbits, settings.check_tolerance_scale = st.settings.check_tolerance_scale;
  settings.revolutions_per_row = st.revolutions_per_row;
  settings.sweep_rate_rpm_per_s = st.sweep_rate;
  const tracking_result r = run_tracking_loop(table, [](const std::string& line) { std::cerr << line << std::endl; }, settings);
  dir.write("report.json", to_json(r).dump(2) + "\n");
  dir.write("report.md", to_markdown(r));
  dir.write("plot_data.json", plot_data(r).dump() + "\n");
  if (st.figures) run_python_script(default_python(), script_path("plot_tracking.py"), dir.path());
  dir.commit();
  std::ostringstream errors;
  errors << "error before " << r.error_before << " m, after " << r.error_after << " m";
  print_result(errors.str(), r.decision, st.out);
}
}  // namespace

void add_loop(CLI::App& app) {
  auto st = std::make_shared<loop_state>();
  auto& s = st->settings;
  auto* sub = app.add_subcommand("loop", "fit the paper's model to records, trace the residual to library effects, report before/after (docs/loop.md)");
  sub->add_option("records", st->files, "measurement records (docs/data-format.md), with a keyphasor column if the rig has one; or one order-tracked table (docs/real-data.md)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--out", st->out, "report folder (report.json, report.md, figures)")->required();
  add_setting(*sub, s.mass, {"loop", "mass"});
  add_setting(*sub, s.clearance, {"loop", "clearance"});
  add_setting(*sub, s.max_effects, {"trace", "max_effects"});
  add_setting(*sub, s.refit_candidates, {"trace", "refit_candidates"});
  add_setting(*sub, s.orbits.tolerance_scale, {"fit_orbits", "tolerance_scale"});
  add_setting(*sub, s.check_tolerance_scale, {"loop", "check_tolerance_scale"});
  // A callback, not CLI11's negated flag "!--no-figures", whose help shows "--no-figures{false}".
  sub->add_flag_callback("--no-figures", [st] { st->figures = false; }, "write the report without drawing figures");
  auto* table = sub->add_option_group("order-tracked tables", "conventions of a table the file does not declare (docs/data-format.md)");
  table->add_option("--amplitude", st->conventions.amplitude, "amplitude convention: 0-peak, pk-pk or rms");
  table->add_option("--amplitude-unit", st->conventions.amplitude_unit, "unit of amplitude columns without a unit suffix: m, mm, um, mil, V, mV");
  table->add_option("--phase", st->conventions.phase, "phase convention: lead (A cos(k theta + phi)) or lag (A cos(k theta - phi)), theta after the keyphasor");
  table->add_option("--phase-unit", st->conventions.phase_unit, "unit of phase columns without a unit suffix: deg, rad");
  table->add_option("--scale", st->scale, "probe sensitivity for volt amplitudes [mV/um]")->check(CLI::PositiveNumber);
  table->add_option("--probe-angle", st->probe_angles, "a probe's angle from +x towards +y [deg]: DEG (one probe) or NAME=DEG; repeatable");
  table->add_option("--revolutions-per-row", st->revolutions_per_row,
                    "revolutions each row's orders were read over (the run-up transient's block); default: fitted among 1 to 8")
      ->check(CLI::Range(1.0, 1e6));
  table->add_option("--sweep-rate", st->sweep_rate,
                    "the run-up's or coast-down's rate [rpm/s], held by the run-up transient's fit; default: from a time_s column, else fitted")
      ->check(CLI::PositiveNumber);
  add_threads_option(*sub);
  sub->callback([st] {
    staged_directory dir(st->out);  // the output folder is checked before the work, not after it
    if (is_order_table_header(header_of(st->files.front()))) return run_on_table(*st, dir);
    if (!st->conventions.amplitude.empty() || !st->conventions.amplitude_unit.empty() || !st->conventions.phase.empty() ||
        !st->conventions.phase_unit.empty() || st->scale != 0.0 || !st->probe_angles.empty() || st->revolutions_per_row != 0.0 ||
        st->sweep_rate != 0.0)
      throw input_error("--amplitude, --amplitude-unit, --phase, --phase-unit, --scale, --probe-angle, --revolutions-per-row and --sweep-rate describe an order-tracked table; " +
                        st->files.front() + " is a time record");
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
    std::ostringstream errors;
    if (std::isfinite(r.error_before))
      errors << "error before " << r.error_before << ", after " << r.error_after;
    else  // every dwell with contact was left out (the warnings above say why): nothing to score
      errors << "no dwell with contact was usable (see the warnings): nothing fitted";
    print_result(errors.str(), r.decision, st->out);
  });
}

}  // namespace rubref::cli
