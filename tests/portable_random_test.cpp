// The project's portable random draws (ref/base/portable_random.hpp): the first draws pinned bit
// for bit (they must be these on every IEEE-754 toolchain), portable_log and portable_exp within
// 1 ulp of libm, AS 241 against Boost.Math's normal quantile, and the draws' moments.

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include <boost/math/distributions/normal.hpp>

#include "ref/base/portable_random.hpp"

namespace rubref {
namespace {

// Distance in units in the last place between two finite doubles of the same sign.
std::int64_t ulps(double a, double b) { return std::abs(std::bit_cast<std::int64_t>(a) - std::bit_cast<std::int64_t>(b)); }

// Both fdlibm's algorithms and glibc's are within 1 ulp of the true value (glibc's within ~0.5):
// each returns one of the two doubles around it, so they differ by at most 1 ulp.
constexpr std::int64_t kLibmUlps = 1;
// AS 241 is accurate to about 1e-16 relative (Wichura 1988); Boost's quantile to a few eps; the
// difference is measured as |a - b| / max(1, |b|) (absolute near the median, where q ~ 0).
constexpr double kAs241Tol = 2e-15;
// Moments of kMomentDraws draws: each within 5 standard errors of its exact value (a false alarm
// about once in 1.7 million runs; the draws are fixed, so a pass is a pass on every toolchain).
constexpr int kMomentDraws = 1'000'000;
constexpr double kSigmas = 5.0;

TEST(PortableRandom, FirstDrawsArePinnedBitForBit) {
  // SplitMix64 from mix(mix(1) ^ 0): the raw 64-bit draws.
  portable_stream raw(1, 0);
  EXPECT_EQ(raw.next(), 0xb18a02f46d8d86c3ULL);
  EXPECT_EQ(raw.next(), 0xf8c5b62c83f707e8ULL);
  EXPECT_EQ(raw.next(), 0x6d339d1740130eddULL);
  EXPECT_EQ(raw.next(), 0xce639a27887a2771ULL);
  // The same stream as uniforms: (top 53 bits + 1/2) 2^-53.
  portable_stream uni(1, 0);
  EXPECT_EQ(uni.uniform(), 0x1.631405e8db1bp-1);
  EXPECT_EQ(uni.uniform(), 0x1.f18b6c5907eep-1);
  EXPECT_EQ(uni.uniform(), 0x1.b4ce745d004c3p-2);
  // As normals (AS 241 of those uniforms; the second is in AS 241's tail branch, through portable_log).
  portable_stream nor(1, 0);
  const double normals[6] = {0x1.02fc3372f095cp-1,  0x1.e84ca08953d8p+0,   -0x1.7b1e625f42d5p-3,
                             0x1.ba5ece67d5938p-1,  -0x1.71c3fa311345bp-2, 0x1.044a575304a1dp+0};
  for (const double expected : normals) EXPECT_EQ(nor.normal(), expected);
  // A rig's stream: seed 20261125, dwell 3.
  portable_stream rig(20261125, 3);
  EXPECT_EQ(rig.normal(), 0x1.12cedc6026508p-1);
  EXPECT_EQ(rig.normal(), -0x1.8bdec51d846bcp-2);
  // Integers below n, by rejection.
  portable_stream ints(3, 1);
  for (const std::uint64_t expected : {0u, 7u, 8u, 5u, 0u, 3u}) EXPECT_EQ(ints.below(10), expected);
  // A study's counter-based draw and its laws.
  EXPECT_EQ(keyed_uniform(6173, 5, 2), 0x1.7c1e8fd0dac88p-1);
  EXPECT_EQ(log_uniform(2e-7, 2e-6, 0.25), 0x1.7de1f1c6bac24p-22);
  // The quantile in each of AS 241's three branches.
  EXPECT_EQ(normal_quantile(0.975), 0x1.f5c0331eeff82p+0);
  EXPECT_EQ(normal_quantile(0.01), -0x1.29c5c4630ff0ep+1);
  EXPECT_EQ(normal_quantile(0x1p-60), -0x1.18bf0c0948e3fp+3);
  EXPECT_EQ(portable_log(10.0), 0x1.26bb1bbb55516p+1);
  EXPECT_EQ(portable_exp(1.0), 0x1.5bf0a8b14576ap+1);
}

TEST(PortableRandom, LogAndExpAreWithinOneUlpOfLibm) {
  portable_stream s(2026, 45);
  std::int64_t worst_log = 0, worst_exp = 0;
  double worst_log_x = 0.0, worst_exp_x = 0.0;
  for (int i = 0; i < 2'000'000; ++i) {
    // log over the normal range (mantissa and exponent uniform) and subnormals.
    const double x = std::ldexp(1.0 + s.uniform(), static_cast<int>(s.below(2098)) - 1074);
    const std::int64_t d = ulps(portable_log(x), std::log(x));
    if (d > worst_log) worst_log = d, worst_log_x = x;
    // exp from its underflow (subnormal results) to its overflow threshold.
    const double y = s.uniform(-745.0, 709.7);
    const std::int64_t e = ulps(portable_exp(y), std::exp(y));
    if (e > worst_exp) worst_exp = e, worst_exp_x = y;
  }
  EXPECT_LE(worst_log, kLibmUlps) << "log at x = " << worst_log_x;
  EXPECT_LE(worst_exp, kLibmUlps) << "exp at x = " << worst_exp_x;
  // Special values as libm's.
  EXPECT_EQ(portable_log(1.0), 0.0);
  EXPECT_EQ(portable_log(0.0), -HUGE_VAL);
  EXPECT_TRUE(std::isnan(portable_log(-1.0)));
  EXPECT_EQ(portable_log(HUGE_VAL), HUGE_VAL);
  EXPECT_EQ(portable_exp(0.0), 1.0);
  EXPECT_EQ(portable_exp(-HUGE_VAL), 0.0);
  EXPECT_EQ(portable_exp(710.0), HUGE_VAL);
  EXPECT_EQ(portable_exp(-746.0), 0.0);
}

TEST(PortableRandom, As241MatchesBoostsNormalQuantile) {
  const boost::math::normal standard;
  double worst = 0.0, worst_p = 0.0;
  const auto check = [&](double p) {
    const double q = normal_quantile(p), b = boost::math::quantile(standard, p);
    const double err = std::abs(q - b) / std::max(1.0, std::abs(b));
    if (err > worst) worst = err, worst_p = p;
  };
  portable_stream s(241, 0);
  for (int i = 0; i < 200'000; ++i) check(s.uniform());
  for (int e = -1074; e <= -2; ++e) check(std::ldexp(1.0, e)), check(1.0 - std::ldexp(1.0, std::max(e, -53)));
  EXPECT_LE(worst, kAs241Tol) << "at p = " << worst_p;
  EXPECT_EQ(normal_quantile(0.5), 0.0);
  EXPECT_EQ(normal_quantile(0.0), -HUGE_VAL);
  EXPECT_EQ(normal_quantile(1.0), HUGE_VAL);
}

TEST(PortableRandom, MomentsOfTheDraws) {
  // Normals: raw moments 0, 1, 0, 3; the standard errors of their sample means over n draws are
  // sqrt(Var(z^k) / n): Var(z) = 1, Var(z^2) = 2, Var(z^3) = E z^6 = 15, Var(z^4) = 105 - 9 = 96.
  portable_stream s(9001, 7);
  double m1 = 0.0, m2 = 0.0, m3 = 0.0, m4 = 0.0;
  for (int i = 0; i < kMomentDraws; ++i) {
    const double z = s.normal();
    m1 += z, m2 += z * z, m3 += z * z * z, m4 += z * z * z * z;
  }
  const double n = kMomentDraws;
  m1 /= n, m2 /= n, m3 /= n, m4 /= n;
  EXPECT_NEAR(m1, 0.0, kSigmas * std::sqrt(1.0 / n));
  EXPECT_NEAR(m2, 1.0, kSigmas * std::sqrt(2.0 / n));
  EXPECT_NEAR(m3, 0.0, kSigmas * std::sqrt(15.0 / n)) << "third moment";
  EXPECT_NEAR(m4 - 3.0, 0.0, kSigmas * std::sqrt(96.0 / n)) << "fourth moment";
  // Uniforms: mean 1/2 (standard error sqrt(1/12n)), variance 1/12 (sqrt(1/180n)).
  portable_stream u(9001, 8);
  double u1 = 0.0, u2 = 0.0;
  for (int i = 0; i < kMomentDraws; ++i) {
    const double v = u.uniform();
    ASSERT_GT(v, 0.0);
    ASSERT_LT(v, 1.0);
    u1 += v, u2 += v * v;
  }
  u1 /= n, u2 /= n;
  EXPECT_NEAR(u1, 0.5, kSigmas * std::sqrt(1.0 / (12.0 * n)));
  EXPECT_NEAR(u2 - u1 * u1, 1.0 / 12.0, kSigmas * std::sqrt(1.0 / (180.0 * n)));
  // Integers below 3: each count within 5 standard errors of n/3.
  portable_stream b(9001, 9);
  std::vector<int> count(3, 0);
  for (int i = 0; i < kMomentDraws; ++i) ++count[b.below(3)];
  for (const int c : count) EXPECT_NEAR(c, n / 3.0, kSigmas * std::sqrt(n * (1.0 / 3.0) * (2.0 / 3.0)));
}

TEST(PortableRandom, StreamsOfOtherIndicesAreOthers) {
  // A dwell's stream must not repeat another's draws shifted (as seed * c + dwell could).
  std::vector<std::uint64_t> first;
  for (std::uint64_t seed = 0; seed < 20; ++seed)
    for (std::uint64_t index = 0; index < 20; ++index) first.push_back(portable_stream(seed, index).next());
  std::sort(first.begin(), first.end());
  EXPECT_EQ(std::adjacent_find(first.begin(), first.end()), first.end());
}

}  // namespace
}  // namespace rubref
