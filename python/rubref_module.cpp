// rubref's Python module (docs/python.md): the library's front doors, with parameters as keyword
// arguments (the parameter files' keys), arrays as numpy arrays and every JSON the command line
// writes as the same dict. Long calls release the GIL; batch calls also run on the thread pool.
// Errors: rubref.InputError (a ValueError) for bad input, rubref.NumericalError (a RuntimeError)
// for a failed integration, each with the library's one-line message.

#include <pybind11/complex.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <streambuf>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "ref/analysis/orbit_io.hpp"
#include "ref/analysis/orbit_summary.hpp"
#include "ref/base/cancel.hpp"
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
#include "ref/base/number_text.hpp"
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
// arguments: 'from_' for a continuation's range start (`from` is a Python keyword; 'to' is its
// own name), 'revs' for the recorded revolutions (as on the command line), else the field's name.
std::string with_keywords(std::string_view message) {
  return spell_settings(message, [](std::string_view field) {
    return "'" + std::string(field == "from" ? "from_" : field == "record_revs" ? "revs" : field) + "'";
  });
}

// A Python warning at the user's line: stacklevel 3 skips the package's function and its checking
// wrapper (python/rubref/__init__.py), which every call comes through.
void warn(const std::string& text) {
  py::module_::import("warnings").attr("warn")(with_keywords(text), py::module_::import("builtins").attr("UserWarning"), 3);
}

// Progress lines from any thread of a long call, delivered to Python on its own thread.
class line_queue {
 public:
  void push(std::string line) {
    const std::lock_guard lock(mutex_);
    lines_.push_back(std::move(line));
  }
  std::deque<std::string> take() {
    const std::lock_guard lock(mutex_);
    return std::exchange(lines_, {});
  }

 private:
  std::mutex mutex_;
  std::deque<std::string> lines_;
};

// A stream whose complete lines go to `to` (the study's progress meter writes to a stream; it
// writes under the study's own lock, one line at a time).
class line_streambuf : public std::streambuf {
 public:
  explicit line_streambuf(std::function<void(std::string)> to) : to_(std::move(to)) {}

 protected:
  int_type overflow(int_type c) override {
    if (c == traits_type::eof()) return c;
    if (c == '\n' || c == '\r') {
      if (!line_.empty()) to_(std::exchange(line_, {}));
    } else {
      line_ += static_cast<char>(c);
    }
    return c;
  }

 private:
  std::function<void(std::string)> to_;
  std::string line_;
};

