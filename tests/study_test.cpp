// Parameter studies (docs/studies.md): SPEC checking, the points and their random streams, the
// jobs against closed forms, and the folder's journals.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numeric>

#include "ref/base/errors.hpp"
#include "ref/model/closed_form.hpp"
#include "ref/study/study.hpp"
#include "ref/study/study_folder.hpp"
#include "ref/study/study_run.hpp"

namespace rubref::study {
namespace {

namespace fs = std::filesystem;

std::string error_of(const std::string& text) {
  try {
    parse_spec(text, "t.json");
  } catch (const input_error& e) {
    return e.what();
  }
  return "";
}

std::size_t col(const spec& s, const std::string& name) {
  const auto c = columns(s);
  return static_cast<std::size_t>(std::find(c.begin(), c.end(), name) - c.begin());
}

// Every bad SPEC is refused with one line naming its key.
TEST(StudySpec, EachMistakeIsNamedByItsKey) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"[1]", "must be a JSON object"},
      {"{", "not JSON"},
      {R"({"grid": [{"name": "mu", "values": [0.1]}]})", "key 'study': is missing"},
      {R"({"study": "regime_mapp"})", "did you mean 'regime_map'"},
      {R"({"study": "grid", "grdi": []})", "key 'grdi': unknown key; did you mean 'grid'"},
      {R"({"study": "grid"})", "needs a 'grid', a 'sample', or both"},
      {R"({"study": "grid", "grid": [{"name": "muu", "values": [0.1]}]})", "key 'grid[0].name': 'muu' is not a parameter a study can vary; did you mean 'mu'"},
      {R"({"study": "grid", "grid": [{"name": "mu", "from": 0, "to": 1}]})", "key 'grid[0]': give exactly one of 'count' and 'step'"},
      {R"({"study": "grid", "grid": [{"name": "mu", "from": 0, "to": 1, "count": 2.5}]})", "key 'grid[0].count': must be a whole number"},
      {R"({"study": "grid", "grid": [{"name": "mu", "values": [0.1]}, {"name": "mu", "values": [0.2]}]})", "key 'grid[1].name': 'mu' is varied twice"},
      {R"({"study": "grid", "grid": [{"name": "speed_rpm", "values": [-5]}]})", "speed_rpm values must be > 0"},
      {R"({"study": "grid", "parameters": {"mu": -1}, "grid": [{"name": "e_m", "values": [1e-5]}]})", "key 'parameters'"},
      {R"({"study": "monte_carlo", "sample": {"count": 10, "seed": 1, "vary": [{"name": "mu", "normal": [0.2, 0]}]}, "job": {"from_rpm": 1000, "to_rpm": 2000}})",
       "key 'sample.vary[0].normal[1]': the standard deviation must be > 0"},
      {R"({"study": "monte_carlo", "sample": {"count": 10, "seed": 1, "vary": [{"name": "mu", "uniform": [0.2, 0.3]}]}})", "key 'job.from_rpm': is missing"},
      {R"({"study": "regime_map", "grid": [{"name": "mu", "values": [0.1]}, {"name": "speed_rpm", "values": [1500]}]})",
       "exactly two axes, clearance_m and speed_rpm"},
      {R"({"study": "basins", "grid": [{"name": "x0_m", "values": [0]}, {"name": "y0_m", "values": [0]}], "job": {"start": "contact_free"}})",
       "key 'job.start'"},
      {R"({"study": "grid", "grid": [{"name": "x0_m", "values": [0]}]})", "varies x0_m but the start is 'contact_free'"},
      {R"({"study": "grid", "grid": [{"name": "mu", "values": [0.1]}], "job": {"max_period": 7}})", "key 'job.max_period'"},
      {R"({"study": "grid", "grid": [{"name": "mu", "values": [0.1]}], "job": {"type": "run_up", "from_rpm": 1000, "to_rpm": 900}})",
       "key 'job.to_rpm': must be > 'from_rpm'"},
      {R"({"study": "grid", "grid": [{"name": "effect.preload.F_y", "values": [0, -4]}]})", "effects and probe noise enter only a loop job"},
      {R"({"study": "grid", "grid": [{"name": "effect.prelod.F_y", "values": [0]}], "job": {"type": "loop"}})", "did you mean 'effect.preload.F_y'"},
      {R"({"study": "grid", "effects": ["hertz"], "grid": [{"name": "mu", "values": [0.2]}], "job": {"type": "loop"}})", "key 'effects[0]'"},
      {R"({"study": "grid", "grid": [{"name": "mu", "values": [0.2]}], "job": {"type": "loop", "speeds_rpm": [-1]}})",
       "key 'job.speeds_rpm[0]' must be finite and in (0, "},
      // The job's counts and the noise: the settings registry's ranges and reasons (ref/model/settings.hpp).
      {R"({"study": "grid", "grid": [{"name": "mu", "values": [0.2]}], "job": {"settle_rounds": 0}})",
       "key 'job.settle_rounds' must be a whole number in [1, 64] (got 0): each round"},
      {R"({"study": "grid", "grid": [{"name": "mu", "values": [0.2]}], "job": {"samples_per_rev": 8.5}})", "key 'job.samples_per_rev' must be a whole number"},
      {R"({"study": "grid", "grid": [{"name": "mu", "values": [0.2]}], "job": {"type": "loop", "noise_m": -1e-6}})",
       "key 'job.noise_m' must be finite and >= 0 m"},
      {R"({"study": "grid", "grid": [{"name": "mu", "values": [0.2]}], "job": {"noise_m": 1e-6}})", "key 'job.noise_m': belongs to a loop job only"},
  };
  for (const auto& [text, expected] : cases) {
    const std::string e = error_of(text);
    EXPECT_NE(e.find(expected), std::string::npos) << text << "\n -> " << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  }
}

