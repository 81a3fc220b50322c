// rubref's default fast path (dopri5, rtol 1e-10, located events) against every golden file, and
// the files' own provenance. A missing or hand-edited file fails here.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "ref/analysis/orbit_io.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "ref/validation/golden.hpp"
#include "ref/validation/validate.hpp"

namespace rubref {
namespace {

// The fast path agrees with the careful method to 6.8e-14 m or better on every orbit case (the
// table of docs/validation.md, made by scripts/update-doc-validation); 1e-11 m leaves a margin
// of 150 and is still 3000 below the tolerance the files give other codes. Statistics cases (chaotic) are held to their files' own tolerances.
constexpr double kFastPathOrbitTol = 1e-11;  // m

golden_case load(const golden_spec& spec) {
  const std::filesystem::path path = std::filesystem::path(RUBREF_GOLDEN_DIR) / golden_file_name(spec);
  return read_golden_case(read_record(path), path.filename().string());
}

class golden_regression : public ::testing::TestWithParam<golden_spec> {};

TEST_P(golden_regression, fast_path_matches_the_golden_file) {
  const golden_case g = load(GetParam());
  const orbit o = simulate(g.request);  // rubref's defaults: the fast path
  ASSERT_EQ(o.samples.size(), g.t.size());
  if (g.comparison == comparison_kind::orbit) {
    double worst = 0.0;
    std::size_t at = 0;
    for (std::size_t i = 0; i < g.t.size(); ++i) {
      ASSERT_EQ(o.samples[i].t, g.t[i]) << "sample " << i;  // same grid to the bit: t = t0 + k dt
      const double e = std::hypot(o.samples[i].s[idx::x] - g.x[i], o.samples[i].s[idx::y] - g.y[i]);
      if (e > worst) {
        worst = e;
        at = i;
      }
    }
    EXPECT_LE(worst, kFastPathOrbitTol) << "worst sample " << at << " at t = " << g.t[at] << " s: golden (" << g.x[at] << ", "
                                        << g.y[at] << "), fast path (" << o.samples[at].s[idx::x] << ", "
                                        << o.samples[at].s[idx::y] << ") m, error " << worst << " m";
  }
  // Both kinds: every statistic within the file's tolerance (what `rubref validate` checks).
  record mine;
  orbit_columns cols;
  cols.append(o.samples, g.request.rpm);
  cols.move_into(mine);
  const validation_result v = validate_candidate(g, mine, "fast path");
  EXPECT_TRUE(v.pass) << to_text(v);
}

// The exact free flight (ref/model/free_flight.hpp) with the files' own careful contact
// integration reproduces every orbit case to kExactFreeFlightTol: the files were made with the
// free flight integrated by rkf78 at rtol 1e-13, the two differ by the integrators' errors only.
constexpr double kExactFreeFlightTol = 1e-12;  // m

TEST_P(golden_regression, exact_free_flight_matches_at_the_files_own_accuracy) {
  const golden_case g = load(GetParam());
  if (g.comparison != comparison_kind::orbit) GTEST_SKIP() << "statistics case (not a single orbit)";
  run_request req = g.request;
  req.integration = golden_method();
  ASSERT_TRUE(req.integration.exact_free_flight);
  const orbit o = simulate(req);
  ASSERT_EQ(o.samples.size(), g.t.size());
  EXPECT_GT(o.counts.free_arcs, 0u);
  double worst = 0.0;
  for (std::size_t i = 0; i < g.t.size(); ++i)
    worst = std::max(worst, std::hypot(o.samples[i].s[idx::x] - g.x[i], o.samples[i].s[idx::y] - g.y[i]));
  EXPECT_LE(worst, kExactFreeFlightTol);
}

// Provenance: what made the file, with what, when, and how to compare with it.
TEST_P(golden_regression, carries_its_provenance) {
  const std::filesystem::path path = std::filesystem::path(RUBREF_GOLDEN_DIR) / golden_file_name(GetParam());
  const record r = read_record(path);
  for (const char* key : {"generator", "commit", "date", "method", "stepper", "rtol", "atol", "max_dt_s", "event_time_tolerance_s",
                          "settle_revs", "record_revs", "samples_per_rev", "cross_check_stepper", "cross_check_max_difference_m",
                          "comparison", "period_revs"})
    EXPECT_NE(r.find(key), nullptr) << path << " lacks '" << key << "'";
  const golden_case g = read_golden_case(r, path.filename().string());
  EXPECT_EQ(g.request.variant, GetParam().variant);
  EXPECT_EQ(g.request.params.clearance, GetParam().clearance);
  EXPECT_EQ(g.request.rpm, GetParam().rpm);
  EXPECT_EQ(*r.find("stepper"), "rkf78");  // the careful method, not the fast path
  EXPECT_LE(r.number("rtol"), 1e-13);
  if (g.comparison == comparison_kind::orbit) {
    EXPECT_LE(r.number("cross_check_max_difference_m"), kReproducibleRelTol * g.statistics.max_radius);
    EXPECT_EQ(g.orbit_tolerance, kGoldenOrbitRelTol * g.statistics.max_radius);
  }
  // A periodic case is the shot fixed point of its period map (ref/validation/golden.cpp): converged to the
  // shooting's tolerance, stable (a transient from rest reached it), and the settled transient
  // on it to the reproducibility share of the orbit.
  if (g.comparison == comparison_kind::orbit && g.period_revs > 0) {
    for (const char* key : {"shooting_residual_m", "shooting_iterations", "floquet_max_modulus", "transient_max_difference_m"})
      ASSERT_NE(r.find(key), nullptr) << path << " lacks '" << key << "'";
    EXPECT_LE(r.number("shooting_residual_m"), kGoldenShootingTolerance);
    EXPECT_LT(r.number("floquet_max_modulus"), 1.0);
    EXPECT_LE(r.number("transient_max_difference_m"), kReproducibleRelTol * g.statistics.max_radius);
  }
  // Every cell at 17 significant digits, e.g. 7.5000000000000000e+00.
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line) && (line.empty() || line[0] == '#' || line[0] == 't')) {
  }
  EXPECT_EQ(line.substr(0, line.find(',')).size(), std::string("7.5000000000000000e+00").size()) << line;
}

