#include "ref/identification/weak_form.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <utility>

#include "ref/base/errors.hpp"

namespace rubref {

namespace {

// Contact runs closer than this many samples are one episode: probe noise makes a light contact
// flicker across y = delta at onset and separation, and one support over the flicker keeps every
// contact sample interior.
constexpr std::size_t kMergeGap = 2;
// The support's margin is at least this many samples, so that the onset interval is interior.
constexpr double kMinMarginSamples = 3.0;

// A dwell's samples in the order they are integrated: a periodic cycle is rotated to start at its
// lowest y (farthest from the stator), so that no episode wraps around its end.
struct series {
  std::vector<double> t, x, y, z, zd, zd_gain;
};

series ordered(const dwell_forces& f) {
  const dwell& d = *f.source;
  const std::size_t n = d.size();
  std::size_t start = 0;
  if (d.periodic) start = static_cast<std::size_t>(std::min_element(d.y.begin(), d.y.end()) - d.y.begin());
  series s;
  const double period = static_cast<double>(n) * d.dt;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = (start + k) % n;
    s.t.push_back(d.t[i] + (start + k >= n ? period : 0.0));
    s.x.push_back(d.x[i]);
    s.y.push_back(d.y[i]);
    s.z.push_back(f.z[i]);
    s.zd.push_back(f.vy[i]);
    s.zd_gain.push_back(f.vy_gain[i]);
  }
  return s;
}

// psi_q and its first two derivatives in s: (1 - s^2)^P s^q as polynomial coefficients.
struct test_function {
  std::vector<double> c, c1, c2;  // coefficients of s^k for psi, dpsi/ds, d2psi/ds2
  test_function(int q, int P) {
    // (1 - s^2)^P by repeated multiplication.
    std::vector<double> bump{1.0};
    for (int r = 0; r < P; ++r) {
      std::vector<double> next(bump.size() + 2, 0.0);
      for (std::size_t k = 0; k < bump.size(); ++k) next[k] += bump[k], next[k + 2] -= bump[k];
      bump = next;
    }
    c.assign(bump.size() + q, 0.0);
    for (std::size_t k = 0; k < bump.size(); ++k) c[k + q] = bump[k];
    for (std::size_t k = 1; k < c.size(); ++k) c1.push_back(k * c[k]);
    for (std::size_t k = 1; k < c1.size(); ++k) c2.push_back(k * c1[k]);
  }
  static double horner(const std::vector<double>& p, double s) {
    double v = 0.0;
    for (auto it = p.rbegin(); it != p.rend(); ++it) v = v * s + *it;
    return v;
  }
};

// One episode's rows, whitened: Q test functions by the library's terms.
struct block {
  Eigen::MatrixXd A;
  Eigen::VectorXd b, bx;
  std::size_t dwell;
  double noise;
};

// Per sample of a dwell: its displacements less their mean and 1X (the rest r, through psi''),
// and Eq. 1's left side on the mean and 1X less the unbalance forcing (g, times psi).
struct split_at_one_x {
  std::vector<double> rx, ry, gx, gy;
};

// The dwell's mean and 1X, v1 = a0 + ac cos wt + as sin wt, are integrated exactly (Eq. 1
// applied to them analytically, no quadrature of psi''); only the rest, the contact's tens of
// micrometres rather than the orbit's hundreds, goes through psi''. This keeps the quadrature
// error of the large terms m v psi'' out of the rows.
split_at_one_x split_one_x(const series& s, double w, const linear_part& lin) {
  const std::size_t n = s.t.size();
  const double unbalance = lin.m * lin.e * w * w;
  std::vector<double> co(n), si(n);
  for (std::size_t i = 0; i < n; ++i) co[i] = std::cos(w * s.t[i]), si[i] = std::sin(w * s.t[i]);
  const auto one_x = [&](const std::vector<double>& v) {
    Eigen::MatrixXd B(static_cast<Eigen::Index>(n), 3);
    Eigen::VectorXd r(static_cast<Eigen::Index>(n));
    for (std::size_t i = 0; i < n; ++i) {
      B.row(static_cast<Eigen::Index>(i)) << 1.0, co[i], si[i];
      r[static_cast<Eigen::Index>(i)] = v[i];
    }
    return Eigen::Vector3d(B.colPivHouseholderQr().solve(r));
  };
  const Eigen::Vector3d cx = one_x(s.x), cy = one_x(s.y);
  // Per sample, for every test function alike: the rest r = v - v1 (through psi'') and Eq. 1's
  // left side on v1, k a0 + (k - m w^2)(ac cos + as sin) + c w (as cos - ac sin), minus the
  // unbalance forcing m e w^2 (cos, sin)(w t + phase) (times psi).
  split_at_one_x out{std::vector<double>(n), std::vector<double>(n), std::vector<double>(n), std::vector<double>(n)};
  const double cp = std::cos(lin.phase), sp = std::sin(lin.phase);
  for (std::size_t i = 0; i < n; ++i) {
    const auto eq1_on_1x = [&](const Eigen::Vector3d& c, double cc, double kk) {
      return kk * c[0] + (kk - lin.m * w * w) * (c[1] * co[i] + c[2] * si[i]) + cc * w * (c[2] * co[i] - c[1] * si[i]);
    };
    out.rx[i] = s.x[i] - (cx[0] + cx[1] * co[i] + cx[2] * si[i]);
    out.ry[i] = s.y[i] - (cy[0] + cy[1] * co[i] + cy[2] * si[i]);
    out.gx[i] = eq1_on_1x(cx, lin.c_x, lin.k_x) - unbalance * (co[i] * cp - si[i] * sp);
    out.gy[i] = eq1_on_1x(cy, lin.c_y, lin.k_y) - unbalance * (si[i] * cp + co[i] * sp);
  }
  return out;
}

// Contact runs [first, last], merged across short gaps.
std::vector<std::pair<std::size_t, std::size_t>> contact_runs(const std::vector<double>& z) {
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  for (std::size_t i = 0; i < z.size(); ++i) {
    if (!(z[i] > 0.0)) continue;
    if (!runs.empty() && i - runs.back().second <= kMergeGap + 1) {
      runs.back().second = i;
    } else {
      runs.push_back({i, i});
    }
  }
  return runs;
}

// The support [a, b] of run r, when the run can have one: the onset lies in (first - 1, first)
// and the separation in (last, last + 1), so both neighbours must be samples, and every contact
// sample needs its velocity.
std::optional<std::pair<double, double>> episode_support(const series& s, const std::vector<std::pair<std::size_t, std::size_t>>& runs,
                                                         std::size_t r, double dt, const weak_form_settings& set) {
  const std::size_t n = s.t.size();
  const auto [first, last] = runs[r];
  if (first == 0 || last + 1 >= n) return std::nullopt;
  for (std::size_t i = first; i <= last; ++i)
    if (s.z[i] > 0.0 && !std::isfinite(s.zd[i])) return std::nullopt;
  const double duration = static_cast<double>(last - first + 1) * dt;
  const double margin = std::max(kMinMarginSamples * dt, set.margin * duration);
  double a = s.t[first - 1] - margin, b = s.t[last + 1] + margin;
  a = std::max(a, s.t.front());
  b = std::min(b, s.t.back());
  if (r > 0) a = std::max(a, 0.5 * (s.t[runs[r - 1].second] + s.t[first]));
  if (r + 1 < runs.size()) b = std::min(b, 0.5 * (s.t[last] + s.t[runs[r + 1].first]));
  if (!(a < s.t[first - 1] && b > s.t[last + 1])) return std::nullopt;
  return std::pair{a, b};
}

// One episode's rows on its support [a, b] (samples idx), whitened; none if the rows' noise
// covariance is singular.
std::optional<block> episode_rows(const series& s, const split_at_one_x& parts, std::pair<std::size_t, std::size_t> run, std::pair<double, double> support,
                                  const std::vector<std::size_t>& idx, const std::vector<test_function>& psi, double dt, const linear_part& lin,
                                  const std::vector<candidate_term>& library, std::size_t dwell, double noise) {
  const auto [first, last] = run;
  const int Q = static_cast<int>(psi.size());
  const Eigen::Index terms = static_cast<Eigen::Index>(library.size());
  const double half = 0.5 * (support.second - support.first), mid = 0.5 * (support.first + support.second);
  const auto s_of = [&](double t) { return (t - mid) / half; };
  block bl{Eigen::MatrixXd::Zero(Q, terms), Eigen::VectorXd::Zero(Q), Eigen::VectorXd::Zero(Q), dwell, noise};
  Eigen::MatrixXd Ly(Q, static_cast<Eigen::Index>(idx.size()));
  for (int q = 0; q < Q; ++q) {
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const std::size_t i = idx[k];
      const double sv = s_of(s.t[i]);
      const double p0 = test_function::horner(psi[q].c, sv);
      const double p1 = test_function::horner(psi[q].c1, sv) / half;
      const double p2 = test_function::horner(psi[q].c2, sv) / (half * half);
      // Eq. 1 integrated by parts twice (trapezoid rule; psi, psi', psi'' vanish at a, b).
      Ly(q, static_cast<Eigen::Index>(k)) = -dt * (lin.m * p2 - lin.c_y * p1 + lin.k_y * p0);
      bl.b[q] += Ly(q, static_cast<Eigen::Index>(k)) * parts.ry[i] - dt * parts.gy[i] * p0;
      bl.bx[q] += dt * (lin.m * p2 - lin.c_x * p1 + lin.k_x * p0) * parts.rx[i] + dt * parts.gx[i] * p0;
    }
    // Regressors: the law on the contact part of every sample interval, the onset and
    // separation located by linear interpolation of z (trapezoid rule on each part).
    const auto integrand = [&](std::size_t j, double t, double z, double zd, double gain) {
      const double var = noise * gain * noise * gain;
      return library[j].unbiased(z, zd, var) * test_function::horner(psi[q].c, s_of(t));
    };
    for (std::size_t i = first - 1; i <= last; ++i) {
      const bool c0 = s.z[i] > 0.0, c1 = s.z[i + 1] > 0.0;
      if (!c0 && !c1) continue;
      for (Eigen::Index j = 0; j < terms; ++j) {
        const auto at = [&](std::size_t k) { return integrand(static_cast<std::size_t>(j), s.t[k], s.z[k], s.zd[k], s.zd_gain[k]); };
        double v = 0.0;
        if (c0 && c1) {
          v = 0.5 * dt * (at(i) + at(i + 1));
        } else {
          const double tau = s.z[i] / (s.z[i] - s.z[i + 1]);  // z = 0 at t_i + tau dt
          const std::size_t in = c0 ? i : i + 1;
          const auto lerp = [&](const std::vector<double>& v) {
            const double v0 = std::isfinite(v[i]) ? v[i] : v[i + 1], v1 = std::isfinite(v[i + 1]) ? v[i + 1] : v[i];
            return v0 + tau * (v1 - v0);
          };
          const double g = integrand(static_cast<std::size_t>(j), s.t[i] + tau * dt, 0.0, lerp(s.zd), lerp(s.zd_gain));
          v = 0.5 * dt * (c0 ? tau : 1.0 - tau) * (at(in) + g);
        }
        bl.A(q, j) += v;
      }
    }
  }
  // Whitening: the rows' noise covariance per unit sample noise is Ly Ly'.
  const Eigen::LLT<Eigen::MatrixXd> llt(Ly * Ly.transpose());
  if (llt.info() != Eigen::Success) return std::nullopt;
  bl.A = llt.matrixL().solve(bl.A);
  bl.b = llt.matrixL().solve(bl.b);
  bl.bx = llt.matrixL().solve(bl.bx);
  return bl;
}