// The canonical text is a fixed point: a folder's spec.json reads back to the same study.
TEST(StudySpec, CanonicalTextReadsBackToItself) {
  for (const char* text : {
           R"({"study": "regime_map", "grid": [{"name": "clearance_m", "from": 1e-4, "to": 5e-4, "count": 7}, {"name": "speed_rpm", "from": 1200, "to": 3000, "step": 20}]})",
           R"({"study": "monte_carlo", "name": "tol", "variant": "piecewise-linear", "sample": {"count": 50, "seed": 9, "vary": [{"name": "e_m", "normal": [7e-5, 5e-6]}, {"name": "k1_N_m", "log_uniform": [1e6, 1e7]}]}, "job": {"from_rpm": 1200, "to_rpm": 3000}})",
           R"({"study": "grid", "effects": ["shaft_bow:b=2e-5,phi_b=1"], "grid": [{"name": "effect.preload.F_y", "values": [0, -4]}], "sample": {"count": 2, "seed": 4, "vary": [{"name": "noise_m", "uniform": [1e-7, 1e-6]}]}, "job": {"type": "loop", "speeds_rpm": [1200, 1300, 1400, 1550], "keyphasor": false}})",
           R"({"study": "basins", "speed_rpm": 2200, "initial_state": [0, 0, 0.01, 0], "grid": [{"name": "y0_m", "values": [-1e-4, 0]}, {"name": "vy0_m_s", "values": [0, 0.1]}], "job": {"settle_revs": 30}})"}) {
    const std::string c = canonical_text(parse_spec(text, "t.json"));
    EXPECT_EQ(canonical_text(parse_spec(c, "spec.json")), c);
  }
}

// Points: the last grid axis fastest, then the samples; both ends of a counted axis exact.
TEST(StudyPoints, GridOrderAndExactEnds) {
  const spec s = parse_spec(R"({"study": "grid", "grid": [{"name": "clearance_m", "from": 2e-4, "to": 4e-4, "count": 3},
      {"name": "speed_rpm", "values": [1500, 1600]}], "sample": {"count": 2, "seed": 3, "vary": [{"name": "mu", "uniform": [0.1, 0.2]}]}})",
                            "t.json");
  ASSERT_EQ(point_count(s), 12u);
  EXPECT_EQ(point_at(s, 0).params.clearance, 2e-4);
  EXPECT_EQ(point_at(s, 11).params.clearance, 4e-4);
  EXPECT_EQ(point_at(s, 2).rpm, 1600.0);  // index = (clearance * 2 + speed) * 2 + sample
  EXPECT_EQ(point_at(s, 4).params.clearance, point_at(s, 7).params.clearance);
  EXPECT_NE(point_at(s, 0).params.mu, point_at(s, 1).params.mu);  // each sample its own draw
  EXPECT_EQ(point_at(s, 5).params.mu, point_at(s, 5).params.mu);
}

