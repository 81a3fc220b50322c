#include "ref/analysis/spectrum.hpp"

#include <fftw3.h>

#include <cmath>
#include <map>
#include <mutex>
#include <numbers>
#include <optional>

#include "ref/base/errors.hpp"

namespace rubref {

namespace {

// FFTW plans are made once per length. Planning is not thread-safe (executing is), hence the
// mutex. FFTW_ESTIMATE never times alternatives and FFTW_UNALIGNED makes the plan independent of
// the buffers' alignment, so a given length always runs the same arithmetic: same bits on every
// run and every thread. At exit the plans and FFTW's planner are released (fftw_cleanup), so a
// leak checker sees nothing left (scripts/test-sanitizers).
struct plan_cache {
  std::mutex mutex;
  std::map<int, fftw_plan> plans;
  plan_cache() = default;
  plan_cache(const plan_cache&) = delete;
  plan_cache& operator=(const plan_cache&) = delete;
  ~plan_cache() {
    for (const auto& entry : plans) fftw_destroy_plan(entry.second);
    fftw_cleanup();
  }
};

fftw_plan forward_plan(int n) {
  static plan_cache cache;
  const std::lock_guard lock(cache.mutex);
  auto it = cache.plans.find(n);
  if (it == cache.plans.end()) {
    std::vector<std::complex<double>> in(n), out(n);
    const fftw_plan plan = fftw_plan_dft_1d(n, reinterpret_cast<fftw_complex*>(in.data()),
                                            reinterpret_cast<fftw_complex*>(out.data()), FFTW_FORWARD,
                                            FFTW_ESTIMATE | FFTW_UNALIGNED);
    if (!plan) throw numerical_error("FFTW could not plan a transform of length " + std::to_string(n));
    it = cache.plans.emplace(n, plan).first;
  }
  return it->second;
}

// The shared parts of full_spectrum, at and spectrum_line: input checks, the window, the shift of
// the DFT's phase from the first sample to t = 0, and the bin nearest to f.
void check_series(std::span<const double> x, std::span<const double> y, double dt) {
  if (x.size() < 2 || y.size() != x.size()) throw input_error("full spectrum needs two equally long series of at least 2 samples");
  if (!(dt > 0.0) || !std::isfinite(dt)) throw input_error("full spectrum needs a positive sample spacing");
}

// Periodic Hann: zero at the first sample, its coherent gain (mean) is exactly 1/2.
double window_weight(window_kind window, std::size_t i, std::size_t n) {
  return window == window_kind::hann ? 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * i / n) : 1.0;
}

std::complex<double> phase_to_time_zero(double f, double t0) {
  const double phase = -2.0 * std::numbers::pi * f * t0;
  return {std::cos(phase), std::sin(phase)};
}

std::ptrdiff_t first_bin(std::size_t n) { return -static_cast<std::ptrdiff_t>(n / 2); }

// The index (0 .. n-1, from the lowest frequency up) of the bin nearest to f; none outside.
std::optional<std::size_t> nearest_bin(double f, std::size_t n, double resolution) {
  const double k = std::round((f - static_cast<double>(first_bin(n)) * resolution) / resolution);
  if (!(k >= 0.0 && k < static_cast<double>(n))) return std::nullopt;
  return static_cast<std::size_t>(k);
}

}  // namespace

std::complex<double> directional_spectrum::at(double f) const {
  if (coefficient.empty()) return {};
  const auto i = nearest_bin(f, coefficient.size(), resolution);
  return i ? coefficient[*i] : std::complex<double>{};
}

directional_spectrum full_spectrum(std::span<const double> x, std::span<const double> y, double dt, double t0,
                                   window_kind window) {
  check_series(x, y, dt);
  const std::size_t n = x.size();
  std::vector<std::complex<double>> in(n), out(n);
  double weight_sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double w = window_weight(window, i, n);
    weight_sum += w;
    in[i] = w * std::complex<double>(x[i], y[i]);
  }
  fftw_execute_dft(forward_plan(static_cast<int>(n)), reinterpret_cast<fftw_complex*>(in.data()),
                   reinterpret_cast<fftw_complex*>(out.data()));

  directional_spectrum s;
  s.resolution = 1.0 / (static_cast<double>(n) * dt);
  s.frequency.resize(n);
  s.coefficient.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::ptrdiff_t k = first_bin(n) + static_cast<std::ptrdiff_t>(i);
    const std::size_t bin = static_cast<std::size_t>((k + static_cast<std::ptrdiff_t>(n)) % static_cast<std::ptrdiff_t>(n));
    const double f = static_cast<double>(k) * s.resolution;
    s.frequency[i] = f;
    s.coefficient[i] = out[bin] / weight_sum * phase_to_time_zero(f, t0);
  }
  return s;
}

std::complex<double> spectrum_line(std::span<const double> x, std::span<const double> y, double dt, double t0, double f,
                                   window_kind window) {
  check_series(x, y, dt);
  const std::size_t n = x.size();
  const double resolution = 1.0 / (static_cast<double>(n) * dt);
  const auto index = nearest_bin(f, n, resolution);  // the bin directional_spectrum::at picks
  if (!index) return {};
  const std::ptrdiff_t k = first_bin(n) + static_cast<std::ptrdiff_t>(*index);
  const std::size_t bin = static_cast<std::size_t>((k + static_cast<std::ptrdiff_t>(n)) % static_cast<std::ptrdiff_t>(n));
  std::complex<double> sum{};
  double weight_sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double w = window_weight(window, i, n);
    weight_sum += w;
    // e^{-j 2 pi bin i / N} from bin i mod N: the angle stays below 2 pi, as exact as one twiddle.
    const double angle = -2.0 * std::numbers::pi * static_cast<double>((bin * i) % n) / static_cast<double>(n);
    sum += w * std::complex<double>(x[i], y[i]) * std::complex<double>(std::cos(angle), std::sin(angle));
  }
  return sum / weight_sum * phase_to_time_zero(static_cast<double>(k) * resolution, t0);
}

}  // namespace rubref