// Every episode's rows of one dwell.
std::vector<block> dwell_rows(const weak_form_input& input, std::size_t dwell, const std::vector<test_function>& psi, const linear_part& lin,
                              const std::vector<candidate_term>& library, const weak_form_settings& set) {
  const dwell_forces& f = *input.forces;
  const series s = ordered(f);
  const std::size_t n = s.t.size();
  const double dt = f.source->dt;
  const split_at_one_x parts = split_one_x(s, f.source->omega(), lin);
  const auto runs = contact_runs(s.z);
  std::vector<block> blocks;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const auto support = episode_support(s, runs, r, dt, set);
    if (!support) continue;
    std::vector<std::size_t> idx;
    for (std::size_t i = 0; i < n; ++i)
      if (s.t[i] > support->first && s.t[i] < support->second) idx.push_back(i);
    if (idx.size() < 2 * psi.size()) continue;
    if (auto bl = episode_rows(s, parts, runs[r], *support, idx, psi, dt, lin, library, dwell, input.noise)) blocks.push_back(std::move(*bl));
  }
  return blocks;
}

// The episodes' rows stacked, every dwell's scaled to a common noise level: the RMS of the
// dwells' sample noise.
weak_form_system stacked(const std::vector<block>& blocks, int Q, Eigen::Index terms) {
  weak_form_system out;
  double sq = 0.0;
  for (const auto& bl : blocks) sq += bl.noise * bl.noise;
  out.noise = std::sqrt(sq / static_cast<double>(blocks.size()));
  const Eigen::Index rows = static_cast<Eigen::Index>(blocks.size()) * Q;
  out.A.resize(rows, terms);
  out.b.resize(rows);
  out.bx.resize(rows);
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    const auto& bl = blocks[k];
    const double scale = bl.noise > 0.0 && out.noise > 0.0 ? out.noise / bl.noise : 1.0;
    const Eigen::Index r0 = static_cast<Eigen::Index>(k) * Q;
    out.A.middleRows(r0, Q) = scale * bl.A;
    out.b.segment(r0, Q) = scale * bl.b;
    out.bx.segment(r0, Q) = scale * bl.bx;
    for (int q = 0; q < Q; ++q) out.dwell_of_row.push_back(bl.dwell);
  }
  out.episodes = blocks.size();
  return out;
}

}  // namespace

weak_form_system weak_form(const std::vector<weak_form_input>& inputs, const linear_part& lin,
                           const std::vector<candidate_term>& library, const weak_form_settings& set) {
  set.validate();
  const int Q = set.test_functions;
  std::vector<test_function> psi;
  for (int q = 0; q < Q; ++q) psi.emplace_back(q, set.bump_power);
  std::vector<block> blocks;
  for (std::size_t di = 0; di < inputs.size(); ++di)
    for (auto& bl : dwell_rows(inputs[di], di, psi, lin, library, set)) blocks.push_back(std::move(bl));
  if (blocks.empty())
    throw input_error("weak form: no contact episode lies inside its dwell with room for its test functions (records too short?)");
  return stacked(blocks, Q, static_cast<Eigen::Index>(library.size()));
}

void weak_form_settings::validate() const {
  check({"weak_form", "test_functions"}, test_functions);
  check({"weak_form", "bump_power"}, bump_power);
  check({"weak_form", "velocity_half_width"}, velocity_half_width);
  check({"weak_form", "margin"}, margin);
}

}  // namespace rubref
