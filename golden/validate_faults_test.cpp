// `rubref validate` against the faults docs/validation.md shows: each is injected into a
// deliberately wrong model, whose output must fail validation with its likely cause named; and
// correct output, sampled its own way, must pass.

#include <gtest/gtest.h>

#include <algorithm>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "ref/golden.hpp"
#include "ref/orbit_io.hpp"
#include "ref/validation.hpp"
#include "variants/all_variants.hpp"

namespace rubref {
namespace {

// Periodic (orbit-compared) cases of the golden set, one per law family under test.
constexpr const char* kIdentifiedCase = "identified_0.3mm_1600rpm.csv";
constexpr const char* kRestitutionCase = "restitution_0.3mm_1650rpm.csv";

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

struct sample_keeper {
  std::vector<orbit_sample> s;
  template <class System>
  void on_sample(double t, const state_type& x, const System& sys) {
    s.push_back({t, x, sys.normal_force(x, t)});
  }
  void on_event(const contact_event&) {}
};

// Another code's output of the case: rubref's model with `p` (not validated: a fault may need
// mu < 0), sampled `per_rev` times a revolution over `revs` revolutions after `settle`.
template <class Law>
record candidate(const golden_case& g, const parameters& p, int settle, int revs, int per_rev) {
  const rotor_system<Law> model(p, g.omega());
  const double period = model.period();
  sample_keeper out;
  const sample_grid grid{settle * period, period / per_rev, static_cast<std::size_t>(revs * per_rev)};
  integrate_hybrid(model, start_state(model, state_type{}, 0.0), (settle + revs) * period, g.request.integration, grid, out);
  orbit o;
  o.request = g.request;
  o.samples = std::move(out.s);
  return as_record(o);
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

bool names(const validation_result& r, const std::string& words) {
  return std::any_of(r.likely_causes.begin(), r.likely_causes.end(),
                     [&](const std::string& c) { return c.find(words) != std::string::npos; });
}

TEST(validate, correct_output_passes_on_the_case_samples_and_on_its_own) {
  for (const char* name : {kIdentifiedCase, kRestitutionCase}) {
    SCOPED_TRACE(name);
    const golden_case g = load(name);
    ASSERT_EQ(g.comparison, comparison_kind::orbit);
    const validation_result same = validate_candidate(g, as_record(simulate(g.request)), "rubref");
    EXPECT_TRUE(same.pass) << to_text(same);
    // Another sampling (100 a revolution), another stretch (3 revolutions after 205): compared
    // by phase with the golden orbit integrated again at those times.
    const record other = keep_for_docs("own_sampling_" + std::string(name),
                                       visit_variant(g.request.variant, [&]<class V>() { return candidate<V>(g, g.request.params, 205, 3, 100); }));
    const validation_result shifted = validate_candidate(g, other, "rubref, own sampling");
    EXPECT_TRUE(shifted.pass) << to_text(shifted);
    EXPECT_NE(shifted.sampling.find("modulo the orbit's period"), std::string::npos) << shifted.sampling;
  }
}

// Friction pushing the rotor's top to -x (f_x = -mu f_N): the sign convention turned around.
TEST(validate, reversed_friction_sign_fails_and_is_named) {
  const golden_case g = load(kIdentifiedCase);
  parameters wrong = g.request.params;
  wrong.mu = -wrong.mu;
  const validation_result r =
      validate_candidate(g, keep_for_docs("friction_reversed.csv", candidate<identified>(g, wrong, 200, 8, 128)), "reversed friction");
  EXPECT_FALSE(r.pass);
  EXPECT_GT(r.max_error, 100.0 * r.tolerance);
  EXPECT_TRUE(names(r, "wrong friction sign")) << to_text(r);
}

// r applied to the kinetic energy instead of the velocity: the rebound speed is sqrt(r) v.
TEST(validate, wrong_coefficient_of_restitution_fails_and_is_named) {
  const golden_case g = load(kRestitutionCase);
  parameters wrong = g.request.params;
  wrong.r = std::sqrt(g.request.params.r);
  const validation_result r =
      validate_candidate(g, keep_for_docs("energy_restitution.csv", candidate<restitution>(g, wrong, 200, 8, 128)), "energy restitution");
  EXPECT_FALSE(r.pass);
  EXPECT_TRUE(names(r, "wrong coefficient of restitution")) << to_text(r);
  EXPECT_TRUE(names(r, "kinetic energy")) << to_text(r);
}

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
    if (s[idx::y] > g.request.params.delta && s[idx::vy] > 0.0) s[idx::vy] = -g.request.params.r * s[idx::vy];
  }
  return as_record(o);
}

TEST(validate, missed_impacts_fail_and_are_named) {
  const golden_case g = load(kRestitutionCase);
  const validation_result r = validate_candidate(g, keep_for_docs("step_end_impacts.csv", naive_restitution(g)), "step-end impacts");
  EXPECT_FALSE(r.pass);
  EXPECT_TRUE(names(r, "missed impacts")) << to_text(r);
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
  const validation_result bad = validate_candidate(g, candidate<identified>(g, wrong, 200, 8, 128), "reversed friction");
  EXPECT_FALSE(bad.pass) << to_text(bad);
}

}  // namespace
}  // namespace rubref
