#include "ref/base/portable_random.hpp"

#include <bit>
#include <cmath>
#include <limits>

namespace rubref {

namespace {

constexpr std::uint64_t kGoldenGamma = 0x9e3779b97f4a7c15ULL;

// The top 53 bits as (k + 1/2) 2^-53: never 0 or 1, so the normal's quantile stays finite.
double to_unit(std::uint64_t z) { return (static_cast<double>(z >> 11) + 0.5) * 0x1.0p-53; }

double from_words(std::uint32_t hi, std::uint32_t lo) {
  return std::bit_cast<double>((static_cast<std::uint64_t>(hi) << 32) | lo);
}
std::uint32_t high_word(double x) { return static_cast<std::uint32_t>(std::bit_cast<std::uint64_t>(x) >> 32); }
std::uint32_t low_word(double x) { return static_cast<std::uint32_t>(std::bit_cast<std::uint64_t>(x)); }
double with_high_word(double x, std::uint32_t hi) {
  return std::bit_cast<double>((static_cast<std::uint64_t>(hi) << 32) | (std::bit_cast<std::uint64_t>(x) & 0xffffffffULL));
}

}  // namespace

std::uint64_t splitmix64_mix(std::uint64_t z) {
  z += kGoldenGamma;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

portable_stream::portable_stream(std::uint64_t seed, std::uint64_t index) : state_(splitmix64_mix(splitmix64_mix(seed) ^ index)) {}

std::uint64_t portable_stream::next() {
  // SplitMix64: the state advances by the gamma, the output is its mix (splitmix64_mix adds the
  // gamma itself, so the state here is the last value before that addition).
  const std::uint64_t out = splitmix64_mix(state_);
  state_ += kGoldenGamma;
  return out;
}

double portable_stream::uniform() { return to_unit(next()); }

double portable_stream::normal() { return normal_quantile(uniform()); }

double portable_stream::uniform(double a, double b) { return a + (b - a) * uniform(); }

std::uint64_t portable_stream::below(std::uint64_t n) {
  // Reject the top partial block of size 2^64 mod n: every residue then has the same count.
  const std::uint64_t reject_from = std::numeric_limits<std::uint64_t>::max() - std::numeric_limits<std::uint64_t>::max() % n;
  for (;;) {
    const std::uint64_t z = next();
    if (z < reject_from) return z % n;
  }
}

double keyed_uniform(std::uint64_t seed, std::uint64_t index, std::uint64_t k) {
  return to_unit(splitmix64_mix(splitmix64_mix(splitmix64_mix(seed) ^ index) ^ k));
}

double normal_quantile(double p) {
  // AS 241 PPND16 (Wichura 1988), coefficients and evaluation order as published.
  if (!(p > 0.0)) return p == 0.0 ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::quiet_NaN();
  if (!(p < 1.0)) return p == 1.0 ? std::numeric_limits<double>::infinity() : std::numeric_limits<double>::quiet_NaN();
  constexpr double split1 = 0.425, split2 = 5.0, const1 = 0.180625, const2 = 1.6;
  constexpr double a0 = 3.3871328727963666080e0, a1 = 1.3314166789178437745e+2, a2 = 1.9715909503065514427e+3,
                   a3 = 1.3731693765509461125e+4, a4 = 4.5921953931549871457e+4, a5 = 6.7265770927008700853e+4,
                   a6 = 3.3430575583588128105e+4, a7 = 2.5090809287301226727e+3;
  constexpr double b1 = 4.2313330701600911252e+1, b2 = 6.8718700749205790830e+2, b3 = 5.3941960214247511077e+3,
                   b4 = 2.1213794301586595867e+4, b5 = 3.9307895800092710610e+4, b6 = 2.8729085735721942674e+4,
                   b7 = 5.2264952788528545610e+3;
  constexpr double c0 = 1.42343711074968357734e0, c1 = 4.63033784615654529590e0, c2 = 5.76949722146069140550e0,
                   c3 = 3.64784832476320460504e0, c4 = 1.27045825245236838258e0, c5 = 2.41780725177450611770e-1,
                   c6 = 2.27238449892691845833e-2, c7 = 7.74545014278341407640e-4;
  constexpr double d1 = 2.05319162663775882187e0, d2 = 1.67638483018380384940e0, d3 = 6.89767334985100004550e-1,
                   d4 = 1.48103976427480074590e-1, d5 = 1.51986665636164571966e-2, d6 = 5.47593808499534494600e-4,
                   d7 = 1.05075007164441684324e-9;
  constexpr double e0 = 6.65790464350110377720e0, e1 = 5.46378491116411436990e0, e2 = 1.78482653991729133580e0,
                   e3 = 2.96560571828504891230e-1, e4 = 2.65321895265761230930e-2, e5 = 1.24266094738807843860e-3,
                   e6 = 2.71155556874348757815e-5, e7 = 2.01033439929228813265e-7;
  constexpr double f1 = 5.99832206555887937690e-1, f2 = 1.36929880922735805310e-1, f3 = 1.48753612908506148525e-2,
                   f4 = 7.86869131145613259100e-4, f5 = 1.84631831751005468180e-5, f6 = 1.42151175831644588870e-7,
                   f7 = 2.04426310338993978564e-15;
  const double q = p - 0.5;
  if (std::abs(q) <= split1) {
    const double r = const1 - q * q;
    return q * (((((((a7 * r + a6) * r + a5) * r + a4) * r + a3) * r + a2) * r + a1) * r + a0) /
           (((((((b7 * r + b6) * r + b5) * r + b4) * r + b3) * r + b2) * r + b1) * r + 1.0);
  }
  double r = q < 0.0 ? p : 1.0 - p;
  r = std::sqrt(-portable_log(r));
  double value;
  if (r <= split2) {
    r -= const2;
    value = (((((((c7 * r + c6) * r + c5) * r + c4) * r + c3) * r + c2) * r + c1) * r + c0) /
            (((((((d7 * r + d6) * r + d5) * r + d4) * r + d3) * r + d2) * r + d1) * r + 1.0);
  } else {
    r -= split2;
    value = (((((((e7 * r + e6) * r + e5) * r + e4) * r + e3) * r + e2) * r + e1) * r + e0) /
            (((((((f7 * r + f6) * r + f5) * r + f4) * r + f3) * r + f2) * r + f1) * r + 1.0);
  }
  return q < 0.0 ? -value : value;
}

double log_uniform(double a, double b, double u) {
  const double la = portable_log(a);
  return portable_exp(la + (portable_log(b) - la) * u);
}

double portable_log(double x) {
  // fdlibm e_log.c (Sun Microsystems 1993): x = 2^k (1 + f) with sqrt(2)/2 < 1 + f < sqrt(2),
  // log(1 + f) = f - f^2/2 + s (f^2/2 + R(s^2)), s = f / (2 + f), R a minimax polynomial.
  const double ln2_hi = from_words(0x3fe62e42, 0xfee00000), ln2_lo = from_words(0x3dea39ef, 0x35793c76);
  const double two54 = from_words(0x43500000, 0x00000000);
  const double Lg1 = from_words(0x3FE55555, 0x55555593), Lg2 = from_words(0x3FD99999, 0x9997FA04),
               Lg3 = from_words(0x3FD24924, 0x94229359), Lg4 = from_words(0x3FCC71C5, 0x1D8E78AF),
               Lg5 = from_words(0x3FC74664, 0x96CB03DE), Lg6 = from_words(0x3FC39A09, 0xD078C69F),
               Lg7 = from_words(0x3FC2F112, 0xDF3E5244);
  auto hx = static_cast<std::int32_t>(high_word(x));
  const std::uint32_t lx = low_word(x);
  std::int32_t k = 0;
  if (hx < 0x00100000) {  // x < 2^-1022: zero, negative or subnormal
    if (((hx & 0x7fffffff) | static_cast<std::int32_t>(lx)) == 0) return -std::numeric_limits<double>::infinity();
    if (hx < 0) return std::numeric_limits<double>::quiet_NaN();
    k -= 54;
    x *= two54;
    hx = static_cast<std::int32_t>(high_word(x));
  }
  if (hx >= 0x7ff00000) return x + x;  // inf or NaN
  k += (hx >> 20) - 1023;
  hx &= 0x000fffff;
  const std::int32_t i0 = (hx + 0x95f64) & 0x100000;
  x = with_high_word(x, static_cast<std::uint32_t>(hx | (i0 ^ 0x3ff00000)));  // x or x/2 into [sqrt(2)/2, sqrt(2))
  k += i0 >> 20;
  const double f = x - 1.0;
  const double dk = static_cast<double>(k);
  if ((0x000fffff & (2 + hx)) < 3) {  // |f| < 2^-20
    if (f == 0.0) return k == 0 ? 0.0 : dk * ln2_hi + dk * ln2_lo;
    const double R = f * f * (0.5 - 0.33333333333333333 * f);
    return k == 0 ? f - R : dk * ln2_hi - ((R - dk * ln2_lo) - f);
  }
  const double s = f / (2.0 + f);
  const double z = s * s;
  std::int32_t i = hx - 0x6147a;
  const double w = z * z;
  const std::int32_t j = 0x6b851 - hx;
  const double t1 = w * (Lg2 + w * (Lg4 + w * Lg6));
  const double t2 = z * (Lg1 + w * (Lg3 + w * (Lg5 + w * Lg7)));
  i |= j;
  const double R = t2 + t1;
  if (i > 0) {
    const double hfsq = 0.5 * f * f;
    return k == 0 ? f - (hfsq - s * (hfsq + R)) : dk * ln2_hi - ((hfsq - (s * (hfsq + R) + dk * ln2_lo)) - f);
  }
  return k == 0 ? f - s * (f - R) : dk * ln2_hi - ((s * (f - R) - dk * ln2_lo) - f);
}

double portable_exp(double x) {
  // fdlibm e_exp.c (Sun Microsystems 1993): x = k ln2 + r with |r| <= ln2/2 (ln2 in two parts,
  // k ln2_hi exact), exp(r) = 1 + r + r c(r) / (2 - c(r)) with c a minimax polynomial in r^2,
  // exp(x) = 2^k exp(r) (ldexp: exact, or rounded once where the result is subnormal).
  const double o_threshold = from_words(0x40862E42, 0xFEFA39EF), u_threshold = from_words(0xc0874910, 0xD52D3051);
  const double ln2_hi = from_words(0x3fe62e42, 0xfee00000), ln2_lo = from_words(0x3dea39ef, 0x35793c76);
  const double invln2 = from_words(0x3ff71547, 0x652b82fe);
  const double P1 = from_words(0x3FC55555, 0x5555553E), P2 = from_words(0xBF66C16C, 0x16BEBD93),
               P3 = from_words(0x3F11566A, 0xAF25DE2C), P4 = from_words(0xBEBBBD41, 0xC5D26BF1),
               P5 = from_words(0x3E663769, 0x72BEA4D0);
  const std::uint32_t hx = high_word(x) & 0x7fffffffU;
  const bool negative = std::signbit(x);
  if (hx >= 0x40862E42) {  // |x| >= 709.78...
    if (hx >= 0x7ff00000) {
      if (((hx & 0xfffff) | low_word(x)) != 0) return x + x;  // NaN
      return negative ? 0.0 : x;                             // exp(+-inf) = inf, 0
    }
    if (x > o_threshold) return std::numeric_limits<double>::infinity();
    if (x < u_threshold) return 0.0;
  }
  double hi = 0.0, lo = 0.0;
  int k = 0;
  if (hx > 0x3fd62e42) {  // |x| > ln2/2
    if (hx < 0x3FF0A2B2) {  // and |x| < 3 ln2/2
      hi = negative ? x + ln2_hi : x - ln2_hi;
      lo = negative ? -ln2_lo : ln2_lo;
      k = negative ? -1 : 1;
    } else {
      k = static_cast<int>(invln2 * x + (negative ? -0.5 : 0.5));
      const double t = k;
      hi = x - t * ln2_hi;  // t ln2_hi is exact here
      lo = t * ln2_lo;
    }
    x = hi - lo;
  } else if (hx < 0x3e300000) {  // |x| < 2^-28
    return 1.0 + x;
  }
  const double t = x * x;
  const double c = x - t * (P1 + t * (P2 + t * (P3 + t * (P4 + t * P5))));
  if (k == 0) return 1.0 - ((x * c) / (c - 2.0) - x);
  const double y = 1.0 - ((lo - (x * c) / (2.0 - c)) - hi);
  return std::ldexp(y, k);
}

}  // namespace rubref
