// rubref's Python module (docs/python.md): the library's front doors, with parameters as keyword
// arguments (the parameter files' keys), arrays as numpy arrays and every JSON the command line
// writes as the same dict. Long calls release the GIL; batch calls also run on the thread pool.
// Errors: rubref.InputError (a ValueError) for bad input, rubref.NumericalError (a RuntimeError)
// for a failed integration, each with the library's one-line message.

#include <pybind11/complex.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ref/analysis/orbit_io.hpp"
#include "ref/analysis/orbit_summary.hpp"
#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/base/setting_names.hpp"
#include "ref/base/version.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/format/order_table.hpp"
#include "ref/format/record.hpp"
#include "ref/identification/identify.hpp"
#include "ref/identification/identify_io.hpp"
#include "ref/loop/loop.hpp"
#include "ref/loop/report.hpp"
#include "ref/model/parameter_io.hpp"
#include "ref/orbits/continuation.hpp"
#include "ref/orbits/continuation_io.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "ref/orbits/periodic_orbit_io.hpp"
#include "ref/rig/rig.hpp"
#include "ref/run/simulate.hpp"
#include "ref/study/study_run.hpp"
#include "ref/tracking/tracking_loop.hpp"
#include "ref/tracking/tracking_report.hpp"
#include "ref/validation/golden.hpp"
#include "ref/validation/validate.hpp"

namespace py = pybind11;
using namespace rubref;

namespace {

// A library message with its settings (`field`, ref/base/errors.hpp) as this module's keyword
// arguments: 'start' and 'end' for a continuation's range, 'revs' for the recorded revolutions
// (as on the command line), else the field's own name.
std::string with_keywords(std::string_view message) {
  return spell_settings(message, [](std::string_view field) {
    return "'" + std::string(field == "from" ? "start" : field == "to" ? "end" : field == "record_revs" ? "revs" : field) + "'";
  });
}

py::array_t<double> to_array(const std::vector<double>& v) { return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data()); }

// nlohmann JSON -> Python objects, through Python's own json (numbers stay numbers, order kept).
py::object to_python(const nlohmann::ordered_json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

// The paper's parameters overridden by keyword arguments named as in a parameter file
// (`rubref params`: m_kg, clearance_m, mu, k1_N_m, ...); `clearance` in m is a shorthand.
parameters parameters_from(std::optional<double> clearance, const py::dict& kw) {
  parameters p;
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [key, value] : kw) {
    const std::string k = py::str(key);
    if (!py::isinstance<py::float_>(value) && !py::isinstance<py::int_>(value))
      throw input_error("parameter '" + k + "' must be a number (got " + std::string(py::str(py::type::of(value).attr("__name__"))) + ")");
    j[k] = value.cast<double>();
  }
  if (clearance) {
    if (j.contains("clearance_m")) throw input_error("give the clearance once: clearance or clearance_m");
    j["clearance_m"] = *clearance;
  }
  apply_json(p, j, "keyword arguments");
  validate(p);
  return p;
}

integration_options integration_from(const std::string& stepper, std::optional<double> rtol, std::optional<double> atol,
                                     std::optional<double> dt) {
  integration_options o;
  o.stepper.kind = parse_stepper(stepper);
  if (rtol) o.stepper.rtol = *rtol;
  if (atol) o.stepper.atol = *atol;
  if (dt) o.stepper.dt = *dt;
  return o;
}

py::dict samples_of(const orbit& o) {
  std::vector<double> t, x, y, vx, vy, fn;
  for (const auto& s : o.samples) {
    t.push_back(s.t), x.push_back(s.s[0]), y.push_back(s.s[1]), vx.push_back(s.s[2]), vy.push_back(s.s[3]), fn.push_back(s.fn);
  }
  py::dict d;
  d["t"] = to_array(t), d["x"] = to_array(x), d["y"] = to_array(y), d["vx"] = to_array(vx), d["vy"] = to_array(vy), d["fn"] = to_array(fn);
  return d;
}

