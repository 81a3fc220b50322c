#include "ref/rig/rig.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/base/portable_random.hpp"
#include "ref/base/version.hpp"
#include "ref/format/record.hpp"
#include "ref/model/parameter_io.hpp"
#include "ref/run/simulate.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

namespace {


struct truth_samples {
  std::vector<std::array<double, 6>> s;
  std::vector<double> angle;  // rad, shaft angle at each sample
};

// One dwell: `settle_revs` revolutions from `start` (rest, or the previous dwell's end), then
// `count` samples. The dwell's clock starts at 0 with the shaft angle w t; `end` is its last state.
template <class Law>
truth_samples run_dwell(const rig_request& req, double rpm, std::size_t count, const std::array<double, 6>& start,
                        std::array<double, 6>* end) {
  const rotor_with_effects<Law> model(req.params, req.effects, rpm_to_rad_s(rpm), req.unmodelled);
  const double t0 = req.settle_revs * model.period(), dt = 1.0 / req.probes.sample_rate;
  struct keep {
    const rotor_with_effects<Law>* model;
    truth_samples* out;
    void on_sample(double t, const std::array<double, 6>& x, const rotor_with_effects<Law>&) {
      out->s.push_back(x);
      out->angle.push_back(model->shaft_angle(t));
    }
    void on_event(const basic_contact_event<std::array<double, 6>>&) {}
  };
  truth_samples out;
  keep obs{&model, &out};
  const auto last = integrate_hybrid(model, start_state(model, start, 0.0), t0 + static_cast<double>(count) * dt, req.integration,
                                     sample_grid{t0, dt, count}, obs);
  if (end) *end = last.s;
  return out;
}

// The probes: turned by the misorientation, reading the shaft surface's runout, with white noise,
// quantised.
void measure(const rig_request& req, const truth_samples& truth, std::size_t dwell, std::vector<double>& x, std::vector<double>& y,
             std::vector<double>& keyphasor) {
  portable_stream noise(req.probes.seed, dwell);  // one stream per dwell: thread-independent, the same draws on any toolchain
  const auto quantise = [&](double v) { return req.probes.quantisation > 0.0 ? std::round(v / req.probes.quantisation) * req.probes.quantisation : v; };
  const double two_pi = 2.0 * std::numbers::pi;
  for (std::size_t i = 0; i < truth.s.size(); ++i) {
    const auto& s = truth.s[i];
    const double psi = truth.angle[i];
    const auto [xm, ym] = probe_reading(req.effects, s[idx::x], s[idx::y], psi);
    x.push_back(quantise((1.0 + req.unmodelled.probe_gain_x) * xm + req.probes.noise * noise.normal()));
    y.push_back(quantise(ym + req.probes.noise * noise.normal()));
    const double now = std::floor((psi + req.probes.keyphasor_angle) / two_pi);
    const double before = i > 0 ? std::floor((truth.angle[i - 1] + req.probes.keyphasor_angle) / two_pi) : now;
    keyphasor.push_back(now > before ? 1.0 : 0.0);
  }
}

}  // namespace

void validate(const rig_request& req) {
  validate(req.params);
  const bool compliant = visit_variant(req.variant, []<class V>() { return compliant_law<V>; });
  require(compliant, "the rig's truth needs a contact force law; '" + req.variant + "' is an impact map");
  require(!req.speeds_rpm.empty(), "the rig needs at least one speed");
  for (const double rpm : req.speeds_rpm)
    require(std::isfinite(rpm) && rpm > 0.0 && rpm <= kMaxSpeedRpm, "speed " + format_number(rpm) + " rpm must be finite, > 0 and <= " + format_number(kMaxSpeedRpm));
  check({"rig", "settle_revs"}, req.settle_revs);
  check({"rig", "record_revs"}, req.record_revs);
  const auto& pr = req.probes;
  check({"rig", "sample_rate"}, pr.sample_rate);
  check({"rig", "noise"}, pr.noise);
  check({"rig", "quantisation"}, pr.quantisation);
  require(std::isfinite(pr.keyphasor_angle), "keyphasor angle must be finite");
  require(pr.keyphasor || req.time_base == rig_time_base::shaft,
          "a record without a keyphasor needs shaft-synchronous time (time base 'shaft'), else no tool can tell the shaft angle");
  const auto& fl = req.unmodelled.drive;
  require(std::isfinite(fl.amplitude) && fl.amplitude >= 0.0 && fl.amplitude < 0.5, "speed fluctuation amplitude must be in [0, 0.5)");
  require(fl.amplitude == 0.0 || (std::isfinite(fl.frequency) && fl.frequency > 0.0), "speed fluctuation needs a frequency > 0 Hz");
  require(std::isfinite(req.unmodelled.cubic_stiffness) && req.unmodelled.cubic_stiffness >= 0.0 && req.unmodelled.cubic_stiffness <= 1e13,
          "cubic support stiffness must be in [0, 1e13] N/m^3");
  require(std::isfinite(req.unmodelled.probe_gain_x) && std::abs(req.unmodelled.probe_gain_x) <= 0.5, "x probe gain error must be in [-0.5, 0.5]");
  for (const auto& e : effect_library())
    for (const auto& q : e.parameters) {
      const double v = req.effects.*q.member;
      require(std::isfinite(v) && ((q.is_switch && v == q.off) || (v >= q.lo && v <= q.hi)),
              "effect " + std::string(e.name) + ": " + std::string(q.key) + " = " + format_number(v) + " is outside [" + format_number(q.lo) + ", " + format_number(q.hi) + "]");
    }
  double samples = 0.0;
  for (const double rpm : req.speeds_rpm) samples += req.record_revs * 60.0 / rpm * pr.sample_rate;
  require(samples <= 1e8, "the record would hold over 1e8 samples");
  // Each dwell is a run from rest: the slowest speed's is the longest.
  const double slowest = *std::min_element(req.speeds_rpm.begin(), req.speeds_rpm.end());
  require_safe_rates(req.params, compliant, (req.settle_revs + req.record_revs) * 60.0 / slowest);
}

