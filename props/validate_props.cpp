// Property: a golden orbit put through any of the output transforms validate knows (a time
// shift, a mirrored or swapped axis, a unit factor, a constant offset, in any combination) fails
// and is recognised: every transform applied is named, confirmed, and the first cause is one of
// them (docs/validation.md, "Causes").

#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <set>
#include <string>

#include "ref/validation/golden.hpp"
#include "ref/validation/validate.hpp"

namespace rubref {
namespace {

// Periodic cases: period 1 with a compliant law, period 3, period 1 with impacts.
constexpr std::array<const char*, 3> kCases{"identified_0.3mm_1600rpm.csv", "piecewise-linear_0.2mm_1550rpm.csv",
                                            "restitution_0.3mm_1650rpm.csv"};

const golden_case& load(std::size_t k) {
  static const std::array<golden_case, 3> cases = [] {
    std::array<golden_case, 3> out;
    for (std::size_t i = 0; i < kCases.size(); ++i)
      out[i] = read_golden_case(read_record(std::filesystem::path(RUBREF_GOLDEN_DIR) / kCases[i]), kCases[i]);
    return out;
  }();
  return cases[k];
}

// candidate = A golden + b (m), in units of 1/scale, at times shifted back by tau.
constexpr std::array<std::array<int, 4>, 8> kMaps{{{1, 0, 0, 1}, {-1, 0, 0, 1}, {1, 0, 0, -1}, {-1, 0, 0, -1},
                                                    {0, 1, 1, 0}, {0, -1, 1, 0}, {0, 1, -1, 0}, {0, -1, -1, 0}}};
constexpr std::array<double, 4> kScales{1.0, 1e3, 1e6, 1.0 / 25.4e-6};

RC_GTEST_PROP(validate, any_known_transform_of_a_golden_orbit_is_named_and_confirmed, ()) {
  const auto which = *rc::gen::inRange<std::size_t>(0, kCases.size());
  const golden_case& g = load(which);
  const double T = 60.0 / g.request.rpm, P = g.period_revs * T;
  const auto map = *rc::gen::inRange<std::size_t>(0, kMaps.size());
  const auto unit = *rc::gen::inRange<std::size_t>(0, kScales.size());
  // A shift of none, half a revolution (with x mirrored: the clockwise mirror image), or any
  // other away from whole and half revolutions by at least 1 % of one.
  const int shift_kind = *rc::gen::inRange(0, 3);
  double tau = 0.0;
  if (shift_kind == 1) tau = T / 2;
  if (shift_kind == 2) {
    const double u = *rc::gen::inRange(0, 1000000) / 1e6;
    tau = P * u;
    const double within = std::fmod(tau, T) / T;
    RC_PRE(std::abs(within - 0.5) > 0.01 && within > 0.01 && within < 0.99);
  }
  const bool offset = *rc::gen::arbitrary<bool>();
  const double bx = offset ? *rc::gen::inRange(-50, 51) * 1e-6 : 0.0, by = offset ? *rc::gen::inRange(5, 51) * 1e-6 : 0.0;
  RC_PRE(map != 0 || unit != 0 || tau != 0.0 || offset);

  const auto& A = kMaps[map];
  const double s = kScales[unit];
  record r;
  std::vector<double> t, x, y;
  for (std::size_t i = 0; i < g.t.size(); ++i) {
    t.push_back(g.t[i] - tau);
    x.push_back(s * (A[0] * g.x[i] + A[1] * g.y[i] + bx));
    y.push_back(s * (A[2] * g.x[i] + A[3] * g.y[i] + by));
  }
  r.add_column("t_s", t);
  r.add_column("x_m", x);
  r.add_column("y_m", y);
  r.add_column("speed_rpm", std::vector<double>(t.size(), g.request.rpm));
  const validation_result v = validate_candidate(g, r, "transformed");

  std::set<std::string> want;
  if (unit != 0) want.insert("units");
  if (map == 1 && shift_kind == 1) {
    want.insert("rotation_sense");
  } else {
    if (map != 0) want.insert("mirrored_axis");
    if (tau != 0.0) want.insert("time_origin_or_unbalance_phase");
  }
  if (offset) want.insert("static_offset");
  RC_ASSERT(!v.pass);
  RC_ASSERT(!v.causes.empty());
  std::set<std::string> named;
  for (const auto& c : v.causes) {
    named.insert(std::string(to_string(c.code)));
    if (want.count(std::string(to_string(c.code)))) RC_ASSERT(c.confidence == cause_confidence::confirmed);
  }
  for (const auto& w : want) RC_ASSERT(named.count(w) == 1u);
  RC_ASSERT(want.count(std::string(to_string(v.causes.front().code))) == 1u);
}

}  // namespace
}  // namespace rubref
