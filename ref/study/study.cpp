#include "ref/study/study.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <nlohmann/json.hpp>

#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"
#include "ref/base/portable_random.hpp"
#include "ref/model/parameter_io.hpp"
#include "variants/all_variants.hpp"

namespace rubref::study {

namespace {

using json = nlohmann::json;

// Largest study: far beyond any cluster's budget, it only keeps the index arithmetic exact.
constexpr std::size_t kMaxPoints = std::size_t{1} << 40;
constexpr std::size_t kMaxAxisValues = 1'000'000;

// A SPEC problem at 'where' (a key path such as grid[1].count): the one-line message.
[[noreturn]] void bad(const std::string& source, const std::string& where, const std::string& problem) {
  throw input_error("SPEC " + source + ": key '" + where + "': " + problem);
}

// Unknown keys of an object are errors, with the nearest known one.
void only_keys(const json& j, const std::vector<std::string>& known, const std::string& source, const std::string& where) {
  for (const auto& [key, value] : j.items())
    if (std::find(known.begin(), known.end(), key) == known.end())
      bad(source, where.empty() ? key : where + "." + key, "unknown key" + did_you_mean(key, known) + " (known: " + [&] {
            std::string list;
            for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
            return list;
          }() + ")");
}

double number(const json& j, const std::string& source, const std::string& where) {
  if (!j.is_number()) bad(source, where, "must be a number (got " + j.dump() + ")");
  const double v = j.get<double>();
  if (!std::isfinite(v)) bad(source, where, "must be finite");
  return v;
}

long long whole(const json& j, const std::string& source, const std::string& where, long long lo, long long hi) {
  if (!j.is_number_integer() && !(j.is_number_float() && std::floor(j.get<double>()) == j.get<double>()))
    bad(source, where, "must be a whole number (got " + j.dump() + ")");
  const double v = j.get<double>();
  if (v < static_cast<double>(lo) || v > static_cast<double>(hi))
    bad(source, where, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "] (got " + j.dump() + ")");
  return static_cast<long long>(v);
}

// A job's value checked by its registry row; the message names the SPEC's key.
double job_value(const json& j, const std::string& source, const std::string& key, setting_key row) {
  const std::string where = "job." + key;
  const double v = number(j, source, where);
  if (const std::string why = violation(*row.row, v, "key '" + where + "'"); !why.empty()) throw input_error("SPEC " + source + ": " + why);
  return v;
}

std::string text(const json& j, const std::string& source, const std::string& where) {
  if (!j.is_string()) bad(source, where, "must be a string (got " + j.dump() + ")");
  return j.get<std::string>();
}

template <class E>
E choice(const json& j, const std::vector<std::pair<std::string, E>>& options, const std::string& source, const std::string& where) {
  const std::string s = text(j, source, where);
  std::vector<std::string> names;
  for (const auto& [name, value] : options) {
    if (name == s) return value;
    names.push_back(name);
  }
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  bad(source, where, "unknown value '" + s + "'" + did_you_mean(s, names) + " (one of: " + list + ")");
}

const std::vector<std::pair<std::string, study_kind>> kKinds = {
    {"regime_map", study_kind::regime_map}, {"basins", study_kind::basins}, {"monte_carlo", study_kind::monte_carlo}, {"grid", study_kind::grid}};
const std::vector<std::pair<std::string, job_kind>> kJobs = {
    {"orbit", job_kind::orbit}, {"simulate", job_kind::simulate}, {"run_up", job_kind::run_up}, {"loop", job_kind::loop}};
const std::vector<std::pair<std::string, distribution>> kLaws = {
    {"uniform", distribution::uniform}, {"normal", distribution::normal}, {"log_uniform", distribution::log_uniform}};
const std::vector<std::string> kStarts = {"contact_free", "state", "rest"};

template <class E>
std::string name_of(E value, const std::vector<std::pair<std::string, E>>& options) {
  for (const auto& [name, v] : options)
    if (v == value) return name;
  return "?";
}

// How a variable's value enters a point.
// effect.<effect>.<key> -> the member of effect_parameters; nullptr if it names none.
double effect_parameters::*effect_member(const std::string& name) {
  if (name.rfind(kEffectPrefix, 0) != 0) return nullptr;
  const std::string rest = name.substr(std::string(kEffectPrefix).size());
  const auto dot = rest.find('.');
  if (dot == std::string::npos) return nullptr;
  for (const auto& e : effect_library())
    if (e.name == rest.substr(0, dot))
      for (const auto& info : e.parameters)
        if (info.key == rest.substr(dot + 1)) return info.member;
  return nullptr;
}

std::vector<std::string> effect_variable_names() {
  std::vector<std::string> names;
  for (const auto& e : effect_library())
    for (const auto& info : e.parameters) names.push_back(std::string(kEffectPrefix) + std::string(e.name) + "." + std::string(info.key));
  return names;
}

void assign(point& p, const std::string& name, double v) {
  if (name == kSpeed) {
    p.rpm = v;
    return;
  }
  if (name == kNoise) {
    p.noise = v;
    return;
  }
  if (const auto member = effect_member(name)) {
    p.effects.*member = v;
    return;
  }
  for (int i = 0; i < 4; ++i)
    if (name == kInitialState[i]) {
      p.initial[static_cast<std::size_t>(i)] = v;
      return;
    }
  for (const auto& info : parameter_table)
    if (info.key == name) {
      p.params.*info.member = v;
      return;
    }
}

std::string checked_variable(const json& j, const std::string& source, const std::string& where) {
  const std::string name = text(j, source, where);
  auto names = variable_names();
  if (std::find(names.begin(), names.end(), name) != names.end() || effect_member(name) != nullptr) return name;
  if (name.rfind(kEffectPrefix, 0) == 0) names = effect_variable_names();
  bad(source, where, "'" + name + "' is not a parameter a study can vary" + did_you_mean(name, names));
}

axis parse_axis(const json& j, const std::string& source, const std::string& where) {
  if (!j.is_object()) bad(source, where, "must be an object {\"name\": ..., \"values\": [...]} or {\"name\": ..., \"from\", \"to\", \"count\" | \"step\"}");
  only_keys(j, {"name", "values", "from", "to", "count", "step"}, source, where);
  if (!j.contains("name")) bad(source, where + ".name", "is missing");
  axis a;
  a.name = checked_variable(j["name"], source, where + ".name");
  if (j.contains("values")) {
    if (j.contains("from") || j.contains("to") || j.contains("count") || j.contains("step"))
      bad(source, where, "give either 'values' or 'from'/'to' with 'count' or 'step', not both");
    if (!j["values"].is_array() || j["values"].empty()) bad(source, where + ".values", "must be a non-empty array of numbers");
    if (j["values"].size() > kMaxAxisValues) bad(source, where + ".values", "has more than " + std::to_string(kMaxAxisValues) + " values");
    for (std::size_t i = 0; i < j["values"].size(); ++i)
      a.values.push_back(number(j["values"][i], source, where + ".values[" + std::to_string(i) + "]"));
    return a;
  }
  for (const char* key : {"from", "to"})
    if (!j.contains(key)) bad(source, where + "." + key, "is missing (or give 'values')");
  const double from = number(j["from"], source, where + ".from"), to = number(j["to"], source, where + ".to");
  if (j.contains("count") == j.contains("step")) bad(source, where, "give exactly one of 'count' and 'step'");
  if (j.contains("count")) {
    const auto n = static_cast<std::size_t>(whole(j["count"], source, where + ".count", 1, static_cast<long long>(kMaxAxisValues)));
    if (n == 1 && from != to) bad(source, where + ".count", "must be >= 2 when 'from' and 'to' differ");
    for (std::size_t i = 0; i < n; ++i)  // both ends exact
      a.values.push_back(n == 1 ? from : (from * static_cast<double>(n - 1 - i) + to * static_cast<double>(i)) / static_cast<double>(n - 1));
  } else {
    const double step = number(j["step"], source, where + ".step");
    if (!(step > 0.0)) bad(source, where + ".step", "must be > 0");
    if (to < from) bad(source, where + ".to", "must be >= 'from' with a 'step' (use 'count' to go downward)");
    const double n = std::floor((to - from) / step * (1.0 + 1e-12)) + 1.0;
    if (n > static_cast<double>(kMaxAxisValues)) bad(source, where + ".step", "gives more than " + std::to_string(kMaxAxisValues) + " values");
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) a.values.push_back(from + step * static_cast<double>(i));
  }
  return a;
}

random_variable parse_random(const json& j, const std::string& source, const std::string& where) {
  if (!j.is_object()) bad(source, where, "must be an object {\"name\": ..., \"uniform\" | \"normal\" | \"log_uniform\": [a, b]}");
  only_keys(j, {"name", "uniform", "normal", "log_uniform"}, source, where);
  if (!j.contains("name")) bad(source, where + ".name", "is missing");
  random_variable r;
  r.name = checked_variable(j["name"], source, where + ".name");
  int laws = 0;
  for (const auto& [law_name, law] : kLaws) {
    if (!j.contains(law_name)) continue;
    ++laws;
    const json& ab = j[law_name];
    const std::string w = where + "." + law_name;
    if (!ab.is_array() || ab.size() != 2) bad(source, w, "must be a pair [a, b]");
    r.law = law;
    r.a = number(ab[0], source, w + "[0]");
    r.b = number(ab[1], source, w + "[1]");
    if (law == distribution::normal && !(r.b > 0.0)) bad(source, w + "[1]", "the standard deviation must be > 0");
    if (law != distribution::normal && !(r.a < r.b)) bad(source, w, "needs a < b");
    if (law == distribution::log_uniform && !(r.a > 0.0)) bad(source, w + "[0]", "must be > 0 for a log-uniform law");
  }
  if (laws != 1) bad(source, where, "give exactly one distribution: uniform, normal or log_uniform");
  return r;
}

job_settings parse_job(const json& given, study_kind kind, const std::string& source) {
  job_settings job;
  job.kind = kind == study_kind::monte_carlo ? job_kind::run_up : job_kind::orbit;
  if (kind == study_kind::basins) job.start = "state";
  const json j = given.is_null() ? json::object() : given;  // no "job": the kind's defaults, checked the same way
  if (!j.is_object()) bad(source, "job", "must be an object");
  only_keys(j, {"type", "start", "settle_revs", "settle_rounds", "max_period", "record_revs", "samples_per_rev", "from_rpm", "to_rpm",
                "speeds_rpm", "noise_m", "keyphasor"},
            source, "job");
  if (j.contains("type")) job.kind = choice(j["type"], kJobs, source, "job.type");
  if (job.kind == job_kind::loop) {  // the rig's defaults (ref/rig/rig.hpp)
    job.settle_revs = rig_request{}.settle_revs;
    job.record_revs = rig_request{}.record_revs;
  }
  for (const char* key : {"speeds_rpm", "noise_m", "keyphasor"})
    if (j.contains(key) && job.kind != job_kind::loop) bad(source, std::string("job.") + key, "belongs to a loop job only");
  if (j.contains("speeds_rpm")) {
    if (!j["speeds_rpm"].is_array() || j["speeds_rpm"].empty()) bad(source, "job.speeds_rpm", "must be a non-empty array of speeds");
    for (std::size_t i = 0; i < j["speeds_rpm"].size(); ++i)
      job.speeds_rpm.push_back(job_value(j["speeds_rpm"][i], source, "speeds_rpm[" + std::to_string(i) + "]", {"", "rpm"}));
  }
  if (j.contains("noise_m")) job.noise = job_value(j["noise_m"], source, "noise_m", {"rig", "noise"});
  if (j.contains("keyphasor")) {
    if (!j["keyphasor"].is_boolean()) bad(source, "job.keyphasor", "must be true or false");
    job.keyphasor = j["keyphasor"].get<bool>();
  }
  if (j.contains("start")) {
    job.start = text(j["start"], source, "job.start");
    if (std::find(kStarts.begin(), kStarts.end(), job.start) == kStarts.end())
      bad(source, "job.start", "unknown start '" + job.start + "'" + did_you_mean(job.start, kStarts) + " (contact_free, state or rest)");
  }
  const auto count = [&](const char* key, setting_key row, int& field) {
    if (j.contains(key)) field = static_cast<int>(job_value(j[key], source, key, row));
  };
  count("settle_revs", {"study", "settle_revs"}, job.settle_revs);
  count("settle_rounds", {"study", "settle_rounds"}, job.settle_rounds);
  count("record_revs", {"study", "record_revs"}, job.record_revs);
  count("max_period", {"study", "max_period"}, job.max_period);
  count("samples_per_rev", {"study", "samples_per_rev"}, job.samples_per_rev);
  if (j.contains("from_rpm")) job.from_rpm = number(j["from_rpm"], source, "job.from_rpm");
  if (j.contains("to_rpm")) job.to_rpm = number(j["to_rpm"], source, "job.to_rpm");
  // A period is detected in the recorded revolutions: it must fit twice.
  if (job.kind == job_kind::orbit && 2 * job.max_period > job.record_revs)
    bad(source, "job.max_period", "must be at most half of 'record_revs' (" + std::to_string(job.record_revs) + "): a period is recognised when it repeats");
  if (job.kind == job_kind::orbit && job.start != "contact_free" && job.settle_revs == 0)
    bad(source, "job.settle_revs", "must be > 0 when the start is '" + job.start + "': Newton from an arbitrary state may find an orbit that state never reaches");
  if (job.kind == job_kind::run_up) {
    if (!j.contains("from_rpm") || !j.contains("to_rpm")) bad(source, j.contains("from_rpm") ? "job.to_rpm" : "job.from_rpm", "is missing: a run-up needs its speed range");
    if (!(job.from_rpm > 0.0)) bad(source, "job.from_rpm", "must be > 0");
    if (!(job.to_rpm > job.from_rpm)) bad(source, "job.to_rpm", "must be > 'from_rpm'");
  } else if (j.contains("from_rpm") || j.contains("to_rpm")) {
    bad(source, j.contains("from_rpm") ? "job.from_rpm" : "job.to_rpm", "belongs to a run_up job only");
  }
  return job;
}

bool has(const std::vector<std::string>& names, const std::string& n) { return std::find(names.begin(), names.end(), n) != names.end(); }

}  // namespace