rig_output run_rig(const rig_request& req) {
  validate(req);
  const std::size_t n = req.speeds_rpm.size();
  std::vector<std::size_t> counts(n);
  for (std::size_t i = 0; i < n; ++i)
    counts[i] = static_cast<std::size_t>(std::floor(req.record_revs * 60.0 / req.speeds_rpm[i] * req.probes.sample_rate));
  std::vector<truth_samples> truth(n);
  const auto dwell = [&](std::size_t i, const std::array<double, 6>& start, std::array<double, 6>* end) {
    truth[i] = visit_variant(req.variant, [&]<class V>() {
      if constexpr (compliant_law<V>) {
        return run_dwell<V>(req, req.speeds_rpm[i], counts[i], start, end);
      } else {
        return truth_samples{};  // rejected by validate
      }
    });
  };
  if (req.carry_over) {  // a run-up: each dwell from where the previous one ended
    std::array<double, 6> state{};
    for (std::size_t i = 0; i < n; ++i) dwell(i, state, &state);
  } else {
    parallel_for(n, 0, [&](std::size_t i) { dwell(i, std::array<double, 6>{}, nullptr); });
  }

  std::vector<double> t, x, y, rpm, kp;
  const double dt = 1.0 / req.probes.sample_rate;
  std::size_t k = 0;  // the acquisition clock runs on across dwells
  double last = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < n; ++i) {
    measure(req, truth[i], i, x, y, kp);
    // Shaft time: the dwell's own clock (shaft angle w t), moved on by whole periods of its speed
    // so that time increases across the file (docs/data-format.md).
    const double period = 60.0 / req.speeds_rpm[i], first = req.settle_revs * period;
    const double periods = std::max(0.0, std::ceil((last + 0.5 * dt - first) / period));
    for (std::size_t j = 0; j < truth[i].s.size(); ++j, ++k) {
      t.push_back(req.time_base == rig_time_base::acquisition ? static_cast<double>(k) * dt
                                                               : first + static_cast<double>(j) * dt + periods * period);
      rpm.push_back(req.speeds_rpm[i]);
    }
    if (!t.empty()) last = t.back();
  }

  rig_output out;
  record& r = out.measurement;
  const bool shaft_time = req.time_base == rig_time_base::shaft;
  r.set("description", std::string("virtual rig: rotor kit, two proximity probes (x at 0 deg, y at 90 deg)") +
                           (req.probes.keyphasor ? ", keyphasor" : "") +
                           (shaft_time ? "; t_s is shaft-synchronous (shaft angle w t_s)" : "; t_s is the acquisition clock"));
  if (!req.minimal_header) {
    r.set("generator", "rubref " + std::string(version()) + " rig");
    r.set("commit", std::string(commit()));
  }
  r.set("clearance_m", req.params.clearance);
  if (!req.minimal_header) r.set("m_kg", req.params.m);
  r.set("sample_rate_hz", req.probes.sample_rate);
  if (req.probes.keyphasor && !req.minimal_header)
    r.set("keyphasor", "column keyphasor: 1 at the first sample after the shaft's notch passes its probe");
  r.add_column("t_s", std::move(t));
  r.add_column("x_m", std::move(x));
  r.add_column("y_m", std::move(y));
  r.add_column("speed_rpm", std::move(rpm));
  if (req.probes.keyphasor) r.add_column("keyphasor", std::move(kp));

  nlohmann::ordered_json& j = out.truth;
  j["generator"] = "rubref " + std::string(version()) + " rig";
  j["variant"] = req.variant;
  j["parameters"] = to_json(req.params);
  j["effects"] = nlohmann::ordered_json::array();
  for (const auto& e : effect_library()) {
    if (!has_effect(req.effects, e)) continue;
    nlohmann::ordered_json params;
    for (const auto& q : e.parameters) params[std::string(q.key)] = req.effects.*q.member;
    j["effects"].push_back({{"name", e.name}, {"params", params}});
  }
  j["speed_fluctuation"] = {{"amplitude", req.unmodelled.drive.amplitude}, {"frequency_hz", req.unmodelled.drive.frequency}};
  j["unmodelled"] = {{"cubic_stiffness_N_m3", req.unmodelled.cubic_stiffness}, {"probe_gain_x", req.unmodelled.probe_gain_x}};
  j["probes"] = {{"sample_rate_hz", req.probes.sample_rate},
                 {"noise_m", req.probes.noise},
                 {"quantisation_m", req.probes.quantisation},
                 {"keyphasor_angle_rad", req.probes.keyphasor_angle},
                 {"seed", req.probes.seed},
                 {"keyphasor", req.probes.keyphasor}};
  j["time_base"] = shaft_time ? "shaft" : "acquisition";
  j["carry_over"] = req.carry_over;
  j["integration"] = {{"stepper", std::string(to_string(req.integration.stepper.kind))},
                      {"rtol", req.integration.stepper.rtol},
                      {"atol", req.integration.stepper.atol},
                      {"dt_s", req.integration.stepper.dt}};
  j["speeds_rpm"] = req.speeds_rpm;
  j["settle_revs"] = req.settle_revs;
  j["record_revs"] = req.record_revs;
  return out;
}

}  // namespace rubref
