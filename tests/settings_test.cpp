// The settings registry (ref/model/settings.hpp): its rows agree with themselves, with the
// structs whose defaults they give, and a bad value's message names the setting and says why.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>

#include "ref/base/errors.hpp"
#include "ref/identification/identify.hpp"
#include "ref/inference/evidence.hpp"
#include "ref/inference/least_squares.hpp"
#include "ref/loop/loop.hpp"
#include "ref/orbits/fit_orbits.hpp"
#include "ref/model/settings.hpp"
#include "ref/orbits/continuation.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "ref/rig/rig.hpp"
#include "ref/run/simulate.hpp"
#include "ref/study/study.hpp"
#include "ref/sweep/sweep.hpp"

namespace rubref {
namespace {

TEST(settings_registry, every_default_is_inside_its_own_range) {
  for (const auto& s : settings_registry) EXPECT_EQ(violation(s, s.default_value), "") << s.scope << "." << s.name;
}

TEST(settings_registry, one_row_per_scope_and_name) {
  std::set<std::pair<std::string_view, std::string_view>> seen;
  for (const auto& s : settings_registry) EXPECT_TRUE(seen.insert({s.scope, s.name}).second) << s.scope << "." << s.name;
}

// One name is one quantity to the user: the same flag, key and unit wherever it appears (the
// command line spells a message's `field` from the first row of that name).
TEST(settings_registry, rows_of_one_name_spell_it_alike) {
  std::map<std::string_view, const setting_info*> first;
  for (const auto& s : settings_registry) {
    const auto [it, inserted] = first.emplace(s.name, &s);
    if (inserted) continue;
    EXPECT_EQ(s.flag, it->second->flag) << s.name;
    EXPECT_EQ(s.key, it->second->key) << s.name;
    EXPECT_EQ(s.unit, it->second->unit) << s.name;
  }
}

TEST(settings_registry, every_row_says_what_it_is_and_why_its_range) {
  for (const auto& s : settings_registry) {
    EXPECT_FALSE(s.flag.empty() && s.key.empty()) << s.name;  // set on the command line, in a file, or both
    EXPECT_FALSE(s.unit.empty()) << s.name;
    EXPECT_FALSE(s.description.empty()) << s.name;
    EXPECT_FALSE(s.reason.empty()) << s.name;
  }
}

TEST(settings_registry, a_bad_value_is_named_with_its_rule_and_reason) {
  const setting_info& rtol = setting_named("integration", "rtol");
  const std::string msg = violation(rtol, 2.0);
  EXPECT_EQ(msg, "`rtol` must be finite and in (0, 1) (got 2): a relative error");
  EXPECT_NE(violation(rtol, 0.0), "");  // open at 0
  EXPECT_NE(violation(rtol, std::numeric_limits<double>::quiet_NaN()), "");
  const setting_info& periods = setting_named("shooting", "periods");
  EXPECT_NE(violation(periods, 2.5), "");  // whole numbers only
  EXPECT_EQ(violation(periods, 64.0), "");
  EXPECT_NE(violation(periods, 65.0).find("a whole number in [1, 64]"), std::string::npos) << violation(periods, 65.0);
  EXPECT_THROW(check({"run", "rpm"}, 0.0), input_error);
  EXPECT_NO_THROW(check({"run", "rpm"}, 1e6));  // the closed upper end
}

// A scope without its own row reads the shared one; with its own row, its own default.
TEST(settings_registry, scopes_fall_back_to_the_shared_row) {
  EXPECT_EQ(&setting_named("continuation", "rpm"), &setting_named("", "rpm"));
  EXPECT_EQ(setting_named("sweep", "settle_revs").default_value, 60.0);
  EXPECT_EQ(setting_named("run", "settle_revs").default_value, 200.0);
  EXPECT_EQ(setting_with_name("record_revs")->flag, "revs");
  EXPECT_EQ(setting_with_name("no_such_setting"), nullptr);
}

// The structs take their defaults from the registry, and those defaults pass their validate().
TEST(settings_registry, the_structs_defaults_are_the_registrys_and_valid) {
  const run_request run;
  EXPECT_EQ(run.rpm, setting_named("run", "rpm").default_value);
  EXPECT_EQ(run.integration.stepper.rtol, setting_named("integration", "rtol").default_value);
  EXPECT_EQ(run.params.clearance, setting_named("model", "clearance").default_value);
  EXPECT_NO_THROW(validate(run));
  const sweep_settings sweep;
  EXPECT_EQ(sweep.record_revs, 12);
  EXPECT_NO_THROW(validate(sweep));
  const continuation_request cont;
  EXPECT_EQ(cont.tolerance, kShootingTolerance);
  EXPECT_NO_THROW(validate(cont));
  const rig_request rig;
  EXPECT_EQ(rig.probes.sample_rate, setting_named("rig", "sample_rate").default_value);
  EXPECT_NO_THROW(validate(rig));
  EXPECT_EQ(periodic_orbit_request{}.tolerance, setting_named("", "tolerance").default_value);
  const study::job_settings job;
  EXPECT_EQ(job.max_period, setting_named("study", "max_period").default_value);
  EXPECT_EQ(job.samples_per_rev, setting_named("study", "samples_per_rev").default_value);
}

// The upper wings' settings (issue 62): the loop's, the trace's, identification's, the solver's,
// the evidence rules' and the fits' orbits: defaults from the registry, valid, and a bad value
// refused by its row, its message naming the setting.
TEST(settings_registry, the_upper_wings_take_their_settings_from_the_registry) {
  const loop_settings loop;
  EXPECT_EQ(loop.max_effects, setting_named("trace", "max_effects").default_value);
  EXPECT_EQ(loop.rules.claim_share, setting_named("evidence", "claim_share").default_value);
  EXPECT_NO_THROW(loop.validate());
  const identify_settings id;
  EXPECT_EQ(id.bootstrap, setting_named("identify", "bootstrap").default_value);
  EXPECT_EQ(id.frols.rho, setting_named("frols", "rho").default_value);
  EXPECT_EQ(id.weak.test_functions, setting_named("weak_form", "test_functions").default_value);
  EXPECT_EQ(id.orbit.max_jacobians, setting_named("orbit_fit", "max_jacobians").default_value);
  EXPECT_NO_THROW(id.validate());
  EXPECT_NO_THROW(least_squares_options{}.validate());
  EXPECT_NO_THROW(evidence_rules{}.validate());
  EXPECT_NO_THROW(fit_orbit_options{}.validate());
  const auto refused = [](auto settings, const std::string& field) {
    try {
      settings.validate();
    } catch (const input_error& e) {
      return std::string(e.what()).find("`" + field + "`") == 0;
    }
    return false;
  };
  loop_settings bad_loop;
  bad_loop.max_effects = 12;
  EXPECT_TRUE(refused(bad_loop, "max_effects"));
  bad_loop = {}, bad_loop.rules.min_criterion_rise = -1.0;
  EXPECT_TRUE(refused(bad_loop, "min_criterion_rise"));
  identify_settings bad_id;
  bad_id.bootstrap = -1;
  EXPECT_TRUE(refused(bad_id, "bootstrap"));
  bad_id = {}, bad_id.frols.rho = 1.0;
  EXPECT_TRUE(refused(bad_id, "rho"));
  bad_id = {}, bad_id.weak.bump_power = 2;
  EXPECT_TRUE(refused(bad_id, "bump_power"));
  least_squares_options bad_solver;
  bad_solver.difference_step = 0.5;
  EXPECT_TRUE(refused(bad_solver, "difference_step"));
}

}  // namespace
}  // namespace rubref