std::vector<std::string> variable_names() {
  std::vector<std::string> names{kSpeed};
  for (const char* n : kInitialState) names.emplace_back(n);
  names.emplace_back(kNoise);
  for (const auto& info : parameter_table) names.emplace_back(info.key);
  return names;
}

std::string_view to_string(study_kind k) {
  switch (k) {
    case study_kind::regime_map: return "regime_map";
    case study_kind::basins: return "basins";
    case study_kind::monte_carlo: return "monte_carlo";
    case study_kind::grid: return "grid";
  }
  return "?";
}
std::string_view to_string(job_kind k) {
  switch (k) {
    case job_kind::orbit: return "orbit";
    case job_kind::simulate: return "simulate";
    case job_kind::run_up: return "run_up";
    case job_kind::loop: return "loop";
  }
  return "?";
}

spec parse_spec(const std::string& spec_text, const std::string& source) {
  json j;
  try {
    j = json::parse(spec_text);
  } catch (const json::parse_error& e) {
    throw input_error("SPEC " + source + ": not JSON (" + std::string(e.what()) + ")");
  }
  if (!j.is_object()) throw input_error("SPEC " + source + ": must be a JSON object");
  only_keys(j, {"study", "name", "variant", "parameters", "effects", "speed_rpm", "initial_state", "grid", "sample", "job"}, source, "");
  spec s;
  if (!j.contains("study")) bad(source, "study", "is missing (regime_map, basins, monte_carlo or grid)");
  s.kind = choice(j["study"], kKinds, source, "study");
  if (j.contains("name")) s.name = text(j["name"], source, "name");
  if (j.contains("variant")) {
    s.variant = text(j["variant"], source, "variant");
    const auto names = variant_name_list();
    if (!has(names, s.variant)) bad(source, "variant", "unknown variant '" + s.variant + "'" + did_you_mean(s.variant, names));
  }
  if (j.contains("parameters")) {
    if (!j["parameters"].is_object()) bad(source, "parameters", "must be an object of parameter-file keys ('rubref params')");
    apply_json(s.base, j["parameters"], "SPEC " + source + " key 'parameters'");
    try {
      validate(s.base);
    } catch (const input_error& e) {
      bad(source, "parameters", e.what());
    }
  }
  if (j.contains("effects")) {
    if (!j["effects"].is_array()) bad(source, "effects", "must be an array of effects, each as the rig's " + setting("effects") + " takes one (\"preload:F_y=-4\")");
    for (std::size_t i = 0; i < j["effects"].size(); ++i) {
      const std::string where = "effects[" + std::to_string(i) + "]";
      s.effect_texts.push_back(text(j["effects"][i], source, where));
      try {
        apply_effect(s.effects, s.effect_texts.back());
      } catch (const input_error& e) {
        bad(source, where, e.what());
      }
    }
  }
  if (j.contains("speed_rpm")) {
    s.rpm = number(j["speed_rpm"], source, "speed_rpm");
    if (!(s.rpm > 0.0)) bad(source, "speed_rpm", "must be > 0");
  }
  if (j.contains("initial_state")) {
    const json& st = j["initial_state"];
    if (!st.is_array() || st.size() != 4) bad(source, "initial_state", "must be [x, y, vx, vy] in m and m/s");
    for (std::size_t i = 0; i < 4; ++i) s.initial[i] = number(st[i], source, "initial_state[" + std::to_string(i) + "]");
  }
  std::set<std::string> seen;
  if (j.contains("grid")) {
    if (!j["grid"].is_array() || j["grid"].empty()) bad(source, "grid", "must be a non-empty array of axes");
    for (std::size_t i = 0; i < j["grid"].size(); ++i) {
      const std::string where = "grid[" + std::to_string(i) + "]";
      s.grid.push_back(parse_axis(j["grid"][i], source, where));
      if (!seen.insert(s.grid.back().name).second) bad(source, where + ".name", "'" + s.grid.back().name + "' is varied twice");
    }
  }
  if (j.contains("sample")) {
    const json& sm = j["sample"];
    if (!sm.is_object()) bad(source, "sample", "must be an object {\"count\", \"seed\", \"vary\": [...]}");
    only_keys(sm, {"count", "seed", "vary"}, source, "sample");
    for (const char* key : {"count", "seed", "vary"})
      if (!sm.contains(key)) bad(source, std::string("sample.") + key, "is missing");
    s.samples = static_cast<std::size_t>(whole(sm["count"], source, "sample.count", 1, 1'000'000'000'000LL));
    s.seed = static_cast<std::uint64_t>(whole(sm["seed"], source, "sample.seed", 0, (1LL << 53) - 1));
    if (!sm["vary"].is_array() || sm["vary"].empty()) bad(source, "sample.vary", "must be a non-empty array of random variables");
    for (std::size_t i = 0; i < sm["vary"].size(); ++i) {
      const std::string where = "sample.vary[" + std::to_string(i) + "]";
      s.random.push_back(parse_random(sm["vary"][i], source, where));
      if (!seen.insert(s.random.back().name).second) bad(source, where + ".name", "'" + s.random.back().name + "' is varied twice");
    }
  }
  if (s.grid.empty() && s.random.empty()) bad(source, "grid", "a study needs a 'grid', a 'sample', or both");
  double total = static_cast<double>(s.samples);
  for (const auto& a : s.grid) total *= static_cast<double>(a.values.size());
  if (total > static_cast<double>(kMaxPoints)) bad(source, s.grid.empty() ? "sample.count" : "grid", "gives more than 2^40 points");
  s.job = parse_job(j.contains("job") ? j["job"] : json(), s.kind, source);

  // Values every point shares must make sense before any point runs; the varied ones are
  // checked per point (a row with status "invalid").
  const auto names = varied_names(s);
  for (const auto& a : s.grid)
    if (a.name == kSpeed)
      for (double v : a.values)
        if (!(v > 0.0)) bad(source, "grid", "speed_rpm values must be > 0 (got " + format_number(v) + ")");
  if (s.job.kind == job_kind::run_up && has(names, kSpeed)) bad(source, "job.type", "a run_up job traces the speed itself: vary something else");
  if (s.job.start != "state")
    for (const char* n : kInitialState)
      if (has(names, n)) bad(source, "job.start", std::string("varies ") + n + " but the start is '" + s.job.start + "': use \"state\"");
  bool varies_loop_only = !s.effect_texts.empty();
  for (const auto& n : names) varies_loop_only = varies_loop_only || n == kNoise || effect_member(n) != nullptr;
  if (varies_loop_only && s.job.kind != job_kind::loop)
    bad(source, "job.type", "effects and probe noise enter only a loop job (the other jobs integrate the paper's model)");
  if (s.job.kind == job_kind::loop) {
    if (s.kind != study_kind::grid) bad(source, "job.type", "a loop job belongs to a grid study (a campaign)");
    if (has(names, kSpeed)) bad(source, "job.type", "a loop job's speeds are its dwells (job.speeds_rpm): vary something else");
    try {  // the rig's own checks on the shared settings, before any point runs
      point base;
      base.params = s.base;
      base.effects = s.effects;
      base.noise = s.job.noise;
      validate(rig_request_for(s, base));
    } catch (const input_error& e) {
      bad(source, "job", e.what());
    }
  }
  switch (s.kind) {
    case study_kind::regime_map:
      if (s.grid.size() != 2 || !s.random.empty() || !has(names, "clearance_m") || !has(names, kSpeed))
        bad(source, "grid", "a regime_map is a grid of exactly two axes, clearance_m and speed_rpm (no sample)");
      if (s.job.kind != job_kind::orbit) bad(source, "job.type", "a regime_map's job is orbit");
      break;
    case study_kind::basins:
      if (s.grid.size() != 2 || !s.random.empty()) bad(source, "grid", "a basins study is a grid of exactly two axes (no sample)");
      if (s.job.kind != job_kind::orbit) bad(source, "job.type", "a basins study's job is orbit");
      if (s.job.start == "contact_free") bad(source, "job.start", "a basins study starts from each point's state (\"state\") or from rest, then settles");
      break;
    case study_kind::monte_carlo:
      if (s.random.empty()) bad(source, "sample", "a monte_carlo study needs a 'sample'");
      if (s.job.kind != job_kind::run_up) bad(source, "job.type", "a monte_carlo study's job is run_up");
      break;
    case study_kind::grid: break;
  }
  return s;
}

