#pragma once
// Random draws with the same bits on every IEEE-754 toolchain (docs/robustness.md, Determinism).
//
// The standard fixes the sequence of std::mt19937_64 but not the output of its distributions
// (std::normal_distribution may use any algorithm) nor the last bits of libm's log and exp. So the
// project draws its own way:
//   - a stream is SplitMix64 (Steele, Lea & Flood, "Fast splittable pseudorandom number
//     generators", OOPSLA 2014) started at mix(mix(seed) ^ index): one stream per (seed, index),
//     e.g. per rig seed and dwell, so draws never depend on which thread runs which index;
//   - a uniform is the top 53 bits of a 64-bit draw, (k + 1/2) / 2^53, inside (0, 1);
//   - a normal is that uniform through the inverse normal CDF of Wichura's AS 241 (PPND16,
//     Applied Statistics 37, 1988, 477-484; relative accuracy ~1e-16), whose tails use the
//     project's portable_log and sqrt (IEEE-754 rounds sqrt correctly);
//   - portable_log and portable_exp are fdlibm's algorithms (Sun Microsystems, 1993; < 1 ulp)
//     written with + - * /, integer operations on the bits and ldexp only, in a fixed order of
//     evaluation; the library is built with -ffp-contract=off, so no compiler fuses them.
// tests/portable_random_test.cpp pins the first draws bit for bit.

#include <cstddef>
#include <cstdint>

namespace rubref {

// SplitMix64's output function of a state advanced by the golden gamma 0x9e3779b97f4a7c15.
std::uint64_t splitmix64_mix(std::uint64_t z);

class portable_stream {
 public:
  portable_stream(std::uint64_t seed, std::uint64_t index);
  std::uint64_t next();                  // 64 random bits
  double uniform();                      // in (0, 1), a multiple of 2^-54 rounded to double
  double normal();                       // standard normal: normal_quantile(uniform())
  double uniform(double a, double b);    // a + (b - a) * uniform()
  std::uint64_t below(std::uint64_t n);  // uniform integer in [0, n), n >= 1 (rejection: no modulo bias)

 private:
  std::uint64_t state_;
};

// The counter-based draw k of stream (seed, index) for a study's random variables:
// mix(mix(mix(seed) ^ index) ^ k) as a uniform in (0, 1); needs no state from earlier draws.
double keyed_uniform(std::uint64_t seed, std::uint64_t index, std::uint64_t k);

// The quantile of the standard normal at p in (0, 1) by AS 241 (PPND16); +-inf at 0 and 1.
double normal_quantile(double p);

// log-uniform on [a, b] (0 < a <= b) at u in [0, 1]: exp(log a + (log b - log a) u), portably.
double log_uniform(double a, double b, double u);

// Natural logarithm and exponential, the same bits everywhere, within 1 ulp of the true value.
double portable_log(double x);
double portable_exp(double x);

}  // namespace rubref
