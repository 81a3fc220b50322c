// `rubref validate` against faults an independent implementation makes: each is injected into a
// candidate made by rubref itself (a deliberately wrong model, start, step or output), which must
// fail with its cause code first in the diagnosis (docs/validation.md, "Causes"); and correct
// output, sampled its own way, must pass.

#include <gtest/gtest.h>

#include <algorithm>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <string>

#include "ref/analysis/orbit_io.hpp"
#include "ref/model/parameter_io.hpp"
#include "ref/validation/golden.hpp"
#include "ref/validation/validate.hpp"
#include "variants/all_variants.hpp"

namespace rubref {
namespace {

// Periodic (orbit-compared) cases of the golden set.
constexpr const char* kIdentifiedCase = "identified_0.3mm_1600rpm.csv";        // period 1
constexpr const char* kRestitutionCase = "restitution_0.3mm_1650rpm.csv";      // period 1, impacts
constexpr const char* kPeriodThreeCase = "identified_0.2mm_1650rpm.csv";       // period 3
constexpr const char* kLinearCase = "piecewise-linear_0.4mm_1600rpm.csv";      // period 1

golden_case load(const std::string& name) {
  return read_golden_case(read_record(std::filesystem::path(RUBREF_GOLDEN_DIR) / name), name);
}

record as_record(const orbit& o) {
  record r;
  orbit_columns cols;
  cols.append(o.samples, o.request.rpm);
  cols.move_into(r);
  return r;
}

// Positions as another code would write them: t_s, x_m, y_m, speed_rpm and nothing else (no
// header: an independent code does not write rubref's).
struct samples {
  std::vector<double> t, x, y;
};

record to_record(const samples& s, double rpm) {
  record r;
  r.add_column("t_s", s.t);
  r.add_column("x_m", s.x);
  r.add_column("y_m", s.y);
  r.add_column("speed_rpm", std::vector<double>(s.t.size(), rpm));
  return r;
}

// Another code's run of the case: `model` from rest at t = t_start, sampled `per_rev` times a
// revolution over `revs` revolutions from t = settle T (absolute time).
template <class Model>
samples run_of(const Model& model, double t_start, int settle, int revs, int per_rev, const integration_options& opt) {
  const double T = model.period();
  std::vector<double> times;
  for (int k = 0; k < revs * per_rev; ++k) times.push_back(settle * T + k * T / per_rev);
  struct keeper {
    samples s;
    void on_sample(double t, const state_of<Model>& x, const Model&) {
      s.t.push_back(t);
      s.x.push_back(x[idx::x]);
      s.y.push_back(x[idx::y]);
    }
    void on_event(const basic_contact_event<state_of<Model>>&) {}
  } out;
  integrate_hybrid(model, start_state(model, state_of<Model>{}, t_start), times.back(), opt, sample_grid::at(times), out);
  return out.s;
}

// The case's model with other parameters (not validated: a fault may need mu < 0) or rotation.
samples wrong_model(const golden_case& g, const parameters& p, double omega_sign = 1.0, double t_start = 0.0, int settle = 200) {
  return visit_variant(g.request.variant, [&]<class Law>() {
    return run_of(rotor_system<Law>(p, omega_sign * g.omega()), t_start, settle, 8, 128, g.request.integration);
  });
}

// With RUBREF_FAULT_CANDIDATES_DIR set, the candidates are also written there, for the worked
// examples of docs/validation.md (scripts/update-doc-validation).
record keep_for_docs(const std::string& file, record r) {
  if (const char* dir = std::getenv("RUBREF_FAULT_CANDIDATES_DIR")) {
    std::ofstream out(std::filesystem::path(dir) / file);
    out << to_csv(r);
  }
  return r;
}

// With RUBREF_FAULT_CANDIDATES_DIR set, each fault's diagnosis is also appended to faults.jsonl
// there, and the vocabulary written to causes.json: the tables of docs/validation.md.
void keep_outcome_for_docs(const validation_result& r) {
  const char* dir = std::getenv("RUBREF_FAULT_CANDIDATES_DIR");
  if (!dir) return;
  std::ofstream(std::filesystem::path(dir) / "faults.jsonl", std::ios::app)
      << nlohmann::ordered_json{{"fault", r.candidate_name}, {"case", r.case_name}, {"max_error_m", r.max_error},
                                {"first", r.causes.empty() ? nlohmann::ordered_json() : to_json(r.causes.front())}}
             .dump()
      << "\n";
  nlohmann::ordered_json vocabulary = nlohmann::ordered_json::array();
  for (const auto& c : cause_table) vocabulary.push_back({{"code", c.name}, {"meaning", c.meaning}});
  std::ofstream(std::filesystem::path(dir) / "causes.json") << vocabulary.dump(1) << "\n";
}

// The fault's code is the first cause, with the expected confidence.
void expect_first(const validation_result& r, cause_code code, cause_confidence confidence = cause_confidence::confirmed) {
  keep_outcome_for_docs(r);
  EXPECT_FALSE(r.pass) << to_text(r);
  ASSERT_FALSE(r.causes.empty()) << to_text(r);
  EXPECT_EQ(to_string(r.causes.front().code), to_string(code)) << to_text(r);
  EXPECT_EQ(to_string(r.causes.front().confidence), to_string(confidence)) << to_text(r);
}

TEST(validate, correct_output_passes_on_the_case_samples_and_on_its_own) {
  for (const char* name : {kIdentifiedCase, kRestitutionCase, kPeriodThreeCase}) {
    SCOPED_TRACE(name);
    const golden_case g = load(name);
    ASSERT_EQ(g.comparison, comparison_kind::orbit);
    const validation_result same = validate_candidate(g, as_record(simulate(g.request)), "rubref");
    EXPECT_TRUE(same.pass) << to_text(same);
    EXPECT_TRUE(same.causes.empty());
    // Another sampling (100 a revolution), another stretch (3 revolutions after 205): compared
    // by phase with the golden orbit integrated again at those times.
    const record other = keep_for_docs("own_sampling_" + std::string(name), visit_variant(g.request.variant, [&]<class V>() {
                                         const rotor_system<V> model(g.request.params, g.omega());
                                         return to_record(run_of(model, 0.0, 205, 3, 100, g.request.integration), g.request.rpm);
                                       }));
    const validation_result shifted = validate_candidate(g, other, "rubref, own sampling");
    EXPECT_TRUE(shifted.pass) << to_text(shifted);
    EXPECT_NE(shifted.sampling.find("modulo the orbit's period"), std::string::npos) << shifted.sampling;
    if (g.period_revs == 1) {
      EXPECT_EQ(shifted.candidate_period_revs, 1);  // (3 revolutions cannot show a period of 3)
    }
  }
}

// --- coverage, header, periodicity -------------------------------------------------------------

TEST(validate, less_than_one_period_fails_with_coverage) {
  const golden_case g = load(kIdentifiedCase);
  samples s = wrong_model(g, g.request.params);
  for (auto* v : {&s.t, &s.x, &s.y}) v->resize(20);  // 0.16 of a revolution, each sample exact
  const validation_result r = validate_candidate(g, to_record(s, g.request.rpm), "20 samples (0.16 of a revolution)");
  EXPECT_LE(r.max_error, r.tolerance) << "the samples themselves agree";
  expect_first(r, cause_code::coverage);
  EXPECT_EQ(r.causes.size(), 1u);
}

TEST(validate, a_header_naming_other_values_is_reported_first) {
  const golden_case g = load(kIdentifiedCase);
  run_request req = g.request;
  req.params.k1 *= 1.06;
  record candidate = as_record(simulate(req));
  write_parameters(candidate, req.params);  // as rubref simulate writes them
  const validation_result r = validate_candidate(g, candidate, "a header naming k1 +6 %");
  expect_first(r, cause_code::header_mismatch);
  EXPECT_NEAR(r.causes.front().fitted["k1_N_m"].get<double>(), req.params.k1, 1e-9 * req.params.k1);
}

TEST(validate, a_start_that_lands_on_another_stable_orbit_is_named) {
  // From rest a quarter of a revolution late (an unbalance phase of 90 deg, seen in the case's
  // frame): the period-3 case's rotor settles on a coexisting orbit.
  const golden_case g = load(kPeriodThreeCase);
  const double T = 60.0 / g.request.rpm;
  const validation_result r = validate_candidate(g, keep_for_docs("late_start.csv", to_record(wrong_model(g, g.request.params, 1.0, T / 4), g.request.rpm)),
                         "start from rest a quarter revolution late");
  expect_first(r, cause_code::other_attractor);
}

TEST(validate, an_unsettled_candidate_is_non_periodic) {
  const golden_case g = load(kIdentifiedCase);
  const validation_result r = validate_candidate(g, to_record(wrong_model(g, g.request.params, 1.0, 0.0, 4), g.request.rpm), "recorded after 4 settling revolutions");
  expect_first(r, cause_code::non_periodic, cause_confidence::likely);
  EXPECT_EQ(r.candidate_period_revs, 0);
}

// --- transforms of the output -------------------------------------------------------------------

using transform = std::function<void(samples&)>;

validation_result transformed(const char* name, const std::string& file, const std::string& fault, const transform& f) {
  const golden_case g = load(name);
  samples s = wrong_model(g, g.request.params);
  f(s);
  return validate_candidate(g, keep_for_docs(file, to_record(s, g.request.rpm)), fault);
}

TEST(validate, output_in_millimetres_is_units) {
  const validation_result r = transformed(kIdentifiedCase, "in_mm.csv", "output in mm", [](samples& s) {
    for (auto* v : {&s.x, &s.y})
      for (double& a : *v) a *= 1e3;
  });
  expect_first(r, cause_code::units);
  EXPECT_EQ(r.causes.front().fitted["unit"], "mm");
}

TEST(validate, y_pointing_down_is_a_mirrored_axis) {
  const validation_result r = transformed(kRestitutionCase, "y_down.csv", "y pointing down", [](samples& s) {
    for (double& a : s.y) a = -a;
  });
  expect_first(r, cause_code::mirrored_axis);
}

TEST(validate, times_from_another_origin_are_a_time_shift) {
  const validation_result r = transformed(kPeriodThreeCase, "time_origin.csv", "times from another origin (-12.3 ms)", [](samples& s) {
    for (double& t : s.t) t -= 0.0123;
  });
  expect_first(r, cause_code::time_origin_or_unbalance_phase);
  EXPECT_NEAR(r.causes.front().fitted["time_shift_s"].get<double>(), 0.0123 - 60.0 / 1650.0 * std::round(0.0123 * 1650.0 / 60.0), 1e-9);
}

TEST(validate, a_constant_offset_is_static_offset) {
  const validation_result r = transformed(kLinearCase, "offset.csv", "y offset by 20 um", [](samples& s) {
    for (double& a : s.y) a += 20e-6;
  });
  expect_first(r, cause_code::static_offset);
  EXPECT_NEAR(r.causes.front().fitted["offset_y_m"].get<double>(), 20e-6, 1e-9);
}

// --- the model changed -------------------------------------------------------------------------

validation_result changed(const char* name, const std::string& file, const std::string& fault, const std::function<void(parameters&)>& f,
                          double omega_sign = 1.0) {
  const golden_case g = load(name);
  parameters p = g.request.params;
  f(p);
  return validate_candidate(g, keep_for_docs(file, to_record(wrong_model(g, p, omega_sign), g.request.rpm)), fault);
}

TEST(validate, another_clearance_is_clearance) {
  const validation_result r = changed(kIdentifiedCase, "clearance_0.25mm.csv", "clearance 0.25 mm", [](parameters& p) { p.clearance = 0.25e-3; });
  expect_first(r, cause_code::clearance);
  EXPECT_NEAR(r.causes.front().fitted["clearance_m"].get<double>(), 0.25e-3, 1e-8);  // Brent stops at ~1e-5 of the value: the RMS is flat at its minimum
}

// Friction pushing the rotor's top to -x (f_x = -mu f_N): the sign convention turned around.
TEST(validate, reversed_friction_sign_is_friction_sign) {
  const validation_result r = changed(kIdentifiedCase, "friction_reversed.csv", "friction sign reversed", [](parameters& p) { p.mu = -p.mu; });
  expect_first(r, cause_code::friction_sign);
  EXPECT_GT(r.max_error, 100.0 * r.tolerance);
}

TEST(validate, another_friction_coefficient_is_friction_coefficient) {
  const validation_result r = changed(kLinearCase, "mu_0.3.csv", "mu = 0.3", [](parameters& p) { p.mu = 0.3; });
  expect_first(r, cause_code::friction_coefficient);
  EXPECT_NEAR(r.causes.front().fitted["mu"].get<double>(), 0.3, 1e-5);
}

TEST(validate, k1_six_percent_high_is_a_law_coefficient) {
  const validation_result r = changed(kIdentifiedCase, "k1_plus_6pc.csv", "k1 +6 %", [](parameters& p) { p.k1 *= 1.06; });
  expect_first(r, cause_code::contact_law_coefficient);
  EXPECT_NEAR(r.causes.front().fitted["relative_change"].get<double>(), 0.06, 1e-5);
}

TEST(validate, c2_ten_percent_high_is_a_law_coefficient) {
  const validation_result r = changed(kPeriodThreeCase, "c2_times_1.1.csv", "c2 x 1.1", [](parameters& p) { p.c2 *= 1.1; });
  expect_first(r, cause_code::contact_law_coefficient);
  EXPECT_NEAR(r.causes.front().fitted["relative_change"].get<double>(), 0.1, 1e-4);
}

// r applied to the kinetic energy instead of the velocity: the rebound speed is sqrt(r) v.
TEST(validate, restitution_on_the_energy_is_a_law_coefficient) {
  const validation_result r = changed(kRestitutionCase, "energy_restitution.csv", "r applied to the kinetic energy", [](parameters& p) { p.r = std::sqrt(p.r); });
  expect_first(r, cause_code::contact_law_coefficient);
  EXPECT_NE(r.causes.front().detail.find("kinetic energy"), std::string::npos) << to_text(r);
}

TEST(validate, a_larger_unbalance_is_unbalance) {
  const validation_result r = changed(kLinearCase, "e_times_1.1.csv", "e x 1.1", [](parameters& p) { p.e *= 1.1; });
  expect_first(r, cause_code::unbalance);
}

// sin and cos swapped in the unbalance force: it turns clockwise while friction stays rubref's.
TEST(validate, sin_and_cos_swapped_is_rotation_sense) {
  const validation_result r = changed(kIdentifiedCase, "sin_cos_swapped.csv", "sin and cos swapped in the unbalance force", [](parameters& p) {
    p.mu = -p.mu;  // rubref turns friction with the rotation; this code does not
    p.unbalance_phase = std::numbers::pi / 2;
  }, -1.0);
  expect_first(r, cause_code::rotation_sense);
}

// A code that is rubref's mirror image throughout (shaft, unbalance and friction clockwise).
TEST(validate, a_clockwise_shaft_is_rotation_sense) {
  const validation_result r = changed(kLinearCase, "clockwise.csv", "shaft turning clockwise", [](parameters&) {}, -1.0);
  expect_first(r, cause_code::rotation_sense);
}

// Eq. 5's c2 z_dot^2 written as a damper, c2 |z_dot| z_dot (the diagnosis's own hypothesis law).
TEST(validate, a_damper_for_c2_z_dot_squared_is_the_law_form) {
  const golden_case g = load(kIdentifiedCase);
  const samples s = run_of(rotor_system<abs_damper_law>(g.request.params, g.omega()), 0.0, 200, 8, 128, g.request.integration);
  const validation_result r = validate_candidate(g, keep_for_docs("abs_damper.csv", to_record(s, g.request.rpm)), "c2 |z_dot| z_dot for c2 z_dot^2");
  expect_first(r, cause_code::contact_law_form);
}

// Gravity: a static load m g downwards (the effect library's preload), which the paper's Eq. 1 has not.
TEST(validate, gravity_is_a_static_offset) {
  const golden_case g = load(kLinearCase);
  effect_parameters fx;
  fx.preload_y = -g.request.params.m * 9.80665;
  const samples s = run_of(rotor_with_effects<piecewise_linear>(g.request.params, fx, g.omega()), 0.0, 200, 8, 128, g.request.integration);
  const validation_result r = validate_candidate(g, keep_for_docs("gravity.csv", to_record(s, g.request.rpm)), "gravity (static load m g)");
  expect_first(r, cause_code::static_offset);
}

// --- numerics ----------------------------------------------------------------------------------

// A naive code: fixed RK4 steps of the free rotor (odeint's runge_kutta4, 256 a revolution),
// the impact map applied only when a step ends inside the stator, and the rotor left there.
record naive_restitution(const golden_case& g) {
  constexpr int kStepsPerRev = 256, kEvery = kStepsPerRev / kGoldenSamplesPerRev;
  const rotor_system<restitution> free_rotor(g.request.params, g.omega(), contact_phase::free);
  const double dt = free_rotor.period() / kStepsPerRev;
  boost::numeric::odeint::runge_kutta4<state_type> rk4;
  state_type s{};
  orbit o;
  o.request = g.request;
  const long first = static_cast<long>(g.request.settle_revs) * kStepsPerRev;
  const long last = first + static_cast<long>(g.request.record_revs) * kStepsPerRev;
  for (long k = 0; k < last; ++k) {
    if (k >= first && (k - first) % kEvery == 0) o.samples.push_back({static_cast<double>(k) * dt, s, 0.0});
    rk4.do_step(free_rotor, s, static_cast<double>(k) * dt, dt);
    if (s[idx::y] > g.request.params.clearance && s[idx::vy] > 0.0) s[idx::vy] = -g.request.params.r * s[idx::vy];
  }
  return as_record(o);
}

TEST(validate, impacts_applied_at_step_ends_are_missed_events) {
  const golden_case g = load(kRestitutionCase);
  const validation_result r = validate_candidate(g, keep_for_docs("step_end_impacts.csv", naive_restitution(g)), "impacts applied at RK4 step ends");
  expect_first(r, cause_code::missed_events, cause_confidence::likely);
}

// Eq. 1-2 as written, stepped by a fixed RK4 at 256 steps a revolution with the force switched
// on by z > 0 inside the steps: a contact lasts ~20 steps, and its onset is missed by up to one.
TEST(validate, a_coarse_fixed_step_is_coarse_step) {
  const golden_case g = load(kLinearCase);
  const rotor_system<piecewise_linear> model(g.request.params, g.omega(), contact_phase::by_penetration);
  const double dt = model.period() / 256;
  boost::numeric::odeint::runge_kutta4<state_type> rk4;
  state_type s{};
  samples out;
  for (long k = 0; k < 208L * 256; ++k) {
    if (k >= 200L * 256 && k % 2 == 0) {
      out.t.push_back(static_cast<double>(k) * dt);
      out.x.push_back(s[idx::x]);
      out.y.push_back(s[idx::y]);
    }
    rk4.do_step(model, s, static_cast<double>(k) * dt, dt);
  }
  const validation_result r = validate_candidate(g, keep_for_docs("coarse_rk4.csv", to_record(out, g.request.rpm)), "fixed RK4 step, 256 a revolution, force switched inside steps");
  expect_first(r, cause_code::coarse_step);
  EXPECT_NEAR(r.causes.front().fitted["dt_s"].get<double>(), dt, 1e-12);
}

// A fault outside the vocabulary (horizontal damping 1.5 times): nothing is confirmed.
TEST(validate, a_fault_outside_the_vocabulary_is_none_found) {
  const validation_result r = changed(kIdentifiedCase, "c_x_times_1.5.csv", "c_x x 1.5 (outside the vocabulary)", [](parameters& p) { p.c_x *= 1.5; });
  expect_first(r, cause_code::none_found, cause_confidence::likely);
}

// Statistics cases compare statistics only; a reversed friction still shows in them.
TEST(validate, chaotic_case_compares_statistics) {
  const golden_case g = load("identified_0.3mm_1450rpm.csv");
  ASSERT_EQ(g.comparison, comparison_kind::statistics);
  const validation_result ok = validate_candidate(g, as_record(simulate(g.request)), "rubref");
  EXPECT_TRUE(ok.pass) << to_text(ok);
  EXPECT_TRUE(std::isnan(ok.max_error));
  parameters wrong = g.request.params;
  wrong.mu = -wrong.mu;
  const validation_result bad = validate_candidate(g, to_record(wrong_model(g, wrong), g.request.rpm), "reversed friction");
  EXPECT_FALSE(bad.pass) << to_text(bad);
  EXPECT_FALSE(bad.causes.empty());
}

// Every code of the vocabulary is tested above, and the table has no duplicate.
TEST(validate, the_vocabulary_is_fixed) {
  std::vector<std::string_view> names;
  for (const auto& c : cause_table) names.push_back(c.name);
  std::sort(names.begin(), names.end());
  EXPECT_EQ(std::adjacent_find(names.begin(), names.end()), names.end());
  EXPECT_EQ(names.size(), 18u);
}

}  // namespace
}  // namespace rubref