py::dict record_to_python(const record& r) {
  py::dict columns, metadata;
  for (std::size_t c = 0; c < r.columns.size(); ++c) columns[py::str(r.columns[c])] = to_array(r.data[c]);
  for (const auto& [k, v] : r.metadata) metadata[py::str(k)] = v;
  py::dict d;
  d["columns"] = columns;
  d["metadata"] = metadata;
  return d;
}

std::vector<std::pair<record, std::string>> read_records(const std::vector<std::string>& paths) {
  if (paths.empty()) throw input_error("give at least one record file");
  std::vector<std::pair<record, std::string>> out;
  for (const auto& p : paths) out.emplace_back(read_record(p), p);
  return out;
}

run_request run_from(const std::string& variant, double rpm, int settle_revs, int revs, int samples_per_rev, const parameters& p,
                     const integration_options& integration, std::optional<std::vector<double>> initial) {
  run_request req;
  req.variant = variant;
  req.rpm = rpm;
  req.settle_revs = settle_revs;
  req.record_revs = revs;
  req.samples_per_rev = samples_per_rev;
  req.params = p;
  req.integration = integration;
  if (initial) {
    if (initial->size() != 4) throw input_error("initial must be 4 numbers: x, y, vx, vy (m, m, m/s, m/s)");
    req.initial_state = {(*initial)[0], (*initial)[1], (*initial)[2], (*initial)[3]};
  }
  return req;
}

}  // namespace