// The stream of a point depends on (seed, index, k) alone, and is uniform: over 20000 draws the
// mean and variance are within 5 standard errors of 1/2 and 1/12 (a fixed seed: not flaky), and
// the normal law's draws have the requested mean and deviation to 5 standard errors.
TEST(StudyPoints, RandomStreamsAreUniformAndKeyedByIndex) {
  const std::size_t n = 20000;
  double sum = 0.0, sq = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double u = uniform_draw(11, i, 0);
    ASSERT_GT(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum += u;
    sq += (u - 0.5) * (u - 0.5);
  }
  EXPECT_NEAR(sum / n, 0.5, 5.0 * std::sqrt(1.0 / 12.0 / n));
  EXPECT_NEAR(sq / n, 1.0 / 12.0, 5.0 * std::sqrt(1.0 / 180.0 / n));
  EXPECT_NE(uniform_draw(11, 5, 0), uniform_draw(12, 5, 0));
  EXPECT_NE(uniform_draw(11, 5, 0), uniform_draw(11, 5, 1));

  const spec s = parse_spec(R"({"study": "grid", "sample": {"count": 20000, "seed": 2, "vary": [{"name": "e_m", "normal": [7e-5, 5e-6]}]}})", "t.json");
  double m = 0.0, v = 0.0;
  for (std::size_t i = 0; i < n; ++i) m += point_at(s, i).params.e;
  m /= n;
  for (std::size_t i = 0; i < n; ++i) v += std::pow(point_at(s, i).params.e - m, 2);
  v /= n - 1;
  EXPECT_NEAR(m, 7e-5, 5.0 * 5e-6 / std::sqrt(n));
  EXPECT_NEAR(std::sqrt(v), 5e-6, 5.0 * 5e-6 / std::sqrt(2.0 * n));
}

// Shards partition the points: contiguous, disjoint, complete, sizes within one.
TEST(StudyShards, BlocksPartitionThePoints) {
  for (std::size_t points : {1u, 7u, 100u, 1547u})
    for (std::size_t of : {1u, 2u, 3u, 8u, 13u}) {
      std::size_t next = 0;
      for (std::size_t i = 1; i <= of; ++i) {
        const auto [first, last] = shard_block(points, {i, of});
        EXPECT_EQ(first, next);
        EXPECT_LE(last - first, points / of + 1);
        next = last;
      }
      EXPECT_EQ(next, points);
    }
  EXPECT_THROW(parse_shard("0/3"), input_error);
  EXPECT_THROW(parse_shard("4/3"), input_error);
  EXPECT_THROW(parse_shard("1-3"), input_error);
  EXPECT_EQ(parse_shard("2/3").number, 2u);
}

// A contact-free point's orbit job returns the closed form (Eq. 1 without contact): its top and
// radius to 1e-9 of the clearance (a shot orbit is exact to 1e-12 m; the record's samples fall
// at the same phases as the closed form's grid, so only the sampling of the maximum differs,
// which the check bounds by evaluating the closed form on the same grid).
TEST(StudyJobs, ContactFreeOrbitIsTheClosedForm) {
  const spec s = parse_spec(R"({"study": "grid", "parameters": {"clearance_m": 0.01}, "grid": [{"name": "speed_rpm", "values": [1300, 1520, 2400]}]})", "t.json");
  for (std::size_t i = 0; i < point_count(s); ++i) {
    const auto row = evaluate(s, i);
    ASSERT_EQ(row[col(s, "status")], "ok") << row.back();
    EXPECT_EQ(row[col(s, "response")], "no_contact");
    EXPECT_EQ(row[col(s, "period_revs")], "1");
    const point p = point_at(s, i);
    const double w = rpm_to_rad_s(p.rpm);
    const unbalance_response cf(p.params, w);
    double top = -1.0;
    for (int k = 0; k < s.job.samples_per_rev; ++k) top = std::max(top, cf.at(2.0 * std::numbers::pi / w * k / s.job.samples_per_rev)[1]);
    EXPECT_NEAR(std::stod(row[col(s, "max_y_m")]), top, 1e-9 * 0.01);
    EXPECT_NEAR(std::stod(row[col(s, "forward_1x_m")]), std::abs(cf.forward()), 1e-9 * 0.01);
    EXPECT_NEAR(std::stod(row[col(s, "backward_1x_m")]), std::abs(cf.backward()), 1e-9 * 0.01);
  }
}

