// The loop end to end (docs/loop.md) on virtual-rig records with an effect nobody declares, in
// the forms records from elsewhere take: no keyphasor (shaft-synchronous time), dwells carried
// over from the previous one, only the three metadata lines rubref reads, a second, contact-free
// record, levels other than the library's moderate ones. These scenarios are the smoke set of
// label `loop` (a few minutes); how the loop fares over the documented range is measured by the
// randomized campaign (scripts/loop-campaign, docs/loop.md), not here.
//
// Every scenario is one row of kScenarios; ctest lists each row as loop.scenario/<name> (tests/CMakeLists.txt).

#include <gtest/gtest.h>

#include "tests/sanitized.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ref/loop/loop.hpp"
#include "ref/rig/rig.hpp"

namespace rubref::testing {
namespace {

// The sanitizers make the loop ~12x slower (docs/robustness.md): there only the rows marked
// `sanitized` run, the others are skipped.

// What the independent records looked like: 0.3 mm, rub dwells 1500-1700 rpm and a
// separate contact-free record at 1200-1800 rpm (10 kHz, so 1200, 1500 and 1800 rpm have a whole
// number of samples per revolution), 10 revolutions after 60 carried over, no keyphasor.
rig_request from_elsewhere(std::vector<double> speeds, double clearance, unsigned seed) {
  rig_request req;
  req.speeds_rpm = std::move(speeds);
  req.params.clearance = clearance;
  req.record_revs = 10;
  req.settle_revs = 60;
  req.carry_over = true;
  req.minimal_header = true;
  req.probes.keyphasor = false;
  req.time_base = rig_time_base::shaft;
  req.probes.seed = seed;
  return req;
}

// A rub record and a contact-free one of the same rig, in other forms than from_elsewhere's and
// the campaign draws: a keyphasor, dwells from rest, the full header.
std::vector<rig_request> rub_and_free(double clearance, std::vector<double> rub, std::vector<double> free, unsigned seed, int revs,
                                      double noise, double sample_rate, const char* variant) {
  std::vector<rig_request> out(2);
  for (int i = 0; i < 2; ++i) {
    rig_request& req = out[static_cast<std::size_t>(i)];
    req.speeds_rpm = i == 0 ? rub : free;
    req.params.clearance = i == 0 ? clearance : 0.01;
    req.probes.seed = seed + static_cast<unsigned>(i);
    req.record_revs = revs;
    req.settle_revs = 80;
    req.probes.noise = noise;
    req.probes.sample_rate = sample_rate;
    req.variant = variant;
  }
  return out;
}

struct scenario {
  const char* name = nullptr;
  std::vector<std::string> effects = {};       // injected (rig --effect syntax), in both records
  std::function<void(rig_request&)> rig = {};  // changes to both records
  bool separate_free_record = true;       // else one record from the rig's default speeds
  std::vector<std::string> expected = {};  // the effects the loop must name, and nothing else
  std::optional<bool> unexplained = false;  // what the report must say (nullopt: not checked; `check` says what holds)
  double param_tol = 0.0;                 // relative, on every switch parameter of the expected effects (0: not checked)
  double error_ratio = 0.0;               // error after / before at most (0: not checked)
  bool sanitized = false;                 // also run under the sanitizers
  std::function<std::vector<rig_request>()> records = nullptr;  // the records' rigs (else from_elsewhere's, or the rig's default)
  const char* claim = nullptr;            // the report's claim (null: not checked)
  std::function<void(const loop_result&, const std::vector<rig_request>&)> check = nullptr;  // what else the row asserts
};

// mu(v) = mu + (mu_s - mu) exp(-v / v_c) at the sliding speed R w (the rotor's own tangential
// speed, ~0.05 m/s against R w ~ 0.5 m/s, left out).
double falling_mu(double mu, double mu_s, double v_c, double radius, double w) { return mu + (mu_s - mu) * std::exp(-radius * w / v_c); }

// Tolerances: the estimates' measured errors (docs/loop.md) are < 0.1 %; 1 % leaves room for
// another seed. Error ratio 0.2: the campaign's target where the effect is visible.
const std::vector<scenario> kScenarios{
    {"records_from_elsewhere_without_an_effect", {}, nullptr, true, {}, false, 0.0, 0.0, true},
    {"preload_in_y_only", {"preload:F_x=0,F_y=-4"}, nullptr, true, {"preload"}, false, 0.01, 0.2, true},
    {"contact_angle_of_14_degrees",
     {"contact_angle:theta=0.244"},
     [](rig_request& r) { r.probes.keyphasor = true, r.time_base = rig_time_base::acquisition, r.probes.keyphasor_angle = 0.7; },
     false,
     {"contact_angle"},
     false,
     0.01,
     0.2},
    {"preload_and_misalignment", {"preload:F_x=0,F_y=-3", "misalignment_2x:F2=0.4"}, nullptr, true, {"preload", "misalignment_2x"}, false,
     0.01, 0.2},
    {"hardening_supports_are_unexplained", {}, [](rig_request& r) { r.unmodelled.cubic_stiffness = 5e9; }, true, {}, true},
    {"a_drifting_speed_is_unexplained", {}, [](rig_request& r) { r.unmodelled.drive = speed_fluctuation{0.01, 3.0}; }, false, {}, true, 0.0,
     0.0, true},
    // Every effect parameter is fitted (issue 42): a stator whose mass and damper are not the
    // library's typical 1 kg and 100 N s/m is named alone, with both recovered (no stand-in second
    // effect), under a piecewise-linear base law. Measured (docs/loop.md's example, the same
    // records): k_s 0.07 %, c_s 0.9 %, m_s 0.7 % off; 5 % leaves room for another seed.
    {.name = "a_stator_of_its_own_mass_and_damper",
     .effects = {"stator_compliance:k_s=4e6,c_s=300,m_s=0.4"},
     .expected = {"stator_compliance"},
     .param_tol = 0.05,
     .records = [] { return rub_and_free(0.25e-3, {1500, 1550, 1600, 1650, 1700}, {1200, 1350, 1500, 1650, 1800}, 3, 12, 1e-6, 8000, "piecewise-linear"); },
     .claim = "full",
     .check = [](const loop_result& r, const std::vector<rig_request>& req) {
       ASSERT_EQ(r.effects.size(), 1u);
       EXPECT_NEAR(r.after.fx.stator_m, req.front().effects.stator_m, 0.05 * req.front().effects.stator_m);
       EXPECT_NEAR(r.after.fx.stator_c, req.front().effects.stator_c, 0.05 * req.front().effects.stator_c);
       ASSERT_EQ(r.effects.front().profiles.size(), 2u);  // ring frequency and damping ratio
       for (const auto& p : r.effects.front().profiles) EXPECT_EQ(p.verdict, "determined") << p.quantity;
     }},
    // A falling friction curve away from the library's v_c = 0.5 m/s and R = 5 mm: named, and the
    // curve is right at the sliding speeds the records reach (mu_s and v_c trade along it: measured
    // 13 % off each, the curve within 0.3 %), under a piecewise-nonlinear base law.
    {.name = "falling_friction_off_the_library_curve",
     .effects = {"velocity_dependent_friction:mu_s=0.8,v_c=0.15,R=3e-3"},
     .expected = {"velocity_dependent_friction"},
     .records = [] { return rub_and_free(0.3e-3, {1500, 1550, 1600, 1650, 1700}, {1200, 1350, 1500, 1650, 1800}, 5, 14, 0.7e-6, 12000, "piecewise-nonlinear"); },
     .claim = "full",
     .check = [](const loop_result& r, const std::vector<rig_request>& req) {
       const effect_parameters& t = req.front().effects;
       const effect_parameters& e = r.after.fx;
       for (const double rpm : req.front().speeds_rpm) {
         const double w = rpm * 3.14159265358979 / 30.0;
         const double truth = falling_mu(req.front().params.mu, t.mu_static, t.slip_decay_speed, t.shaft_radius, w);
         EXPECT_NEAR(falling_mu(r.after.p.mu, e.mu_static, e.slip_decay_speed, e.shaft_radius, w), truth, 0.02 * truth) << rpm << " rpm";
       }
       ASSERT_EQ(r.effects.size(), 1u);
       EXPECT_EQ(r.effects.front().profiles.size(), 2u);  // v_c and R, each with its verdict
     }},
    // One combined record (contact-free dwells and rub dwells, no free record) with a shaft bow:
    // the bow alone (no cross-coupling beside it).
    {.name = "one_combined_record_with_a_shaft_bow",
     .effects = {"shaft_bow:b=3e-5,phi_b=2"},
     .separate_free_record = false,
     .expected = {"shaft_bow"},
     .param_tol = 0.01,
     .records = [] { return std::vector<rig_request>{rub_and_free(0.3e-3, {1200, 1300, 1500, 1550, 1600, 1650, 1700}, {}, 9, 12, 1e-6, 10000, "identified").front()}; },
     .claim = "full"},
    // A base law the staged start gets wrong: on one combined record with a 2X misalignment at
    // 0.15 um of noise, the FROLS law puts k3 z^3 in k1 z's place (k1 -> 0 in the before-fit). The
    // misalignment alone, to its switch parameter, once the model with it is refitted from the
    // Table 2 law's start on the orbits the data is on; the residual is then at the noise in RMS.
    // Whether the structure tests also call it noise depends on the draw: over noise seeds 95-105
    // (this record by `rubref rig` and `rubref loop`) the claim was "full" on 4 and "partial" on 7
    // (synchronous chi^2 and Box-Pierce above their limits), every one with the misalignment
    // alone, F2 within 0.03 %, error ratio 0.018, RMS / noise <= 1.01 and at most 3.2e-6 of the
    // excess left. So the row asserts those, not the claim:
    // the remaining share below 1e-4 (30x the worst seed) and RMS / noise within the validity
    // check's own limit (1.05).
    {.name = "a_misalignment_on_a_base_law_the_staged_start_gets_wrong",
     .effects = {"misalignment_2x:F2=1.2,phi2=-2"},
     .rig = [](rig_request& r) { r.settle_revs = 100, r.probes.keyphasor_angle = 0.8; },
     .separate_free_record = false,
     .expected = {"misalignment_2x"},
     .unexplained = std::nullopt,
     .param_tol = 0.01,
     .error_ratio = 0.2,
     .records = [] { return std::vector<rig_request>{rub_and_free(0.35e-3, {1040, 1110, 1230, 1490, 1530, 1570, 1610, 1640, 1670, 1720}, {}, 95, 6, 0.15e-6, 14000, "piecewise-nonlinear").front()}; },
     .check = [](const loop_result& r, const std::vector<rig_request>&) {
       EXPECT_TRUE(r.decision.claim == "full" || r.decision.claim == "partial") << r.decision.claim;
       EXPECT_LE(1.0 - r.decision.explained_share, 1e-4);
       EXPECT_TRUE(r.validity_after.noise_level.pass) << r.validity_after.noise_level.value;
       EXPECT_TRUE(r.excluded.empty());
     }},
    // A named effect that leaves more than noise is a partial explanation, and said so: a preload
    // with hardening supports (outside the library) that it cannot take.
    {.name = "a_named_effect_that_leaves_more_than_noise_is_partial",
     .effects = {"preload:F_x=0,F_y=-6"},
     .rig = [](rig_request& r) { r.unmodelled.cubic_stiffness = 4e8; },
     .expected = {"preload"},
     .unexplained = true,
     .param_tol = 0.01,
     .error_ratio = 0.2,
     .records = [] { return std::vector<rig_request>{from_elsewhere({1500, 1550, 1600, 1650, 1700}, 0.3e-3, 31), from_elsewhere({1200, 1350, 1500, 1650, 1800}, 0.01, 32)}; },
     .claim = "partial",
     .check = [](const loop_result& r, const std::vector<rig_request>&) {
       EXPECT_GE(r.decision.explained_share, evidence_rules{}.claim_share);
       EXPECT_FALSE(r.validity_after.pass);
     }},
    // A dwell on a period-3 rub orbit (below the resonance at 0.2 mm) is fitted on the model's
    // period-3 orbit, not left out: the residual is noise with the paper's law.
    {.name = "a_period_3_dwell_is_fitted_on_its_orbit",
     .rig = [](rig_request& r) { r.settle_revs = 150, r.probes.noise = 0.5e-6, r.record_revs = 16; },
     .sanitized = true,
     .records = [] { return rub_and_free(0.2e-3, {1200, 1250, 1300, 1350, 1400}, {1100, 1250, 1400, 1600}, 21, 16, 0.5e-6, 10000, "identified"); },
     .claim = "none",
     .check = [](const loop_result& r, const std::vector<rig_request>&) {
       const auto at = std::find_if(r.errors.begin(), r.errors.end(), [](const dwell_error& e) { return e.record == "rub.csv" && e.rpm == 1400; });
       ASSERT_NE(at, r.errors.end());
       EXPECT_EQ(at->periods, 3);
       EXPECT_TRUE(at->contact);
       EXPECT_TRUE(r.validity_after.pass);
     }},
};

class loop : public ::testing::TestWithParam<scenario> {};

// The effects injected are named, with their switch parameters, and nothing else is.
TEST_P(loop, scenario) {
  const scenario& sc = GetParam();
  if (kSanitized && !sc.sanitized) GTEST_SKIP() << "release builds only (tests/loop_test.cpp)";
  std::vector<rig_request> requests;
  if (sc.records) {
    requests = sc.records();
  } else if (sc.separate_free_record) {
    requests.push_back(from_elsewhere({1500, 1550, 1600, 1650, 1700}, 0.3e-3, 21));
    requests.push_back(from_elsewhere({1200, 1350, 1500, 1650, 1800}, 0.01, 22));
  } else {
    requests.emplace_back();
  }
  std::vector<std::pair<record, std::string>> records;
  for (auto& req : requests) {
    for (const auto& e : sc.effects) apply_effect(req.effects, e);
    if (sc.rig) sc.rig(req);
    records.emplace_back(run_rig(req).measurement, records.empty() ? "rub.csv" : "free.csv");
  }
  const loop_result r = run_loop(records, loop_settings{});
  const std::vector<std::string>& named = r.decision.named;
  std::printf("MEASURED %s: error %.4g -> %.4g, unexplained %d, claim %s, effects", sc.name, r.error_before, r.error_after, r.decision.unexplained,
              r.decision.claim.c_str());
  for (const auto& e : r.effects) std::printf(" %s", e.effect.c_str());
  std::printf("\n");
  for (const auto& n : r.notes)
    if (n.find("margin") != std::string::npos) std::printf("  %s\n", n.c_str());

  // Where the verdict's check (the loop again at 0.1 times the orbit tolerances) names other
  // effects, the orbits' round-off chose between them, and round-off differs from machine to
  // machine: the loop then claims nothing and keeps every effect either chose tentative
  // (docs/loop.md, "The verdict's check"), and those must be the expected ones
  // (contact_angle_of_14_degrees: named on the machine of cdb261f's run, on an AMD EPYC the check
  // names nothing and the fit the contact angle).
  const bool on_round_off = r.decision.claim == "tentative" && r.check && !r.check->agrees;
  if (on_round_off) {
    std::printf("  decided by the orbits' round-off on this machine: tentative");
    for (const auto& e : r.decision.tentative) std::printf(" %s", e.c_str());
    std::printf("\n");
  }
  std::vector<std::string> expected = sc.expected, got = on_round_off ? r.decision.tentative : named;
  std::sort(expected.begin(), expected.end());
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, expected);
  if (sc.unexplained) {
    EXPECT_EQ(r.decision.unexplained, *sc.unexplained);
  }
  if (sc.unexplained == false) {
    EXPECT_TRUE(r.excluded.empty()) << r.excluded.front().reason;
  }
  for (const auto& step : r.effects) {
    if (std::find(expected.begin(), expected.end(), step.effect) == expected.end()) continue;
    const std::map<std::string, double> est(step.params.begin(), step.params.end());
    for (const auto& q : find_effect(step.effect).parameters) {
      if (!q.is_switch || !(sc.param_tol > 0.0)) continue;
      const double truth = requests.front().effects.*q.member;
      EXPECT_NEAR(est.at(std::string(q.key)), truth, std::max(sc.param_tol * std::abs(truth), 1e-3 * q.level_lo))
          << step.effect << "." << q.key;
    }
  }
  if (sc.error_ratio > 0.0) {
    EXPECT_LE(r.error_after, sc.error_ratio * r.error_before);
  }
  if (sc.expected.empty() && sc.unexplained == false) {
    EXPECT_EQ(r.error_after, r.error_before);
  }
  if (sc.claim) {
    EXPECT_EQ(r.decision.claim, sc.claim);
  }
  // Every effect added was needed out of sample by the numbers its report gives (evidence_rules:
  // the held-out gain exceeds min_criterion_rise and min_holdout_share of the gain on all data,
  // each within its numerical uncertainty, on the margin included): the report shows what the
  // decision read, not another statistic.
  const evidence_rules rules;
  for (const auto& step : r.effects) {
    if (!step.exchanged_for.empty()) continue;  // its scores are those of the round it was exchanged in
    const auto c = std::find_if(step.candidates.begin(), step.candidates.end(), [&](const effect_candidate& x) { return x.name == step.effect; });
    ASSERT_NE(c, step.candidates.end()) << step.effect;
    EXPECT_EQ(c->verdict, "added") << step.effect;
    ASSERT_TRUE(std::isfinite(c->holdout_gain)) << step.effect << ": not tested out of sample";
    EXPECT_EQ(c->holdout_gain, step.holdout_gain);
    EXPECT_TRUE(std::isfinite(c->holdout_gain_uncertainty) && c->holdout_gain_uncertainty >= 0.0) << c->holdout_gain_uncertainty;
    EXPECT_TRUE(std::isfinite(c->in_sample_gain_uncertainty) && c->in_sample_gain_uncertainty >= 0.0) << c->in_sample_gain_uncertainty;
    EXPECT_GT(c->in_sample_gain + c->in_sample_gain_uncertainty, rules.min_criterion_rise) << step.effect;
    EXPECT_GT(c->holdout_gain + c->holdout_gain_uncertainty, rules.min_criterion_rise) << step.effect;
    EXPECT_GE(c->holdout_gain + c->holdout_gain_uncertainty + rules.min_holdout_share * c->in_sample_gain_uncertainty,
              rules.min_holdout_share * c->in_sample_gain)
        << step.effect;
  }
  if (sc.check) sc.check(r, requests);
}

INSTANTIATE_TEST_SUITE_P(, loop, ::testing::ValuesIn(kScenarios),
                         [](const ::testing::TestParamInfo<scenario>& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace rubref::testing