// Runs work(report) on a thread of its own while the caller's (Python's) thread waits with the
// GIL released. Every 50 ms that thread takes the GIL back to hand the lines given to `report`
// to `progress` (a Python callable, or None) and to run Python's signal handlers: Ctrl-C raises
// KeyboardInterrupt there. Then the work's stop is requested (ref/base/cancel.hpp: every
// integration step and every parallel task checks it), its unwinding removes what it staged, and
// the Python exception is raised once it has ended: nothing partial, within a step of the poll.
template <class Work>
auto interruptible(const py::object& progress, Work&& work) {
  using result = decltype(work(std::function<void(std::string)>{}));
  line_queue lines;
  const std::function<void(std::string)> report = [&lines](std::string line) { lines.push(std::move(line)); };
  stop_source stop;
  std::mutex mutex;
  std::condition_variable finished;
  bool done = false;
  std::optional<result> out;
  std::exception_ptr error;
  const auto deliver = [&] {
    for (auto& line : lines.take())
      if (!progress.is_none()) progress(line);
  };
  std::optional<py::error_already_set> raised;
  {
    py::gil_scoped_release free;
    std::thread worker([&] {
      const stop_scope scope(&stop);
      try {
        out.emplace(work(report));
      } catch (...) {
        error = std::current_exception();
      }
      const std::lock_guard lock(mutex);
      done = true;
      finished.notify_one();
    });
    for (;;) {
      bool ended = false;
      {
        std::unique_lock lock(mutex);
        ended = finished.wait_for(lock, std::chrono::milliseconds(50), [&] { return done; });
      }
      {
        py::gil_scoped_acquire hold;
        try {
          deliver();
          if (PyErr_CheckSignals() != 0) throw py::error_already_set();
        } catch (py::error_already_set& e) {
          raised.emplace(std::move(e));
        }
      }
      if (raised) {
        stop.request_stop();
        break;
      }
      if (ended) break;
    }
    worker.join();
  }
  if (raised) throw std::move(*raised);  // KeyboardInterrupt, or the progress callable's own error
  deliver();
  if (error) std::rethrow_exception(error);
  return std::move(*out);
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
  for (const auto& w : unit_warnings(p)) warn(w);  // the command line's warning (ref/model/parameter_io.hpp)
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

// The module's documentation, version and exceptions.
void bind_module(py::module_& m) {
  m.doc() = "rubref's compiled core (docs/python.md); use the functions of the rubref package";
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
}

// The paper's parameters, the names rubref knows, and the settings' registry and defaults.
void bind_settings(py::module_& m) {
  m.def("default_parameters", [] { return to_python(to_json(parameters{})); });
  m.def("variants", [] { return variant_name_list(); });
  m.def("steppers", [] { return std::vector<std::string>{"rk4", "dopri5", "rkf78", "bulirsch-stoer"}; });
  m.def("_did_you_mean", [](const std::string& word, const std::vector<std::string>& candidates) { return did_you_mean(word, candidates); });

  // The settings registry (ref/model/settings.hpp), for the docstrings and the defaults: every row,
  // and the row a scope uses for a name (its own, else the shared one: setting_named's rule).
  const auto row_dict = [](const setting_info& r) {
    py::dict d;
    d["scope"] = std::string(r.scope), d["name"] = std::string(r.name), d["flag"] = std::string(r.flag);
    d["key"] = std::string(r.key), d["unit"] = std::string(r.unit), d["default"] = r.default_value;
    d["whole"] = r.range.integer, d["range"] = describe(r.range), d["description"] = std::string(r.description);
    return d;
  };
  m.def("_settings", [row_dict] {
    py::list rows;
    for (const auto& r : settings_registry) rows.append(row_dict(r));
    return rows;
  });
  m.def("_setting", [row_dict](const std::string& scope, const std::string& name) {
    return row_dict(setting_named(scope, name));  // no such row: the package's bug (setting_named throws)
  });
  // Defaults that live in the library's request structs rather than in the registry.
  m.def("_defaults", [] {
    py::dict d;
    d["shooting_tolerance"] = kShootingTolerance;
    d["identify_library"] = identify_settings{}.library, d["identify_reid_fit"] = identify_settings{}.reid.fit;
    d["rig_seed"] = probe_settings{}.seed, d["rig_speeds"] = rig_request{}.speeds_rpm;
    return d;
  });
}

// Steady runs, one at a time and in batches on the thread pool.
void bind_runs(py::module_& m) {
  m.def("_simulate", [](const std::string& variant, double rpm, std::optional<double> clearance, int settle_revs, int revs,
                        int samples_per_rev, const std::string& stepper, std::optional<double> rtol, std::optional<double> atol,
                        std::optional<double> dt, std::optional<std::vector<double>> initial, const py::dict& params) {
    const run_request req = run_from(variant, rpm, settle_revs, revs, samples_per_rev, parameters_from(clearance, params),
                                     integration_from(stepper, rtol, atol, dt), initial);
    const orbit o = interruptible(py::none(), [&](const auto&) { return simulate(req); });
    py::dict d = samples_of(o);
    d["summary"] = to_python(to_json(summarize(o), o));
    if (const std::string w = coarse_contact_warning(o.counts); !w.empty()) warn(w);
    return d;
  });

  // One steady run per row of `rpm` and `columns` (equal lengths, made by the Python wrapper from
  // scalars and arrays); the runs share the thread pool, results in row order. Progress: a line
  // at every twentieth of the runs, to `progress` (None: none).
  m.def("_simulate_batch", [](const std::string& variant, const std::vector<double>& rpm, const std::map<std::string, std::vector<double>>& columns,
                              int settle_revs, int revs, int samples_per_rev, const std::string& stepper, unsigned threads,
                              const py::object& progress) {
    const integration_options integration = integration_from(stepper, std::nullopt, std::nullopt, std::nullopt);
    std::vector<run_request> runs;
    std::set<std::string> warned;
    for (std::size_t i = 0; i < rpm.size(); ++i) {
      parameters p;
      nlohmann::json j = nlohmann::json::object();
      for (const auto& [k, v] : columns) j[k] = v.at(i);
      apply_json(p, j, "keyword arguments (row " + std::to_string(i) + ")");
      validate(p);
      for (const auto& w : unit_warnings(p))
        if (warned.insert(w).second) warn(w);
      runs.push_back(run_from(variant, rpm[i], settle_revs, revs, samples_per_rev, p, integration, std::nullopt));
      validate(runs.back());
    }
    const auto out = interruptible(progress, [&](const auto& report) {
      std::vector<orbit_summary> sums(runs.size());
      std::atomic<std::size_t> finished{0};
      const std::size_t every = std::max<std::size_t>(1, runs.size() / 20);
      parallel_for(runs.size(), threads, [&](std::size_t i) {
        sums[i] = summarize(simulate(runs[i]));
        if (const std::size_t n = ++finished; n % every == 0 || n == runs.size())
          report("simulate_batch: " + std::to_string(n) + " of " + std::to_string(runs.size()) + " runs");
      });
      return sums;
    });
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
  });
}

// Periodic orbits by shooting, and their continuation.
void bind_orbits(py::module_& m) {
  m.def("_orbit", [](const std::string& variant, double rpm, std::optional<double> clearance, int periods, double tolerance,
                     int samples_per_rev, const std::string& stepper, std::optional<double> rtol, std::optional<double> atol,
                     std::optional<double> dt, std::optional<std::vector<double>> initial, const py::dict& params) {
    periodic_orbit_request req;
    req.run = run_from(variant, rpm, req.run.settle_revs, req.run.record_revs, samples_per_rev, parameters_from(clearance, params),
                       integration_from(stepper, rtol, atol, dt), std::nullopt);
    req.periods = periods;
    req.tolerance = tolerance;
    if (initial) {
      if (initial->size() != 4) throw input_error("initial must be 4 numbers: x, y, vx, vy (m, m, m/s, m/s)");
      req.initial_guess = state_type{(*initial)[0], (*initial)[1], (*initial)[2], (*initial)[3]};
    }
    const periodic_orbit_result r = interruptible(py::none(), [&](const auto&) { return find_periodic_orbit(req); });
    if (!r.converged)
      warn("Newton shooting did not converge (" + r.failure + "); the orbit is the end of a transient, with no Floquet multipliers");
    py::dict d = samples_of(r.samples);
    d["summary"] = to_python(periodic_orbit_json(req, r));
    return d;
  });

  m.def("_continuation", [](const std::string& variant, const std::string& parameter, std::optional<double> from, std::optional<double> to,
                            const std::string& direction, double rpm, std::optional<double> clearance, int periods, double max_step,
                            int max_points, double tolerance, const py::dict& params) {
    continuation_request req;
    req.variant = variant;
    req.parameter = parse_continuation_parameter(parameter);
    if (req.parameter != continuation_parameter::speed && (!from || !to))
      throw input_error("parameter '" + parameter + "' needs from_ and to (in " + std::string(column_name(req.parameter)) + "'s unit)");
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
    const continuation_result res = interruptible(py::none(), [&](const auto&) { return continue_branch(req); });
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
  });
}

// Measurement records, read and written as the command line does.
void bind_records(py::module_& m) {
  m.def("_read_record", [](const std::string& path) { return record_to_python(read_record(path)); });

  m.def("_write_record", [](const std::string& path, const std::map<std::string, std::vector<double>>& columns,
                            const std::map<std::string, std::string>& metadata, const std::vector<std::string>& order, bool force) {
    check_output_file(path, {}, force);  // the command line's rule: never replace a file rubref did not write
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
  });
}

// Identification, golden-case validation and the virtual rig.
void bind_identification(py::module_& m) {
  m.def("_identify", [](const std::vector<std::string>& paths, std::optional<double> clearance, std::optional<py::dict> linear,
                        const std::string& averaging, const std::string& law_method, const std::string& library, double rho, bool orbit_fit,
                        bool reidentify, const std::vector<std::string>& reid_fit, int bootstrap) {
    identify_settings s;
    if (linear) s.linear = parameters_from(std::nullopt, *linear);  // the linear part known: the parameter file's keys
    if (clearance) s.clearance = *clearance;
    s.average = parse_averaging(averaging);
    s.law_route = parse_law_method(law_method);
    s.library = library;
    s.frols.rho = rho;
    s.orbit_fit = orbit_fit;
    s.reidentify = reidentify;
    s.reid.fit = reid_fit;
    s.bootstrap = bootstrap;
    s.validate();  // every setting by its registry row (the message names the keyword), before the records are read
    const auto records = read_records(paths);
    const identification id = interruptible(py::none(), [&](const auto&) { return identify(records, s); });
    for (const auto& w : id.warnings) warn(w);
    return to_python(to_json(id, s));
  });

  m.def("_validate", [](const std::string& case_path, const std::string& candidate_path) {
    const golden_case g = read_golden_case(read_record(case_path), case_path);
    const record candidate = read_record(candidate_path);
    const validation_result r = interruptible(py::none(), [&](const auto&) { return validate_candidate(g, candidate, candidate_path); });
    return to_python(to_json(r));
  });

  m.def("_rig", [](const std::vector<std::string>& effects, std::optional<std::vector<double>> speeds, std::optional<double> noise, bool keyphasor,
                   bool carry_over, int settle_revs, int revs, unsigned seed, const std::string& variant, std::optional<double> clearance,
                   const py::dict& params) {
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
    const rig_output o = interruptible(py::none(), [&](const auto&) { return run_rig(req); });
    py::dict d = record_to_python(o.measurement);
    d["truth"] = to_python(o.truth);
    return d;
  });
}

// The loop, on time records and on order-tracked tables.
void bind_loop(py::module_& m) {
  m.def("_loop", [](const std::vector<std::string>& paths, std::optional<double> clearance, std::optional<double> mass, int max_effects,
                    const py::object& progress) {
    loop_settings s;
    if (clearance) s.clearance = *clearance;
    if (mass) s.mass = *mass;
    s.max_effects = max_effects;
    s.validate();  // every setting by its registry row (the message names the keyword), before the records are read
    const auto records = read_records(paths);
    const loop_result r = interruptible(progress, [&](const auto& report) {
      loop_settings with_progress = s;
      with_progress.progress = [&report](const std::string& line) { report(line); };
      return run_loop(records, with_progress);
    });
    for (const auto& w : r.warnings) warn(w);
    return to_python(to_json(r));
  });

  // Order-tracked tables (docs/real-data.md): the conventions a file does not declare, as keyword
  // arguments; probe angles as {name: degrees} ("" for a table's only probe).
  const auto conventions_of = [](const std::string& amplitude, const std::string& amplitude_unit, const std::string& phase,
                                 const std::string& phase_unit, std::optional<double> scale, const std::map<std::string, double>& probe_angles) {
    order_conventions c;
    c.amplitude = amplitude, c.amplitude_unit = amplitude_unit, c.phase = phase, c.phase_unit = phase_unit, c.scale_mV_per_um = scale;
    for (const auto& [name, deg] : probe_angles) c.probe_angles_deg.emplace_back(name, deg);
    return c;
  };
  m.def("_read_order_table", [conventions_of](const std::string& path, const std::string& amplitude, const std::string& amplitude_unit,
                                              const std::string& phase, const std::string& phase_unit, std::optional<double> scale,
                                              const std::map<std::string, double>& probe_angles) {
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
    if (!t.time_s.empty()) out["time_s"] = to_array(t.time_s);
    out["orders"] = orders;
    out["notes"] = t.notes;
    out["conventions"] = t.conventions;
    return out;
  });
  m.def("_loop_table", [conventions_of](const std::string& path, const std::string& amplitude, const std::string& amplitude_unit,
                                        const std::string& phase, const std::string& phase_unit, std::optional<double> scale,
                                        const std::map<std::string, double>& probe_angles, double revolutions_per_row, double sweep_rate,
                                        const py::object& progress) {
    const order_table t = read_order_table(path, conventions_of(amplitude, amplitude_unit, phase, phase_unit, scale, probe_angles));
    tracking_settings settings;
    settings.revolutions_per_row = revolutions_per_row;
    settings.sweep_rate_rpm_per_s = sweep_rate;
    const tracking_result r = interruptible(progress, [&](const auto& report) {
      return run_tracking_loop(t, [&report](const std::string& line) { report(line); }, settings);
    });
    return to_python(to_json(r));
  });
  m.def("_is_order_table", [](const std::string& path) { return is_order_table_header(header_of(path)); });
}

// Parameter studies.
void bind_studies(py::module_& m) {
  // A parameter study into the folder `out` (docs/studies.md): the points of `shard` not yet
  // there, then the results when that completes the study. No figures (the command line draws
  // them, or scripts/plot_study.py on the folder).
  const auto summary_of = [](const std::string& dir) {
    std::ifstream in(std::filesystem::path(dir) / "summary.json");
    return to_python(nlohmann::ordered_json::parse(in));
  };
  m.def("_study", [summary_of](const std::string& spec_text, const std::string& source, const std::string& out, const std::string& shard,
                               unsigned threads, const py::object& progress) {
    const study::spec s = study::parse_spec(spec_text, source);
    study::run_settings rs;
    rs.part = study::parse_shard(shard);
    rs.threads = threads;
    const study::run_outcome o = interruptible(progress, [&](const auto& report) {
      line_streambuf buffer(report);
      std::ostream stream(&buffer);
      study::run_settings with_progress = rs;
      with_progress.progress = progress.is_none() ? nullptr : &stream;
      return study::run_study(out, s, with_progress);
    });
    py::dict d;
    d["computed"] = o.computed;
    d["already"] = o.already;
    d["complete"] = o.complete;
    d["summary"] = o.complete && rs.part.of == 1 ? summary_of(out) : py::none();
    if (o.results.problems > 0) warn(std::to_string(o.results.problems) + " point(s) have no steady result (see summary['problems'])");
    return d;
  });
  m.def("_study_merge", [summary_of](const std::vector<std::string>& dirs, const std::string& out, unsigned threads) {
    std::vector<std::filesystem::path> paths(dirs.begin(), dirs.end());
    interruptible(py::none(), [&](const auto&) {
      study::merge_study(paths, out, threads);
      return true;
    });
    return summary_of(out);
  });
}

}  // namespace

PYBIND11_MODULE(_rubref, m) {
  // The public functions are python/rubref/__init__.py's: they check keywords and types, carry the
  // docstrings and the defaults, and call these with every argument given.
  bind_module(m);
  bind_settings(m);
  bind_runs(m);
  bind_orbits(m);
  bind_records(m);
  bind_identification(m);
  bind_loop(m);
  bind_studies(m);
}