// The run-up's rub onset is where the contact-free orbit's top reaches the clearance: the
// closed form's root, found here by bisection, to 0.01 rpm (the continuation locates the grazing
// to ~1e-6 of the clearance in the top, ~0.001 rpm on this slope).
TEST(StudyJobs, RunUpOnsetIsWhereTheClosedFormTouches) {
  const spec s = parse_spec(R"({"study": "grid", "grid": [{"name": "clearance_m", "values": [2e-4, 3e-4]}], "job": {"type": "run_up", "from_rpm": 1200, "to_rpm": 3200}})", "t.json");
  for (std::size_t i = 0; i < point_count(s); ++i) {
    const auto row = evaluate(s, i);
    ASSERT_EQ(row[col(s, "status")], "ok") << row.back();
    const parameters p = point_at(s, i).params;
    const auto top = [&](double rpm) {
      const unbalance_response cf(p, rpm_to_rad_s(rpm));
      return std::abs(cf.y_phasor);  // the contact-free orbit's top: the amplitude of y
    };
    double lo = 1200.0, hi = 1520.0;  // below the vertical critical speed the top grows with speed
    ASSERT_LT(top(lo), p.clearance);
    ASSERT_GT(top(hi), p.clearance);
    for (int k = 0; k < 60; ++k) (top(0.5 * (lo + hi)) < p.clearance ? lo : hi) = 0.5 * (lo + hi);
    EXPECT_NEAR(std::stod(row[col(s, "onset_rpm")]), lo, 0.01);
    EXPECT_GT(std::stod(row[col(s, "jump_rpm")]), 2000.0);  // the rubbing branch folds far above (docs/orbits.md)
    EXPECT_GT(std::stod(row[col(s, "peak_force_N")]), 0.0);
  }
}

// A start inside the stator is no state of the rotor: status invalid, never a number.
TEST(StudyJobs, StartInsideTheStatorIsInvalid) {
  const spec s = parse_spec(R"({"study": "grid", "grid": [{"name": "y0_m", "values": [0.5e-3]}], "job": {"start": "state"}})", "t.json");
  const auto row = evaluate(s, 0);
  EXPECT_EQ(row[col(s, "status")], "invalid");
  EXPECT_EQ(row[col(s, "max_y_m")], "nan");
  EXPECT_NE(row.back().find("inside the stator"), std::string::npos);
}

// A journal's unfinished last line (a killed writer) is dropped, and the point runs again; a
// row that contradicts another of the same index is refused.
TEST(StudyFolder, JournalsSurviveAKillAndRefuseContradictions) {
  const fs::path dir = fs::temp_directory_path() / ("rubref_study_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const spec s = parse_spec(R"({"study": "grid", "parameters": {"clearance_m": 0.01}, "grid": [{"name": "speed_rpm", "values": [1300, 1400, 1500]}]})", "t.json");
  open_study_folder(dir, canonical_text(s));
  {
    journal j(dir, s, shard{});
    j.append({evaluate(s, 0), evaluate(s, 1)});
  }
  {  // a kill in the middle of the third row
    std::ofstream out(dir / "rows-1-of-1.csv", std::ios::app);
    out << "2,1500,ok,no_con";
  }
  EXPECT_EQ(read_rows(dir, s).size(), 2u);
  run_settings rs;
  rs.threads = 1;
  const run_outcome o = run_study(dir, s, rs);
  EXPECT_EQ(o.already, 2u);
  EXPECT_EQ(o.computed, 1u);
  EXPECT_TRUE(o.complete);
  EXPECT_EQ(read_rows(dir, s).size(), 3u);
  {  // another writer's different row for point 1
    std::ofstream out(dir / "rows-2-of-2.csv");
    auto row = evaluate(s, 1);
    row[col(s, "max_y_m")] = "1";
    out << "# generator: rubref test study\n" << row_line(columns(s)) << "\n" << row_line(row) << "\n";
  }
  EXPECT_THROW(read_rows(dir, s), input_error);
  // Another study cannot use the folder.
  const spec other = parse_spec(R"({"study": "grid", "grid": [{"name": "speed_rpm", "values": [1300]}]})", "t.json");
  EXPECT_THROW(check_study_folder(dir, canonical_text(other)), input_error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rubref::study
