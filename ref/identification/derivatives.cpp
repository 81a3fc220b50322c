#include "ref/identification/derivatives.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

#include "ref/base/errors.hpp"

namespace rubref {

namespace {

// Weights w1, w2 with v'(0) ~ sum w1_k v_k / dt and v''(0) ~ sum w2_k v_k / dt^2 for samples at
// offsets k = first .. first + n - 1 (in steps), from a least-squares polynomial of `degree`.
struct weights {
  Eigen::VectorXd d1, d2;
};

weights make_weights(int first, int n, int degree) {
  Eigen::MatrixXd V(n, degree + 1);
  for (int i = 0; i < n; ++i) {
    const double k = first + i;
    double p = 1.0;
    for (int j = 0; j <= degree; ++j, p *= k) V(i, j) = p;
  }
  // Coefficients c = pinv(V) v; row 1 gives c1 = v'(0), row 2 gives c2 = v''(0) / 2.
  const Eigen::MatrixXd pinv = V.completeOrthogonalDecomposition().pseudoInverse();
  return {pinv.row(1).transpose(), 2.0 * pinv.row(2).transpose()};
}

}  // namespace

derivatives differentiate(std::span<const double> v, double dt, const derivative_settings& s, std::span<const int> segment) {
  if (s.half_width < 1) throw input_error("derivative half-width must be >= 1");
  if (s.degree < 2 || s.degree > 2 * s.half_width) throw input_error("derivative degree must be in [2, 2 * half-width]");
  if (!segment.empty() && segment.size() != v.size()) throw input_error("segment labels and samples differ in length");
  const std::size_t n = v.size();
  derivatives out{std::vector<double>(n, std::numeric_limits<double>::quiet_NaN()),
                  std::vector<double>(n, std::numeric_limits<double>::quiet_NaN()),
                  std::vector<double>(n, std::numeric_limits<double>::quiet_NaN())};
  const auto label = [&](std::size_t i) { return segment.empty() ? 0 : segment[i]; };
  std::map<std::tuple<int, int, int>, weights> cache;  // (first offset, length, degree)
  const int window = 2 * s.half_width + 1;

  for (std::size_t lo = 0; lo < n;) {
    std::size_t hi = lo;  // the segment is [lo, hi]
    while (hi + 1 < n && label(hi + 1) == label(lo)) ++hi;
    const int len = static_cast<int>(hi - lo + 1);
    if (len >= 3) {
      const int w = std::min(window, len);
      const int degree = std::min(s.degree, w - 1);
      for (std::size_t i = lo; i <= hi; ++i) {
        // Window [start, start + w - 1], centred on i where the segment allows.
        const long start = std::clamp(static_cast<long>(i) - s.half_width, static_cast<long>(lo), static_cast<long>(hi) - w + 1);
        const int first = static_cast<int>(start - static_cast<long>(i));
        auto it = cache.find({first, w, degree});
        if (it == cache.end()) it = cache.emplace(std::tuple{first, w, degree}, make_weights(first, w, degree)).first;
        double a = 0.0, b = 0.0;
        for (int k = 0; k < w; ++k) {
          a += it->second.d1[k] * v[start + k];
          b += it->second.d2[k] * v[start + k];
        }
        out.d1[i] = a / dt;
        out.d2[i] = b / (dt * dt);
        out.d1_gain[i] = it->second.d1.norm() / dt;
      }
    }
    lo = hi + 1;
  }
  return out;
}

void derivative_settings::validate() const {
  check({"derivatives", "half_width"}, half_width);
  check({"derivatives", "degree"}, degree);
}

}  // namespace rubref