// The attractor scan (ref/validation/golden.hpp, scan_attractors): every file has been scanned, and every
// coexisting attractor it records is one. Newton from its state with its period stays on it (the
// state is a fixed point converged to 1e-12 m; the scan merged states closer than
// kDistinctAttractorRelTol of the radius, so that is how close "the same" is), it is stable, and it
// is not the case's own orbit: farther from every revolution start of the record than ten orbit
// tolerances, so a candidate on it cannot pass as the case.
constexpr double kApartFromOwnRelTol = 10.0 * kGoldenOrbitRelTol;
TEST_P(golden_regression, coexisting_attractors_are_stable_and_not_the_case) {
  const golden_case g = load(GetParam());
  ASSERT_TRUE(g.attractors_scanned) << g.name << " predates the attractor scan (no 'coexisting_attractors'): regenerate";
  run_request careful = g.request;
  careful.integration = golden_method();
  const double omega = g.omega(), radius = g.statistics.max_radius;
  for (std::size_t k = 0; k < g.attractors.size(); ++k) {
    const coexisting_attractor& a = g.attractors[k];
    SCOPED_TRACE(::testing::Message() << g.name << ", attractor " << k + 1 << " (" << a.start << ")");
    shot_options so;
    so.t0 = g.t.front();
    so.stepper = careful.integration.stepper;
    so.tolerance = kGoldenShootingTolerance;
    const periodic_orbit_result shot = shoot_from(careful, a.state, a.period_revs, so);
    ASSERT_TRUE(shot.converged) << shot.failure;
    EXPECT_LE(shot.residual, kGoldenShootingTolerance);
    EXPECT_LE(state_distance(shot.samples.request.initial_state, a.state, omega), kDistinctAttractorRelTol * radius);
    EXPECT_LT(shot.max_multiplier_modulus, 1.0);
    EXPECT_LT(a.max_multiplier, 1.0);
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < g.t.size(); i += static_cast<std::size_t>(g.request.samples_per_rev))
      nearest = std::min(nearest, state_distance(a.state, state_type{g.x[i], g.y[i], g.vx[i], g.vy[i]}, omega));
    EXPECT_GT(nearest, kApartFromOwnRelTol * radius);
  }
}

