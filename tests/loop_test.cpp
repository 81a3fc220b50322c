// The loop end to end (docs/loop.md) on virtual-rig records with an effect nobody declares: the
// rig's truth is the paper's model plus the effect at the library's moderate level, with its
// default probes (0.5 um noise, 61 nm quantisation, 10 kHz, keyphasor 0.7 rad off the
// unbalance). Each scenario is one ctest entry (label `loop`, tests/CMakeLists.txt).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>

#include "ref/loop/loop.hpp"
#include "ref/rig/rig.hpp"

namespace rubref::testing {
namespace {

// "Well below": the error after the trace is at most this share of the error before (docs/loop.md
// lists the measured ratios, 0.02-0.3).
constexpr double kErrorRatio = 0.5;

struct run {
  rig_request req;
  loop_result result;
};

// `rig` sets the probes and records (default: the rig's defaults); the effects are added to it.
run loop_on_rig(const std::vector<std::string>& effects, const rig_request& rig = {}) {
  run out;
  out.req = rig;
  out.req.probes.keyphasor_angle = 0.7;  // the loop does not know where the notch is
  for (const auto& e : effects) apply_effect(out.req.effects, e);
  const rig_output o = run_rig(out.req);
  out.result = run_loop({{o.measurement, "rig.csv"}}, loop_settings{});
  return out;
}

// The effect found first, with its switch parameters within `rel_tol` of the truth, and the
// error after at most `error_ratio` x the error before.
void check_found_first(const run& r, const std::string& name, double rel_tol, double error_ratio) {
  ASSERT_FALSE(r.result.effects.empty()) << name << " not found";
  const loop_step& first = r.result.effects.front();
  EXPECT_EQ(first.effect, name);
  if (first.effect != name) return;
  const effect_info& e = find_effect(name);
  std::map<std::string, double> est(first.params.begin(), first.params.end());
  for (const auto& q : e.parameters) {
    if (!q.is_switch) continue;
    const double truth = r.req.effects.*q.member;
    EXPECT_NEAR(est.at(std::string(q.key)), truth, rel_tol * std::abs(truth)) << name << "." << q.key;
  }
  EXPECT_LT(r.result.error_after, error_ratio * r.result.error_before) << name;
  // The measured line docs/loop.md quotes.
  std::printf("MEASURED %s: error %.4g -> %.4g (ratio %.3g), unexplained %d, effects", name.c_str(), r.result.error_before,
              r.result.error_after, r.result.error_after / r.result.error_before, r.result.unexplained);
  for (const auto& s : r.result.effects) std::printf(" %s", s.effect.c_str());
  for (const auto& q : e.parameters)
    if (q.is_switch) std::printf("; %s = %.5g (truth %.5g)", std::string(q.key).c_str(), est.at(std::string(q.key)), r.req.effects.*q.member);
  std::printf("\n");
}
void expect_found_first(const std::string& name, double rel_tol, const rig_request& rig = {}) {
  check_found_first(loop_on_rig({name}, rig), name, rel_tol, kErrorRatio);
}

// Paper model and noise only: nothing added, the residual is the noise.
TEST(loop_scenarios, no_effect_adds_nothing) {
  const run r = loop_on_rig({});
  EXPECT_TRUE(r.result.effects.empty());
  EXPECT_FALSE(r.result.unexplained);
  EXPECT_EQ(r.result.error_after, r.result.error_before);
  EXPECT_LE(r.result.validity_after.noise_level.value, r.result.validity_after.noise_level.limit);
}

// Parameter tolerances: measured estimate errors (docs/loop.md) times ~3, rounded up.
TEST(loop_scenarios, preload) { expect_found_first("preload", 0.01); }
TEST(loop_scenarios, shaft_bow) { expect_found_first("shaft_bow", 0.02); }
TEST(loop_scenarios, probe_runout) { expect_found_first("probe_runout", 0.05); }
TEST(loop_scenarios, hunt_crossley_damping) { expect_found_first("hunt_crossley_damping", 0.3); }
TEST(loop_scenarios, velocity_dependent_friction) { expect_found_first("velocity_dependent_friction", 0.3); }
TEST(loop_scenarios, cross_coupling) { expect_found_first("cross_coupling", 0.1); }
TEST(loop_scenarios, misalignment_2x) { expect_found_first("misalignment_2x", 0.1); }
// probe_misorientation and contact_angle turn the orbit or the contact so far that a local fit
// without them lands far from their basin: the trace profiles them on a trial grid (docs/loop.md).
TEST(loop_scenarios, probe_misorientation) { expect_found_first("probe_misorientation", 0.1); }
TEST(loop_scenarios, contact_angle) { expect_found_first("contact_angle", 0.1); }
// stator_compliance rings between impacts, so the residual along 1/k_s is a comb of dips ~2 %
// wide (the trace searches them, docs/loop.md); in the right dip k_s is pinned far inside 1 %
// (measured -0.003 % here, +0.006 % at k_s = 2e6).
TEST(loop_scenarios, stator_compliance) { expect_found_first("stator_compliance", 0.01); }
// hertz_contact: the paper's law with free k1, k3, c2 absorbs all but ~0.01 um RMS of it, 2 % of
// the default probes' noise, which 16 revolutions per dwell do not resolve (docs/loop.md measures
// 0.5 and 0.05 um). With probes quiet enough to resolve it (5 nm, no ADC step) it must be found.
TEST(loop_scenarios, hertz_contact_quiet_probes) {
  rig_request quiet;
  quiet.probes.noise = 5e-9;
  quiet.probes.quantisation = 0.0;
  expect_found_first("hertz_contact", 0.01, quiet);
}
// With the default probes and 128 revolutions per dwell the synchronous orders resolve the
// remainder (chi^2/dof 1.745, limit 1.28): Hertz must be found and leave a residual that is noise.
// Its error is the noise's (NRMSE ~0.0015 both times), so "well below" cannot hold: after < before.
TEST(loop_scenarios, hertz_contact_long_records) {
  rig_request long_records;
  long_records.record_revs = 128;
  const run r = loop_on_rig({"hertz_contact"}, long_records);
  check_found_first(r, "hertz_contact", 0.02, 1.0);
  EXPECT_FALSE(r.result.unexplained);
}
// Not found yet (docs/loop.md, "Limits, measured"): kept runnable with
// --gtest_also_run_disabled_tests, and not registered with ctest, until the loop finds it.
// hertz_contact with the default probes and 16 revolutions per dwell: see above.
TEST(loop_scenarios, DISABLED_hertz_contact) { expect_found_first("hertz_contact", 0.3); }

// Two at once: both named.
TEST(loop_scenarios, two_effects_are_both_found) {
  const run r = loop_on_rig({"preload", "shaft_bow"});
  std::vector<std::string> names;
  for (const auto& e : r.result.effects) names.push_back(e.effect);
  EXPECT_NE(std::find(names.begin(), names.end(), "preload"), names.end());
  EXPECT_NE(std::find(names.begin(), names.end(), "shaft_bow"), names.end());
  EXPECT_LT(r.result.error_after, kErrorRatio * r.result.error_before);
}

// A drive that does not hold its speed (1 % at 3 Hz) is not in the library: the loop must say
// it cannot explain the residual.
TEST(loop_scenarios, an_effect_outside_the_library_is_unexplained) {
  rig_request drifting;
  drifting.unmodelled.drive = speed_fluctuation{0.01, 3.0};
  const run r = loop_on_rig({}, drifting);
  EXPECT_TRUE(r.result.unexplained);
}

}  // namespace
}  // namespace rubref::testing