PYBIND11_MODULE(_rubref, m) {
  m.doc() = "rubref: numerical reference for partial rotor-stator rub (docs/python.md)";
  m.attr("__version__") = std::string(version());
  m.attr("commit") = std::string(commit());
  static py::exception<input_error> input_exc(m, "InputError", PyExc_ValueError);
  static py::exception<numerical_error> numerical_exc(m, "NumericalError", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const input_error& e) {
      input_exc(with_keywords(e.what()).c_str());
    } catch (const numerical_error& e) {
      numerical_exc(with_keywords(e.what()).c_str());
    }
  });

  m.def("default_parameters", [] { return to_python(to_json(parameters{})); }, "The paper's parameters, as a parameter file has them.");
  m.def("variants", [] { return variant_name_list(); }, "The contact laws' names.");

  m.def(
      "simulate",
      [](const std::string& variant, double rpm, std::optional<double> clearance, int settle_revs, int revs, int samples_per_rev,
         const std::string& stepper, std::optional<double> rtol, std::optional<double> atol, std::optional<double> dt,
         std::optional<std::vector<double>> initial, const py::kwargs& params) {
        const run_request req = run_from(variant, rpm, settle_revs, revs, samples_per_rev, parameters_from(clearance, params),
                                         integration_from(stepper, rtol, atol, dt), initial);
        orbit o;
        {
          py::gil_scoped_release free;
          o = simulate(req);
        }
        py::dict d = samples_of(o);
        d["summary"] = to_python(to_json(summarize(o), o));
        const std::string warn = coarse_contact_warning(o.counts);
        if (!warn.empty()) py::module_::import("warnings").attr("warn")(with_keywords(warn));
        return d;
      },
      py::arg("variant") = "identified", py::arg("rpm") = default_of("run", "rpm"), py::arg("clearance") = py::none(),
      py::arg("settle_revs") = default_count_of("run", "settle_revs"), py::arg("revs") = default_count_of("run", "record_revs"),
      py::arg("samples_per_rev") = default_count_of("run", "samples_per_rev"), py::arg("stepper") = "dopri5", py::arg("rtol") = py::none(),
      py::arg("atol") = py::none(), py::arg("dt") = py::none(), py::arg("initial") = py::none());

  // One steady run per row of `rpm` and `params` (columns of equal length, made by the Python
  // wrapper from scalars and arrays); the runs share the thread pool, results in row order.
  m.def(
      "_simulate_batch",
      [](const std::string& variant, const std::vector<double>& rpm, const std::map<std::string, std::vector<double>>& columns,
         int settle_revs, int revs, int samples_per_rev, const std::string& stepper, unsigned threads) {
        const integration_options integration = integration_from(stepper, std::nullopt, std::nullopt, std::nullopt);
        std::vector<run_request> runs;
        for (std::size_t i = 0; i < rpm.size(); ++i) {
          parameters p;
          nlohmann::json j = nlohmann::json::object();
          for (const auto& [k, v] : columns) j[k] = v.at(i);
          apply_json(p, j, "keyword arguments (row " + std::to_string(i) + ")");
          validate(p);
          runs.push_back(run_from(variant, rpm[i], settle_revs, revs, samples_per_rev, p, integration, std::nullopt));
          validate(runs.back());
        }
        std::vector<orbit_summary> out(runs.size());
        {
          py::gil_scoped_release free;
          parallel_for(runs.size(), threads, [&](std::size_t i) { out[i] = summarize(simulate(runs[i])); });
        }
        std::vector<double> max_radius, max_y, ppx, ppy, force, penetration, per_rev, fraction, period;
        std::vector<std::string> regime;
        std::vector<bool> backward;
        for (const auto& s : out) {
          max_radius.push_back(s.max_radius), max_y.push_back(s.max_y), ppx.push_back(s.peak_to_peak_x), ppy.push_back(s.peak_to_peak_y);
          force.push_back(s.max_normal_force), penetration.push_back(s.max_penetration), per_rev.push_back(s.contact_episodes_per_rev);
          fraction.push_back(s.contact_fraction), period.push_back(s.period_revs);
          regime.emplace_back(to_string(s.regime));
          backward.push_back(s.backward_whirl());
        }
        py::dict d;
        d["max_radius_m"] = to_array(max_radius), d["max_y_m"] = to_array(max_y);
        d["peak_to_peak_x_m"] = to_array(ppx), d["peak_to_peak_y_m"] = to_array(ppy);
        d["max_normal_force_N"] = to_array(force), d["max_penetration_m"] = to_array(penetration);
        d["contact_episodes_per_rev"] = to_array(per_rev), d["contact_fraction"] = to_array(fraction);
        d["period_revs"] = to_array(period);
        d["regime"] = regime;
        d["backward_whirl"] = py::array(py::cast(backward));
        return d;
      },
      py::arg("variant"), py::arg("rpm"), py::arg("columns"), py::arg("settle_revs"), py::arg("revs"), py::arg("samples_per_rev"),
      py::arg("stepper"), py::arg("threads"));

  m.def(
      "orbit",
      [](const std::string& variant, double rpm, std::optional<double> clearance, int periods, double tolerance, int samples_per_rev,
         std::optional<std::vector<double>> initial, const py::kwargs& params) {
        periodic_orbit_request req;
        req.run = run_from(variant, rpm, req.run.settle_revs, req.run.record_revs, samples_per_rev, parameters_from(clearance, params),
                           integration_options{}, std::nullopt);
        req.periods = periods;
        req.tolerance = tolerance;
        if (initial) {
          if (initial->size() != 4) throw input_error("initial must be 4 numbers: x, y, vx, vy (m, m, m/s, m/s)");
          req.initial_guess = state_type{(*initial)[0], (*initial)[1], (*initial)[2], (*initial)[3]};
        }
        periodic_orbit_result r;
        {
          py::gil_scoped_release free;
          r = find_periodic_orbit(req);
        }
        if (!r.converged)
          py::module_::import("warnings").attr("warn")("Newton shooting did not converge (" + r.failure +
                                                        "); the orbit is the end of a transient, with no Floquet multipliers");
        py::dict d = samples_of(r.samples);
        d["summary"] = to_python(periodic_orbit_json(req, r));
        return d;
      },
      py::arg("variant") = "identified", py::arg("rpm") = default_of("run", "rpm"), py::arg("clearance") = py::none(),
      py::arg("periods") = default_count_of("shooting", "periods"), py::arg("tolerance") = kShootingTolerance,
      py::arg("samples_per_rev") = default_count_of("run", "samples_per_rev"), py::arg("initial") = py::none());

  m.def(
      "continuation",
      [](const std::string& variant, const std::string& parameter, std::optional<double> from, std::optional<double> to,
         const std::string& direction, double rpm, std::optional<double> clearance, int periods, double max_step, int max_points,
         double tolerance, const py::kwargs& params) {
        continuation_request req;
        req.variant = variant;
        req.parameter = parse_continuation_parameter(parameter);
        if (req.parameter != continuation_parameter::speed && (!from || !to))
          throw input_error("parameter '" + parameter + "' needs start and end (in " + std::string(column_name(req.parameter)) + "'s unit)");
        if (from) req.from = *from;
        if (to) req.to = *to;
        if (direction != "up" && direction != "down") throw input_error("direction must be up or down (got '" + direction + "')");
        req.downward = direction == "down";
        req.rpm = rpm;
        req.periods = periods;
        req.max_step = max_step;
        req.initial_step = std::min(req.initial_step, req.max_step);
        req.max_points = max_points;
        req.tolerance = tolerance;
        req.params = parameters_from(clearance, params);
        validate(req);
        continuation_result res;
        {
          py::gil_scoped_release free;
          res = continue_branch(req);
        }
        const table t = branch_table(req, res);
        py::dict branch;
        for (std::size_t c = 0; c < t.columns.size(); ++c) {
          std::vector<double> v;
          py::list text;
          bool numeric = true;
          for (const auto& row : t.rows) {
            try {
              std::size_t used = 0;
              v.push_back(std::stod(row[c], &used));
              numeric = numeric && used == row[c].size();
            } catch (const std::exception&) {
              numeric = false;
            }
            text.append(row[c]);
          }
          branch[py::str(t.columns[c])] = numeric ? py::object(to_array(v)) : py::object(text);
        }
        py::dict d;
        d["branch"] = branch;
        d["summary"] = to_python(branch_summary_json(req, res));
        return d;
      },
      py::arg("variant") = "identified", py::arg("parameter") = "speed", py::arg("start") = py::none(), py::arg("end") = py::none(),
      py::arg("direction") = "up", py::arg("rpm") = default_of("continuation", "rpm"), py::arg("clearance") = py::none(),
      py::arg("periods") = default_count_of("continuation", "periods"), py::arg("max_step") = default_of("continuation", "max_step"),
      py::arg("max_points") = default_count_of("continuation", "max_points"), py::arg("tolerance") = kShootingTolerance);

  m.def(
      "read_record", [](const std::string& path) { return record_to_python(read_record(path)); }, py::arg("path"),
      "A record file (docs/data-format.md) as {'columns': {name: array}, 'metadata': {key: text}}.");

  m.def(
      "write_record",
      [](const std::string& path, const std::map<std::string, std::vector<double>>& columns,
         const std::map<std::string, std::string>& metadata, const std::vector<std::string>& order) {
        record r;
        for (const auto& [k, v] : metadata) r.set(k, v);
        for (const auto& name : order) {
          const auto it = columns.find(name);
          if (it == columns.end()) throw input_error("column '" + name + "' is in the order but has no values");
          r.add_column(name, it->second);
        }
        const std::string text = to_csv(r);
        parse_record(text, path);  // what is written must read back (required columns, lengths, finite numbers)
        atomic_output out;
        out.stage(path, text);
        out.commit();
      },
      py::arg("path"), py::arg("columns"), py::arg("metadata"), py::arg("order"));

  m.def(
      "identify",
      [](const std::vector<std::string>& paths, std::optional<double> clearance, std::optional<py::dict> linear, const std::string& averaging,
         const std::string& law_method, const std::string& library, double rho, bool orbit_fit, bool reidentify, int bootstrap) {
        identify_settings s;
        if (linear) s.linear = parameters_from(std::nullopt, *linear);  // the linear part known: the parameter file's keys
        if (clearance) s.clearance = *clearance;
        s.average = parse_averaging(averaging);
        s.law_route = parse_law_method(law_method);
        s.library = library;
        if (!(rho >= 0.0 && rho < 1.0)) throw input_error("rho must be in [0, 1)");
        s.frols.rho = rho;
        s.orbit_fit = orbit_fit;
        s.reidentify = reidentify;
        if (bootstrap < 0) throw input_error("bootstrap must be >= 0");
        s.bootstrap = bootstrap;
        const auto records = read_records(paths);
        identification id;
        {
          py::gil_scoped_release free;
          id = identify(records, s);
        }
        for (const auto& w : id.warnings) py::module_::import("warnings").attr("warn")(w);
        return to_python(to_json(id, s));
      },
      py::arg("paths"), py::arg("clearance") = py::none(), py::arg("linear") = py::none(), py::arg("averaging") = "auto", py::arg("law_method") = "auto",
      py::arg("library") = identify_settings{}.library, py::arg("rho") = identify_settings{}.frols.rho, py::arg("orbit_fit") = true,
      py::arg("reidentify") = false, py::arg("bootstrap") = identify_settings{}.bootstrap);

  m.def(
      "validate",
      [](const std::string& case_path, const std::string& candidate_path) {
        const golden_case g = read_golden_case(read_record(case_path), case_path);
        const record candidate = read_record(candidate_path);
        validation_result r;
        {
          py::gil_scoped_release free;
          r = validate_candidate(g, candidate, candidate_path);
        }
        return to_python(to_json(r));
      },
      py::arg("case"), py::arg("candidate"));

  m.def(
      "rig",
      [](const std::vector<std::string>& effects, std::optional<std::vector<double>> speeds, std::optional<double> noise, bool keyphasor,
         bool carry_over, int settle_revs, int revs, unsigned seed, const std::string& variant, std::optional<double> clearance,
         const py::kwargs& params) {
        rig_request req;
        req.variant = variant;
        req.params = parameters_from(clearance, params);
        for (const auto& e : effects) apply_effect(req.effects, e);
        if (speeds) req.speeds_rpm = *speeds;
        if (noise) req.probes.noise = *noise;
        req.probes.keyphasor = keyphasor;
        req.probes.seed = seed;
        req.time_base = keyphasor ? rig_time_base::acquisition : rig_time_base::shaft;
        req.carry_over = carry_over;
        req.settle_revs = settle_revs;
        req.record_revs = revs;
        validate(req);
        rig_output o;
        {
          py::gil_scoped_release free;
          o = run_rig(req);
        }
        py::dict d = record_to_python(o.measurement);
        d["truth"] = to_python(o.truth);
        return d;
      },
      py::arg("effects") = std::vector<std::string>{}, py::arg("speeds") = py::none(), py::arg("noise") = py::none(),
      py::arg("keyphasor") = true, py::arg("carry_over") = false, py::arg("settle_revs") = rig_request{}.settle_revs,
      py::arg("revs") = rig_request{}.record_revs, py::arg("seed") = probe_settings{}.seed, py::arg("variant") = "identified",
      py::arg("clearance") = py::none());

  m.def(
      "loop",
      [](const std::vector<std::string>& paths, std::optional<double> clearance, std::optional<double> mass, int max_effects) {
        loop_settings s;
        if (clearance) s.clearance = *clearance;
        if (mass) s.mass = *mass;
        if (max_effects < 0) throw input_error("max_effects must be >= 0");
        s.max_effects = max_effects;
        const auto records = read_records(paths);
        loop_result r;
        {
          py::gil_scoped_release free;
          r = run_loop(records, s);
        }
        for (const auto& w : r.warnings) py::module_::import("warnings").attr("warn")(w);
        return to_python(to_json(r));
      },
      py::arg("paths"), py::arg("clearance") = py::none(), py::arg("mass") = py::none(), py::arg("max_effects") = loop_settings{}.max_effects);

  // Order-tracked tables (docs/real-data.md): the conventions a file does not declare, as keyword
  // arguments; probe angles as {name: degrees} ("" for a table's only probe).
  const auto conventions_of = [](const std::string& amplitude, const std::string& amplitude_unit, const std::string& phase,
                                 const std::string& phase_unit, std::optional<double> scale, const std::map<std::string, double>& probe_angles) {
    order_conventions c;
    c.amplitude = amplitude, c.amplitude_unit = amplitude_unit, c.phase = phase, c.phase_unit = phase_unit, c.scale_mV_per_um = scale;
    for (const auto& [name, deg] : probe_angles) c.probe_angles_deg.emplace_back(name, deg);
    return c;
  };
  m.def(
      "read_order_table",
      [conventions_of](const std::string& path, const std::string& amplitude, const std::string& amplitude_unit, const std::string& phase,
                       const std::string& phase_unit, std::optional<double> scale, const std::map<std::string, double>& probe_angles) {
        const order_table t = read_order_table(path, conventions_of(amplitude, amplitude_unit, phase, phase_unit, scale, probe_angles));
        py::list orders;
        for (const auto& o : t.orders) {
          py::array_t<std::complex<double>> v(static_cast<py::ssize_t>(o.vector.size()), o.vector.data());
          py::dict d;
          d["probe"] = o.probe, d["order"] = o.order, d["vector_m"] = v;
          d["probe_angle_deg"] = o.probe_angle ? py::object(py::float_(*o.probe_angle * 180.0 / 3.141592653589793)) : py::object(py::none());
          d["amplitude_column"] = o.amplitude_column, d["phase_column"] = o.phase_column;
          orders.append(d);
        }
        py::dict out;
        out["rpm"] = to_array(t.rpm);
        out["orders"] = orders;
        out["notes"] = t.notes;
        out["conventions"] = t.conventions;
        return out;
      },
      py::arg("path"), py::arg("amplitude") = "", py::arg("amplitude_unit") = "", py::arg("phase") = "", py::arg("phase_unit") = "",
      py::arg("scale") = py::none(), py::arg("probe_angles") = std::map<std::string, double>{});
  m.def(
      "loop_table",
      [conventions_of](const std::string& path, const std::string& amplitude, const std::string& amplitude_unit, const std::string& phase,
                       const std::string& phase_unit, std::optional<double> scale, const std::map<std::string, double>& probe_angles) {
        const order_table t = read_order_table(path, conventions_of(amplitude, amplitude_unit, phase, phase_unit, scale, probe_angles));
        tracking_result r;
        {
          py::gil_scoped_release free;
          r = run_tracking_loop(t);
        }
        return to_python(to_json(r));
      },
      py::arg("path"), py::arg("amplitude") = "", py::arg("amplitude_unit") = "", py::arg("phase") = "", py::arg("phase_unit") = "",
      py::arg("scale") = py::none(), py::arg("probe_angles") = std::map<std::string, double>{});
  m.def(
      "is_order_table", [](const std::string& path) { return is_order_table_header(header_of(path)); }, py::arg("path"));

  // A parameter study into the folder `out` (docs/studies.md): the points of `shard` not yet
  // there, then the results when that completes the study. No figures (the command line draws
  // them, or scripts/plot_study.py on the folder).
  const auto summary_of = [](const std::string& dir) {
    std::ifstream in(std::filesystem::path(dir) / "summary.json");
    return to_python(nlohmann::ordered_json::parse(in));
  };
  m.def(
      "_study",
      [summary_of](const std::string& spec_text, const std::string& source, const std::string& out, const std::string& shard, unsigned threads) {
        const study::spec s = study::parse_spec(spec_text, source);
        study::run_settings rs;
        rs.part = study::parse_shard(shard);
        rs.threads = threads;
        study::run_outcome o;
        {
          py::gil_scoped_release free;
          o = study::run_study(out, s, rs);
        }
        py::dict d;
        d["computed"] = o.computed;
        d["already"] = o.already;
        d["complete"] = o.complete;
        d["summary"] = o.complete && rs.part.of == 1 ? summary_of(out) : py::none();
        if (o.results.problems > 0)
          py::module_::import("warnings").attr("warn")(std::to_string(o.results.problems) + " point(s) have no steady result (see summary['problems'])");
        return d;
      },
      py::arg("spec_text"), py::arg("source"), py::arg("out"), py::arg("shard"), py::arg("threads"));
  m.def(
      "_study_merge",
      [summary_of](const std::vector<std::string>& dirs, const std::string& out, unsigned threads) {
        std::vector<std::filesystem::path> paths(dirs.begin(), dirs.end());
        {
          py::gil_scoped_release free;
          study::merge_study(paths, out, threads);
        }
        return summary_of(out);
      },
      py::arg("dirs"), py::arg("out"), py::arg("threads"));
}