std::string canonical_text(const spec& s) {
  nlohmann::ordered_json j;
  j["study"] = to_string(s.kind);
  j["name"] = s.name;
  j["variant"] = s.variant;
  j["parameters"] = to_json(s.base);
  if (!s.effect_texts.empty()) j["effects"] = s.effect_texts;
  j["speed_rpm"] = s.rpm;
  j["initial_state"] = {s.initial[0], s.initial[1], s.initial[2], s.initial[3]};
  for (const auto& a : s.grid) j["grid"].push_back({{"name", a.name}, {"values", a.values}});
  if (!s.random.empty()) {
    nlohmann::ordered_json vary = nlohmann::ordered_json::array();
    for (const auto& r : s.random) vary.push_back({{"name", r.name}, {name_of(r.law, kLaws), {r.a, r.b}}});
    j["sample"] = {{"count", s.samples}, {"seed", s.seed}, {"vary", vary}};
  }
  nlohmann::ordered_json job;
  job["type"] = to_string(s.job.kind);
  if (s.job.kind == job_kind::run_up) {
    job["from_rpm"] = s.job.from_rpm;
    job["to_rpm"] = s.job.to_rpm;
  } else if (s.job.kind == job_kind::loop) {
    if (!s.job.speeds_rpm.empty()) job["speeds_rpm"] = s.job.speeds_rpm;
    job["noise_m"] = s.job.noise;
    job["keyphasor"] = s.job.keyphasor;
    job["settle_revs"] = s.job.settle_revs;
    job["record_revs"] = s.job.record_revs;
  } else {
    job["start"] = s.job.start;
    job["settle_revs"] = s.job.settle_revs;
    job["record_revs"] = s.job.record_revs;
  }
  if (s.job.kind == job_kind::orbit) {
    job["settle_rounds"] = s.job.settle_rounds;
    job["max_period"] = s.job.max_period;
  }
  if (s.job.kind != job_kind::loop) job["samples_per_rev"] = s.job.samples_per_rev;
  j["job"] = job;
  return j.dump(2) + "\n";
}