// The long-contact case is what it was chosen for (ref/validation/golden.cpp, long_contact_case): a periodic
// orbit case whose contact share is 1.5 times any matrix case's or more, in one episode a revolution.
TEST(golden_cases, long_contact_case_has_a_long_contact) {
  const golden_spec spec = long_contact_case();
  const golden_case g = load(spec);
  EXPECT_EQ(g.comparison, comparison_kind::orbit);
  EXPECT_GT(g.period_revs, 0);
  double matrix_largest = 0.0;
  for (const golden_spec& other : golden_matrix())
    if (other.feature.empty() && golden_file_name(other) != golden_file_name(spec)) matrix_largest = std::max(matrix_largest, load(other).statistics.contact_fraction);
  EXPECT_GE(g.statistics.contact_fraction, 1.5 * matrix_largest);
  const record r = read_record(std::filesystem::path(RUBREF_GOLDEN_DIR) / golden_file_name(spec));
  EXPECT_EQ(r.number("contact_episodes_per_rev"), 1.0);
}

// The chatter-sticking case is what it was chosen for (ref/validation/golden.cpp,
// chatter_sticking_case): a periodic orbit case in which, every revolution, the rotor chatters
// (at least kMinImpactsPerRev impacts), sticks once and is released once, and its stuck samples
// sit exactly on the face, in the file and on the fast path alike.
TEST(golden_cases, chatter_sticking_case_chatters_then_sticks_every_revolution) {
  constexpr int kMinImpactsPerRev = 10;  // a chatter, not a bounce: the rule is reached by a run of rebounds
  const golden_spec spec = chatter_sticking_case();
  const golden_case g = load(spec);
  EXPECT_EQ(g.comparison, comparison_kind::orbit);
  EXPECT_EQ(g.period_revs, 1);
  int stuck_in_file = 0;
  for (std::size_t i = 0; i < g.t.size(); ++i)
    if (g.y[i] == spec.clearance && g.vy[i] == 0.0) ++stuck_in_file;
  EXPECT_GT(stuck_in_file, 0);
  const orbit o = simulate(g.request);
  const double period = 60.0 / spec.rpm, t0 = g.request.settle_revs * period;
  for (int rev = 0; rev < g.request.record_revs; ++rev) {
    SCOPED_TRACE(::testing::Message() << "revolution " << rev);
    int impacts = 0, sticks = 0, releases = 0;
    for (const auto& ev : o.events) {
      if (ev.t < t0 + rev * period || ev.t >= t0 + (rev + 1) * period) continue;
      impacts += ev.kind == event_kind::impact;
      sticks += ev.kind == event_kind::stick;
      releases += ev.kind == event_kind::release;
    }
    EXPECT_GE(impacts, kMinImpactsPerRev);
    EXPECT_EQ(sticks, 1);
    EXPECT_EQ(releases, 1);
  }
  int stuck = 0;
  for (const auto& smp : o.samples)
    if (smp.fn > 0.0) {
      ++stuck;
      EXPECT_EQ(smp.s[idx::y], spec.clearance) << "t = " << smp.t;
      EXPECT_EQ(smp.s[idx::vy], 0.0) << "t = " << smp.t;
    }
  EXPECT_GT(stuck, 0);
}

std::string case_name(const ::testing::TestParamInfo<golden_spec>& info) {
  std::string n = golden_file_name(info.param);
  n = n.substr(0, n.size() - 4);
  for (char& c : n)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return n;
}

INSTANTIATE_TEST_SUITE_P(every_case, golden_regression, ::testing::ValuesIn(golden_matrix()), case_name);

}  // namespace
}  // namespace rubref
