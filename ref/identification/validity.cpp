#include "ref/identification/validity.hpp"

#include <cmath>
#include <functional>

namespace rubref {

namespace {

using series = std::vector<std::vector<double>>;

double mean_of(const series& s) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const auto& ep : s)
    for (double v : ep) {
      sum += v;
      ++n;
    }
  return n ? sum / n : 0.0;
}

series transform(const series& s, const std::function<double(double)>& f) {
  series out = s;
  for (auto& ep : out)
    for (double& v : ep) v = f(v);
  return out;
}

// Normalised cross-correlation of a(t) and b(t + lag), pairs within an episode.
double correlation(const series& a, const series& b, int lag) {
  const double ma = mean_of(a), mb = mean_of(b);
  double saa = 0.0, sbb = 0.0, sab = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    for (double v : a[k]) saa += (v - ma) * (v - ma);
    for (double v : b[k]) sbb += (v - mb) * (v - mb);
    const long n = static_cast<long>(a[k].size());
    for (long i = 0; i < n; ++i) {
      const long j = i + lag;
      if (j >= 0 && j < n) sab += (a[k][i] - ma) * (b[k][j] - mb);
    }
  }
  return saa > 0.0 && sbb > 0.0 ? sab / std::sqrt(saa * sbb) : 0.0;
}

correlation_test run(std::string name, const series& a, const series& b, int lo, int hi, std::size_t n) {
  correlation_test t;
  t.name = std::move(name);
  t.band = 1.96 / std::sqrt(static_cast<double>(n));
  std::size_t outside = 0;
  for (int lag = lo; lag <= hi; ++lag) {
    const double v = correlation(a, b, lag);
    t.lags.push_back(lag);
    t.values.push_back(v);
    t.max_abs = std::max(t.max_abs, std::abs(v));
    if (std::abs(v) > t.band) ++outside;
  }
  t.outside_fraction = t.lags.empty() ? 0.0 : static_cast<double>(outside) / t.lags.size();
  constexpr double kAllowedOutside = 0.05;  // a 95 % band is crossed by chance at 5 % of lags
  t.pass = t.outside_fraction <= kAllowedOutside;
  return t;
}

}  // namespace

std::vector<correlation_test> residual_tests(const series& e, const series& z, const series& zd, int max_lag) {
  std::size_t n = 0;
  for (const auto& ep : e) n += ep.size();
  const auto centred_square = [](const series& s) {
    const series sq = transform(s, [](double v) { return v * v; });
    const double m = mean_of(sq);
    return transform(sq, [m](double v) { return v - m; });
  };
  const series e2 = transform(e, [](double v) { return v * v; });
  return {run("phi_ee", e, e, 1, max_lag, n),
          run("phi_z_e", z, e, -max_lag, max_lag, n),
          run("phi_zd_e", zd, e, -max_lag, max_lag, n),
          run("phi_z2_e", centred_square(z), e, -max_lag, max_lag, n),
          run("phi_zd2_e", centred_square(zd), e, -max_lag, max_lag, n),
          run("phi_z2_e2", centred_square(z), e2, -max_lag, max_lag, n),
          run("phi_zd2_e2", centred_square(zd), e2, -max_lag, max_lag, n)};
}

}  // namespace rubref