std::size_t point_count(const spec& s) {
  std::size_t n = s.samples;
  for (const auto& a : s.grid) n *= a.values.size();
  return n;
}

std::vector<std::string> varied_names(const spec& s) {
  std::vector<std::string> names;
  for (const auto& a : s.grid) names.push_back(a.name);
  for (const auto& r : s.random) names.push_back(r.name);
  return names;
}

double uniform_draw(std::uint64_t seed, std::size_t index, std::size_t k) {
  // A counter-based stream (ref/base/portable_random.hpp): a point's draws need no state carried
  // from earlier points, and are the same bits on any toolchain.
  return keyed_uniform(seed, static_cast<std::uint64_t>(index), static_cast<std::uint64_t>(k));
}

point point_at(const spec& s, std::size_t index) {
  point p;
  p.index = index;
  p.params = s.base;
  p.rpm = s.rpm;
  p.initial = s.initial;
  p.effects = s.effects;
  p.noise = s.job.noise;
  std::size_t grid_index = index / s.samples;
  std::vector<double> grid_values(s.grid.size());
  for (std::size_t a = s.grid.size(); a-- > 0;) {  // the last axis fastest
    const auto& values = s.grid[a].values;
    grid_values[a] = values[grid_index % values.size()];
    grid_index /= values.size();
  }
  for (std::size_t a = 0; a < s.grid.size(); ++a) {
    p.values.push_back(grid_values[a]);
    assign(p, s.grid[a].name, grid_values[a]);
  }
  for (std::size_t k = 0; k < s.random.size(); ++k) {
    const auto& r = s.random[k];
    const double u = uniform_draw(s.seed, index, k);
    double v = 0.0;
    switch (r.law) {
      case distribution::uniform: v = r.a + (r.b - r.a) * u; break;
      case distribution::normal: v = r.a + r.b * normal_quantile(u); break;
      case distribution::log_uniform: v = log_uniform(r.a, r.b, u); break;
    }
    p.values.push_back(v);
    assign(p, r.name, v);
  }
  return p;
}

}  // namespace rubref::study
