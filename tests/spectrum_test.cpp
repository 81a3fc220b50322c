// The full (directional) spectrum, Eq. 7: known orbits give their exact forward and backward
// amplitudes, and Parseval holds.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <vector>

#include "ref/analysis/spectrum.hpp"
#include "ref/base/errors.hpp"

namespace rubref {
namespace {

using namespace std::complex_literals;
using cplx = std::complex<double>;

// An FFT of length N carries round-off of order log2(N) eps relative to the signal.
constexpr double kFftTol = 1e-13;

// Samples r(t) on `revs` revolutions of a 1 Hz shaft, `per_rev` samples each, from t0 (s).
struct sampled {
  std::vector<double> x, y;
  double dt, t0;
};
template <class F>
sampled sample(F&& r, int revs, int per_rev, double t0 = 0.0) {
  sampled s{{}, {}, 1.0 / per_rev, t0};
  for (int n = 0; n < revs * per_rev; ++n) {
    const cplx v = r(t0 + n * s.dt);
    s.x.push_back(v.real());
    s.y.push_back(v.imag());
  }
  return s;
}
directional_spectrum spectrum_of(const sampled& s, window_kind w = window_kind::rectangular) {
  return full_spectrum(s.x, s.y, s.dt, s.t0, w);
}
cplx whirl(double order, double t) { return std::exp(2i * std::numbers::pi * order * t); }

TEST(spectrum, forward_circle_is_forward_only) {
  const double A = 2.5e-4, phi = 0.7;
  const auto s = spectrum_of(sample([&](double t) { return A * std::exp(1i * phi) * whirl(1, t); }, 4, 64));
  EXPECT_NEAR(std::abs(s.at(1.0) - A * std::exp(1i * phi)), 0.0, kFftTol * A);
  EXPECT_LE(s.amplitude(-1.0), kFftTol * A);
  EXPECT_DOUBLE_EQ(s.resolution, 0.25);  // 4 revolutions: quarter-order bins
}

TEST(spectrum, backward_circle_is_backward_only) {
  const double A = 1e-4;
  const auto s = spectrum_of(sample([&](double t) { return A * whirl(-1, t); }, 3, 32));
  EXPECT_NEAR(s.amplitude(-1.0), A, kFftTol * A);
  EXPECT_LE(s.amplitude(1.0), kFftTol * A);
}

// x = a cos wt, y = b sin wt = (a+b)/2 e^{jwt} + (a-b)/2 e^{-jwt}: a horizontal ellipse whirls
// forward with a backward part (a-b)/2; b > a flips the sign of the backward coefficient.
TEST(spectrum, ellipse_splits_into_forward_and_backward) {
  for (const auto& ab : {std::pair{3e-4, 1e-4}, std::pair{1e-4, 3e-4}}) {
    const double a = ab.first, b = ab.second;  // not a structured binding: clang 14 cannot capture one
    const auto s = spectrum_of(sample([&](double t) {
      const double w = 2 * std::numbers::pi * t;
      return cplx(a * std::cos(w), b * std::sin(w));
    }, 2, 16));
    EXPECT_NEAR(std::abs(s.at(1.0) - (a + b) / 2), 0.0, kFftTol * a);
    EXPECT_NEAR(std::abs(s.at(-1.0) - (a - b) / 2), 0.0, kFftTol * a);
  }
}

// Harmonics, a backward 3X and the 1/2 and 1/3 subharmonics of partial rub, all on bins when the
// record spans a multiple of 6 revolutions; phases refer to t = 0 even when t0 does not.
TEST(spectrum, sum_of_harmonics_and_subharmonics_is_exact) {
  const std::vector<std::pair<double, cplx>> parts{
      {1.0, 3e-4 * std::exp(0.3i)}, {-1.0, 1e-4 * std::exp(-1.1i)}, {0.5, 5e-5 * std::exp(2.0i)},
      {-1.0 / 3.0, 2e-5}, {2.0, 4e-5i}, {-3.0, 1e-5}, {0.0, -7e-6}};
  const auto r = [&](double t) {
    cplx v = 0;
    for (const auto& [order, c] : parts) v += c * whirl(order, t);
    return v;
  };
  const auto s = spectrum_of(sample(r, 12, 64, 123.456));
  for (const auto& [order, c] : parts) EXPECT_NEAR(std::abs(s.at(order) - c), 0.0, kFftTol * 3e-4) << "order " << order;
  double leaked = 0.0;  // nothing anywhere else
  for (std::size_t k = 0; k < s.coefficient.size(); ++k) {
    const bool known = std::any_of(parts.begin(), parts.end(),
                                   [&](const auto& p) { return std::abs(s.frequency[k] - p.first) < s.resolution / 2; });
    if (!known) leaked = std::max(leaked, std::abs(s.coefficient[k]));
  }
  EXPECT_LE(leaked, kFftTol * 3e-4);
}

TEST(spectrum, parseval_holds) {
  std::mt19937_64 rng(20261122);
  std::normal_distribution<double> noise(0.0, 1e-4);
  sampled s{{}, {}, 1e-3, 0.0};
  for (int n = 0; n < 1000; ++n) {
    s.x.push_back(noise(rng));
    s.y.push_back(noise(rng));
  }
  double time_power = 0.0;
  for (std::size_t n = 0; n < s.x.size(); ++n) time_power += (s.x[n] * s.x[n] + s.y[n] * s.y[n]) / s.x.size();
  // Rectangular: mean power = sum of |c_k|^2.
  const auto rect = spectrum_of(s);
  double spec_power = 0.0;
  for (const auto& c : rect.coefficient) spec_power += std::norm(c);
  EXPECT_NEAR(spec_power, time_power, kFftTol * time_power);
  // Hann: sum |w r|^2 = (sum w)^2 / N * sum |c_k|^2, with sum w = N/2.
  const auto hann = spectrum_of(s, window_kind::hann);
  double windowed = 0.0, hann_power = 0.0;
  const double n = static_cast<double>(s.x.size());
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    const double w = 0.5 - 0.5 * std::cos(2 * std::numbers::pi * i / n);
    windowed += w * w * (s.x[i] * s.x[i] + s.y[i] * s.y[i]);
  }
  for (const auto& c : hann.coefficient) hann_power += std::norm(c);
  EXPECT_NEAR(hann_power * (n / 2) * (n / 2) / n, windowed, kFftTol * windowed);
}

// Hann keeps the amplitude of a tone on a bin (its coherent gain is divided out) and is the
// window to use for records that do not span whole periods.
TEST(spectrum, hann_preserves_on_bin_amplitude_and_seconds_give_hertz) {
  const double A = 1e-4, f = 25.0;  // Hz
  sampled s{{}, {}, 1e-3, 0.0};
  for (int n = 0; n < 2000; ++n) {
    const cplx v = A * std::exp(2i * std::numbers::pi * f * (n * 1e-3));
    s.x.push_back(v.real());
    s.y.push_back(v.imag());
  }
  const auto sp = spectrum_of(s, window_kind::hann);
  EXPECT_DOUBLE_EQ(sp.resolution, 0.5);  // 1 / (2000 * 1 ms)
  EXPECT_NEAR(sp.amplitude(f), A, kFftTol * A);
  EXPECT_NEAR(sp.amplitude(f + 0.5), A / 2, kFftTol * A);  // Hann's neighbours carry half
}

// spectrum_line is full_spectrum's line by a direct sum: the same bin (the nearest to f, none
// outside the spectrum), window, scaling and phase reference. Each sum's round-off is of order
// eps times the signal; on random data of N = 385 samples (odd: bins -192..192) and a start
// t0 off the grid, every line agrees with the FFT's to kFftTol of the signal.
TEST(spectrum, a_line_is_the_full_spectrums_line) {
  std::mt19937_64 rng(20261129);
  std::normal_distribution<double> noise(0.0, 1e-4);
  sampled s{{}, {}, 1.0 / 35, 0.37};
  for (int n = 0; n < 385; ++n) {
    s.x.push_back(noise(rng));
    s.y.push_back(noise(rng));
  }
  for (const window_kind w : {window_kind::rectangular, window_kind::hann}) {
    const auto full = spectrum_of(s, w);
    double scale = 0.0;
    for (const auto& c : full.coefficient) scale = std::max(scale, std::abs(c));
    for (std::size_t k = 0; k < full.frequency.size(); ++k) {
      // On the bin and a third of a bin beside it: the same line.
      for (const double off : {0.0, 0.33, -0.33}) {
        const double f = full.frequency[k] + off * full.resolution;
        ASSERT_LE(std::abs(spectrum_line(s.x, s.y, s.dt, s.t0, f, w) - full.coefficient[k]), kFftTol * scale) << k << " " << off;
      }
    }
    // Beyond the last bin on either side: no line, as at() gives none.
    const double beyond = full.frequency.back() + full.resolution;
    EXPECT_EQ(spectrum_line(s.x, s.y, s.dt, s.t0, beyond, w), cplx{});
    EXPECT_EQ(spectrum_line(s.x, s.y, s.dt, s.t0, full.frequency.front() - full.resolution, w), cplx{});
  }
  // A pure whirl on a bin: its amplitude and phase exactly as full_spectrum gives them.
  const double A = 2.5e-4, phi = 0.7;
  const auto w = sample([&](double t) { return A * std::exp(1i * phi) * whirl(-3, t); }, 4, 64, 0.21);
  EXPECT_NEAR(std::abs(spectrum_line(w.x, w.y, w.dt, w.t0, -3.0) - A * std::exp(1i * phi)), 0.0, kFftTol * A);
  EXPECT_NEAR(std::abs(spectrum_line(w.x, w.y, w.dt, w.t0, 3.0)), 0.0, kFftTol * A);
  EXPECT_THROW(spectrum_line(std::vector<double>{1.0}, std::vector<double>{1.0}, 1.0, 0.0, 0.0), input_error);
}

TEST(spectrum, bitwise_reproducible) {
  const auto s = sample([](double t) { return 1e-4 * whirl(1, t) + 3e-5 * whirl(-2, t); }, 6, 128);
  const auto a = spectrum_of(s), b = spectrum_of(s);
  for (std::size_t k = 0; k < a.coefficient.size(); ++k) ASSERT_EQ(a.coefficient[k], b.coefficient[k]);
}

}  // namespace
}  // namespace rubref
