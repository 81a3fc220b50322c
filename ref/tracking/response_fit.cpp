#include "ref/tracking/response_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>

#include <Eigen/Dense>
#include <boost/math/distributions/chi_squared.hpp>

#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"
#include "ref/base/parallel.hpp"
#include "ref/inference/evidence.hpp"
#include "ref/inference/least_squares.hpp"
#include "ref/tracking/swept_response.hpp"

namespace rubref {

namespace {

using cplx = std::complex<double>;
constexpr double kPi = std::numbers::pi;
constexpr double kRpmToRadS = 2.0 * kPi / 60.0;
// The 95 % two-sided normal quantile: intervals are value +- 1.96 standard deviations in the
// fit's chart (logarithms for critical speeds and damping ratios, so those intervals are ratios).
constexpr double kZ95 = 1.959963984540054;
// Damping ratios between nearly undamped and far past critical. Critical speeds inside the
// table's speeds: a mode outside them bends the response inside only as a smooth background,
// which runout, unbalance and the other mode mimic (on the RK-4 run-up a "mode" at a fifth of the
// lowest speed took 58 µm of unbalance against 55 µm of runout); a mode the fit pushes to an edge
// is reported as not determined.
constexpr double kZetaLo = 1e-4, kZetaHi = 2.0;
// Cross-coupling k_xy/m and k_yx/m in units of w_x w_y (the supports' stiffness per unit mass),
// within the effect library's fit range in those units (+-20000 N/m against the paper's
// sqrt(k_x k_y) = 39.8 kN/m); a fit that reaches the bound is reported as not determined.
constexpr double kCrossBound = 0.5;
// The starts, ranked by their projected residual; the best few start a fit by the solver
// each. A critical speed is scanned over the table's speeds in steps of 1 % (a lightly damped
// mode's peak is 2 zeta wide: 1.2 % at zeta = 0.006, where a coarser grid missed it in the
// campaign) at three damping ratios; an anisotropic fit from an isotropic one keeps that mode and
// scans the other; without a start, both modes on a coarse grid. Four probe angles when fitted.
constexpr double kScanStep = 0.01;
constexpr double kScanZetas[] = {0.005, 0.02, 0.1};
constexpr int kGridSpeeds = 12;
constexpr int kGridAngles = 4;
constexpr std::size_t kGridStarts = 4;
// And the isotropic fit's mode split symmetrically (ratios of the two): two critical speeds a few
// per cent apart, between which the isotropic fit sits.
constexpr double kSplits[] = {1.02, 1.05, 1.1, 1.2};
// A sweep's rate alpha = exp(u) w_lo^2 (w_lo the table's lowest speed): from far slower than any
// table could tell from steady (eta = alpha / w^2 = 1e-12: the ringing is e^{-zeta^2 / eta} small)
// to the fastest at which a block of N revolutions keeps its speed positive (alpha < w_lo^2 /
// (pi N)), halved. The sweep's starts: eta / zeta^2 of the lightest damped mode over the range
// where a sweep moves a table's response (from 0.01, a per cent near the peak, to 100, a passage
// far too fast to build the peak), 15 % apart: the beats above the critical speed fall at
// (Omega - w)^2 = 4 pi alpha k, so a rate 15 % off puts the first few beats within a quarter
// period of where they are, inside the solver's basin.
constexpr double kSweepSlowest = 1e-12;
constexpr double kSweepStartLo = 0.01, kSweepStartHi = 100.0, kSweepStartStep = 1.15;
// A fast sweep's ringing shows in a few rows above the critical speed, and from one row to the
// next its phase against the 1X, (Omega - w)^2 / (2 alpha), turns several times over: the swept
// chi^2 is aliased in rate and critical speed together, and the starts above (ranked at the
// steady fit's modes) can all miss the truth's basin (campaign seed 2718: #453, #490, #526 stopped
// short of their noise, each named in full with the truth's rate declared). Nor is the steady
// fit's damping a guide there: the ringing drags it anywhere (to its lower bound on a table like
// #490's). Where the fit from those starts leaves more than the noise (found rate or not),
// chi^2 itself is scanned: eta = alpha / w^2 of the lightest damped mode from kRescueEtaLo (a
// passage with eta / zeta^2 = 1 at zeta = 0.001) to the fastest rate the block allows, in steps of
// 5 %; at each, the damping that puts the passage at eta / zeta^2 = 2, 8 and 32 (the ringing
// visible for a few rows to a few tens); the critical speed moved back from the steady fit's by
// -1 to 2 times the fast passage's lag sqrt(2 pi alpha), in steps of a tenth of it. The best
// kRescueStarts points at least kRescueApart steps from each other in rate or speed are fitted by
// the solver. (On a table like #490's, tests/swept_response_test.cpp, a grid twice as coarse in
// both still finds the basin: the steps keep that margin.) So the grid is evaluated coarse to fine:
// every kRescueCoarse-th rate and lag first, then every point around the kRescueRefined best of
// those (four for each start picked), where the picks come from: a third of the evaluations of the
// whole grid, which was nearly all of a swept fit's time where it ran.
constexpr double kRescueEtaLo = 1e-6, kRescueRateStep = 1.05;
constexpr double kRescueRegimes[] = {2.0, 8.0, 32.0};
constexpr double kRescueLagLo = -1.0, kRescueLagHi = 2.0, kRescueLagStep = 0.1;
constexpr std::size_t kRescueStarts = 8;
constexpr int kRescueApart = 3;
constexpr std::size_t kRescueCoarse = 2, kRescueRefined = 4 * kRescueStarts;

// The standard deviation of Gaussian values from their absolute values, robust to a minority of
// outliers: 1.4826 times the median, then three times again over the values within 3 of those
// standard deviations (a median counts every outlier as a value above it; clipped, the few that
// are left move it little), the median of the clipped half-normal being 0.6727 rather than 0.6745.
double clipped_scale(std::vector<double> a) {
  if (a.empty()) return 0.0;
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  double s = 1.4826 * median(a);
  for (int it = 0; it < 3 && s > 0.0; ++it) {
    std::vector<double> kept;
    for (const double x : a)
      if (x <= 3.0 * s) kept.push_back(x);
    if (kept.empty()) break;
    s = median(kept) / 0.6727;
  }
  return s;
}

// Robust scatter of a sequence of complex vectors in speed order: second differences remove a
// response that is smooth on the rows' spacing; the clipped scale of both parts over sqrt(6) (a
// second difference of white noise has 6 times its variance). (Fourth differences, which the
// waveform estimate uses, came out low in the campaign's tables: scenarios without an effect
// were called unexplained.)
double row_scatter(const std::vector<cplx>& v) {
  std::vector<double> d;
  for (std::size_t i = 1; i + 1 < v.size(); ++i) {
    const cplx s = v[i + 1] - 2.0 * v[i] + v[i - 1];
    d.push_back(std::abs(s.real())), d.push_back(std::abs(s.imag()));
  }
  return clipped_scale(std::move(d)) / std::sqrt(6.0);
}

// The fit's coordinates (response_slots). A fit moves the ones its parts free: an isotropic rotor
// ties y's to x's; beta moves only for an anisotropic rotor read by one probe without a declared
// angle (an isotropic rotor reads the same at every angle, up to the unbalance's phase); the
// cross-coupling only when it is a part.
using namespace response_slots;

// What the model's reading needs of the coordinates (the full slots) and one probe's angle,
// formed once per probe and evaluation, not per row.
struct probe_point {
  double wx, wy, zx, zy, kxy, kyx, cos_b, sin_b;
};
probe_point point_of(const std::vector<double>& f, double beta) {
  const double wx = std::exp(f[ln_wx]), wy = std::exp(f[ln_wy]);
  return {wx, wy, std::exp(f[ln_zx]), std::exp(f[ln_zy]), f[k_xy] * wx * wy, f[k_yx] * wx * wy, std::cos(beta), std::sin(beta)};
}

// The probe's reading at frequency w of the response to a force per unit mass (fx, fy) (the
// equation in response_fit.hpp, solved by Cramer's rule).
cplx probe_reading(const probe_point& c, double w, cplx fx, cplx fy) {
  const cplx dxx(c.wx * c.wx - w * w, 2.0 * c.zx * c.wx * w), dyy(c.wy * c.wy - w * w, 2.0 * c.zy * c.wy * w);
  const cplx det = dxx * dyy - c.kxy * c.kyx;
  const cplx x = (dyy * fx - c.kxy * fy) / det, y = (dxx * fy - c.kyx * fx) / det;
  return c.cos_b * x + c.sin_b * y;
}

// The probe's 1X reading at speed w per unit unbalance e e^{j phi} and per unit bow B: a forward
// force w^2 (1, -j), and the springs' push towards the bow (w_x^2, -j w_y^2).
std::pair<cplx, cplx> reading(const probe_point& c, double w) {
  const cplx j(0.0, 1.0);
  return {w * w * probe_reading(c, w, 1.0, -j), probe_reading(c, w, c.wx * c.wx, -j * c.wy * c.wy)};
}

struct problem {
  const order_table& table;
  response_parts parts;
  std::vector<std::size_t> orders;  // the table's 1X tracked orders, one per probe
  std::vector<std::size_t> rows;
  std::vector<double> sigma;        // per probe
  std::vector<std::optional<double>> beta;  // declared angle per probe
  bool beta_fitted = false;
  std::vector<std::size_t> free;    // the slot of each coordinate
  double w_lo = 1.0, w_hi = 1.0;  // rad/s
  int evaluations = 0;
  // sweep only: every swept row's speed (rad/s; the sweep runs through all of them, fitted or
  // not: every row outside the table's dwell, whose rows are steady), each table row's index
  // among them (-1: in the dwell), the sweep's reference speed (the lowest swept), direction and
  // block.
  std::vector<double> speeds = {};
  std::vector<std::ptrdiff_t> swept_row = {};
  double sweep_ref = 1.0, revolutions = 1.0, rate_start = 0.0;
  double held_rate = 0.0;  // |alpha| held (rad/s^2; 0: the rate is a coordinate)
  int direction = 1;

  void lay_out() {
    free = parts.anisotropy ? std::vector<std::size_t>{ln_wx, ln_wy, ln_zx, ln_zy} : std::vector<std::size_t>{ln_wx, ln_zx};
    if (beta_fitted) free.push_back(probe_beta);
    if (parts.cross_coupling) free.push_back(k_xy), free.push_back(k_yx);
    if (parts.sweep && !(held_rate > 0.0)) free.push_back(ln_sweep);
  }
  double sweep_fastest() const { return std::log(0.5 / (kPi * revolutions)); }
  double held_ln_sweep() const { return std::log(held_rate / (sweep_ref * sweep_ref)); }
  std::vector<double> full(const std::vector<double>& q) const {
    std::vector<double> f(kSlots, 0.0);
    for (std::size_t k = 0; k < free.size(); ++k) f[free[k]] = q[k];
    if (!parts.anisotropy) f[ln_wy] = f[ln_wx], f[ln_zy] = f[ln_zx];
    if (parts.sweep && held_rate > 0.0) f[ln_sweep] = held_ln_sweep();
    return f;
  }
  std::vector<double> reduce(const std::vector<double>& f) const {
    std::vector<double> q(free.size());
    for (std::size_t k = 0; k < free.size(); ++k) q[k] = f[free[k]];
    return q;
  }
  std::size_t amplitudes() const { return 1 + orders.size() + (parts.shaft_bow ? 1 : 0); }

  probe_point point(const std::vector<double>& f, std::size_t p) const { return point_of(f, beta[p] ? *beta[p] : f[probe_beta]); }

  // The basis columns of probe p at one speed: unbalance, runout of each probe, bow.
  void columns(const probe_point& c, std::size_t p, double w, cplx* out) const {
    const auto [unbalance, bow] = reading(c, w);
    out[0] = unbalance;
    for (std::size_t q = 0; q < orders.size(); ++q) out[1 + q] = q == p ? 1.0 : 0.0;
    if (parts.shaft_bow) out[1 + orders.size()] = bow;
  }

  // Weighted residuals (real, imaginary per probe and row) at coordinates q; the amplitudes
  // solved for (fixed = nullptr) or given.
  Eigen::VectorXd residuals(const std::vector<double>& q, std::vector<cplx>& amp, const std::vector<cplx>* fixed = nullptr) {
    ++evaluations;
    const std::vector<double> f = full(q);
    if (parts.sweep) return swept_residuals(f, amp, fixed);
    const std::size_t m = rows.size() * orders.size(), l = amplitudes();
    Eigen::MatrixXcd a(m, l);
    Eigen::VectorXcd data(m);
    std::vector<cplx> col(l);
    for (std::size_t p = 0; p < orders.size(); ++p) {
      const probe_point at = point(f, p);
      for (std::size_t i = 0; i < rows.size(); ++i) {
        const std::size_t row = p * rows.size() + i;
        columns(at, p, table.rpm[rows[i]] * kRpmToRadS, col.data());
        for (std::size_t c = 0; c < l; ++c) a(row, c) = col[c] / sigma[p];
        data(row) = table.orders[orders[p]].vector[rows[i]] / sigma[p];
      }
    }
    Eigen::VectorXcd x(l);
    if (fixed) {
      for (std::size_t c = 0; c < l; ++c) x(c) = (*fixed)[c];
    } else {
      x = a.colPivHouseholderQr().solve(data);
      amp.assign(x.data(), x.data() + l);
    }
    const Eigen::VectorXcd r = data - a * x;
    Eigen::VectorXd out(2 * m);
    for (std::size_t i = 0; i < m; ++i) out(2 * i) = r(i).real(), out(2 * i + 1) = r(i).imag();
    return out;
  }

  // The sweep's columns: per probe and row (every row of the table), the 1X per unit Re and Im of
  // the unbalance and of the bow (swept_response.hpp; not complex-linear once the sweep rings).
  // Empty where the rotor's modes cannot be had (a failed evaluation for the solver).
  swept_table_columns swept_columns(const std::vector<double>& f) const {
    const double wx = std::exp(f[ln_wx]), wy = std::exp(f[ln_wy]);
    const linear_rotor rotor{wx, wy, std::exp(f[ln_zx]), std::exp(f[ln_zy]), f[k_xy] * wx * wy, f[k_yx] * wx * wy};
    std::vector<double> angles;
    for (std::size_t p = 0; p < orders.size(); ++p) angles.push_back(beta[p] ? *beta[p] : f[probe_beta]);
    try {
      return swept_1x(rotor, speeds, direction * std::exp(f[ln_sweep]) * sweep_ref * sweep_ref, revolutions, angles, parts.shaft_bow);
    } catch (const numerical_error&) {
      return {};
    }
  }
  // The real-linear columns (Re, Im) of every amplitude for probe p at table row `row`: the
  // sweep's, or in the dwell the steady ones (complex-linear: Im's column is j times Re's).
  void swept_columns_at(const swept_table_columns& cols, const std::vector<double>& f, std::size_t p, std::size_t row, std::pair<cplx, cplx>* out) const {
    const std::size_t l = amplitudes();
    if (swept_row[row] < 0) {
      std::vector<cplx> col(l);
      columns(point(f, p), p, table.rpm[row] * kRpmToRadS, col.data());
      for (std::size_t c = 0; c < l; ++c) out[c] = {col[c], cplx(0.0, 1.0) * col[c]};
      return;
    }
    const auto& at = cols.columns[p][static_cast<std::size_t>(swept_row[row])];
    out[0] = {at[0], at[1]};
    for (std::size_t q = 0; q < orders.size(); ++q) out[1 + q] = q == p ? std::pair<cplx, cplx>{1.0, cplx(0.0, 1.0)} : std::pair<cplx, cplx>{0.0, 0.0};
    if (parts.shaft_bow) out[l - 1] = {at[2], at[3]};
  }
  Eigen::VectorXd swept_residuals(const std::vector<double>& f, std::vector<cplx>& amp, const std::vector<cplx>* fixed) const {
    const std::size_t m = rows.size() * orders.size(), l = amplitudes();
    const swept_table_columns cols = swept_columns(f);
    if (cols.columns.empty()) return Eigen::VectorXd::Constant(static_cast<Eigen::Index>(2 * m), std::numeric_limits<double>::quiet_NaN());
    Eigen::MatrixXd a(2 * m, 2 * l);
    Eigen::VectorXd data(2 * m);
    std::vector<std::pair<cplx, cplx>> at(l);
    for (std::size_t p = 0; p < orders.size(); ++p)
      for (std::size_t i = 0; i < rows.size(); ++i) {
        const Eigen::Index r = static_cast<Eigen::Index>(2 * (p * rows.size() + i));
        swept_columns_at(cols, f, p, rows[i], at.data());
        for (std::size_t c = 0; c < l; ++c) {
          const auto [re, im] = at[c];
          a(r, static_cast<Eigen::Index>(2 * c)) = re.real() / sigma[p], a(r + 1, static_cast<Eigen::Index>(2 * c)) = re.imag() / sigma[p];
          a(r, static_cast<Eigen::Index>(2 * c + 1)) = im.real() / sigma[p], a(r + 1, static_cast<Eigen::Index>(2 * c + 1)) = im.imag() / sigma[p];
        }
        const cplx d = table.orders[orders[p]].vector[rows[i]] / sigma[p];
        data(r) = d.real(), data(r + 1) = d.imag();
      }
    Eigen::VectorXd x(2 * l);
    if (fixed) {
      for (std::size_t c = 0; c < l; ++c) x(static_cast<Eigen::Index>(2 * c)) = (*fixed)[c].real(), x(static_cast<Eigen::Index>(2 * c + 1)) = (*fixed)[c].imag();
    } else {
      x = a.colPivHouseholderQr().solve(data);
      amp.resize(l);
      for (std::size_t c = 0; c < l; ++c) amp[c] = cplx(x(static_cast<Eigen::Index>(2 * c)), x(static_cast<Eigen::Index>(2 * c + 1)));
    }
    return data - a * x;
  }

  // The model's 1X at every row of the table and the size of each of its parts there (for the
  // report's model, residual and cancellation): per probe and row.
  std::vector<std::vector<std::vector<cplx>>> parts_at_rows(const std::vector<double>& f, const std::vector<cplx>& amp) const {
    const std::size_t l = amplitudes();
    std::vector<std::vector<std::vector<cplx>>> out(orders.size(), std::vector<std::vector<cplx>>(table.rows(), std::vector<cplx>(l)));
    const swept_table_columns cols = parts.sweep ? swept_columns(f) : swept_table_columns{};
    if (parts.sweep && cols.columns.empty()) throw numerical_error(table.source + ": the swept response's modes cannot be computed at the fit");
    std::vector<cplx> col(l);
    std::vector<std::pair<cplx, cplx>> swept(l);
    for (std::size_t p = 0; p < orders.size(); ++p) {
      const probe_point at = point(f, p);
      for (std::size_t i = 0; i < table.rows(); ++i) {
        if (!parts.sweep) columns(at, p, table.rpm[i] * kRpmToRadS, col.data());
        else swept_columns_at(cols, f, p, i, swept.data());
        for (std::size_t c = 0; c < l; ++c) {
          if (!parts.sweep) {
            out[p][i][c] = amp[c] * col[c];
            continue;
          }
          const auto [re, im] = swept[c];
          out[p][i][c] = amp[c].real() * re + amp[c].imag() * im;
        }
      }
    }
    return out;
  }

  double cost(const std::vector<double>& q) {
    std::vector<cplx> amp;
    const Eigen::VectorXd r = residuals(q, amp);
    const double c = r.squaredNorm();
    return std::isfinite(c) ? c : std::numeric_limits<double>::infinity();
  }

  // chi^2 of a swept fit at q, not counted in `evaluations` (the rescue scan's threads share the
  // problem; they count theirs together).
  double swept_cost(const std::vector<double>& q) const {
    std::vector<cplx> amp;
    const double c = swept_residuals(full(q), amp, nullptr).squaredNorm();
    return std::isfinite(c) ? c : std::numeric_limits<double>::infinity();
  }

  std::vector<double> clamp(const std::vector<double>& q) const {
    std::vector<double> f = full(q);
    for (const std::size_t k : {ln_wx, ln_wy}) f[k] = std::clamp(f[k], std::log(w_lo), std::log(w_hi));
    for (const std::size_t k : {ln_zx, ln_zy}) f[k] = std::clamp(f[k], std::log(kZetaLo), std::log(kZetaHi));
    for (const std::size_t k : {k_xy, k_yx}) f[k] = std::clamp(f[k], -kCrossBound, kCrossBound);
    f[ln_sweep] = std::clamp(f[ln_sweep], std::log(kSweepSlowest), sweep_fastest());
    return reduce(f);
  }
};

// The problem for the one solver (ref/inference/least_squares.hpp): the projected residuals
// (variable projection: the amplitudes solved for at every point, so also at each of the forward
// differences' points), inside the coordinates' bounds; the amplitudes `fixed` where given.
least_squares_problem solver_problem(problem& pr, const std::vector<cplx>* fixed = nullptr) {
  least_squares_problem lsq;
  lsq.residuals = [&pr, fixed](const Eigen::VectorXd& u) -> std::optional<Eigen::VectorXd> {
    std::vector<cplx> amp;
    return pr.residuals(std::vector<double>(u.data(), u.data() + u.size()), amp, fixed);
  };
  std::vector<double> lo(kSlots, -std::numeric_limits<double>::infinity()), hi(kSlots, std::numeric_limits<double>::infinity());
  for (const std::size_t k : {ln_wx, ln_wy}) lo[k] = std::log(pr.w_lo), hi[k] = std::log(pr.w_hi);
  for (const std::size_t k : {ln_zx, ln_zy}) lo[k] = std::log(kZetaLo), hi[k] = std::log(kZetaHi);
  for (const std::size_t k : {k_xy, k_yx}) lo[k] = -kCrossBound, hi[k] = kCrossBound;
  lo[ln_sweep] = std::log(kSweepSlowest), hi[ln_sweep] = pr.sweep_fastest();
  const std::vector<double> l = pr.reduce(lo), h = pr.reduce(hi);
  lsq.lower = Eigen::Map<const Eigen::VectorXd>(l.data(), static_cast<Eigen::Index>(l.size()));
  lsq.upper = Eigen::Map<const Eigen::VectorXd>(h.data(), static_cast<Eigen::Index>(h.size()));
  return lsq;
}

least_squares_options solver_options() {
  least_squares_options o;
  o.max_jacobians = default_count_of("response_fit", "max_jacobians");
  o.difference_step = default_of("response_fit", "difference_step");
  return o;
}

// The fit from q0 (the solver's end, in q's layout) and how much lower its minimum may lie (chi^2).
std::pair<std::vector<double>, double> fit_from(problem& pr, const std::vector<double>& q0) {
  const least_squares_result f = solve_least_squares(solver_problem(pr), Eigen::Map<const Eigen::VectorXd>(q0.data(), static_cast<Eigen::Index>(q0.size())), solver_options());
  return {std::vector<double>(f.u.data(), f.u.data() + f.u.size()), f.remaining};
}

// |c| and arg c (degrees) of a complex amplitude with its covariance (re, im).
std::pair<estimate, estimate> polar_estimate(cplx c, const Eigen::Matrix2d& cov) {
  const double a = std::abs(c);
  const Eigen::Vector2d ga(c.real() / a, c.imag() / a), gp(-c.imag() / (a * a), c.real() / (a * a));
  // A direction the table does not constrain (an infinite variance) or an amplitude of exactly 0
  // (its phase undefined) gives an infinite interval, never a NaN.
  // (std::max(0, NaN) is 0: the variance is tested before it is clamped.)
  const auto sd_along = [&cov](const Eigen::Vector2d& g) {
    const double v = g.dot(cov * g);
    return std::isfinite(v) ? std::sqrt(std::max(0.0, v)) : std::numeric_limits<double>::infinity();
  };
  const double sa = sd_along(ga);
  estimate amp{a, std::max(0.0, a - kZ95 * sa), a + kZ95 * sa, std::isfinite(sa) && a > kZ95 * sa};
  estimate phase = angle_estimate(std::arg(c), sd_along(gp));
  phase.determined = phase.determined && amp.determined;
  return {amp, phase};
}

}  // namespace

estimate log_estimate(double chart, double sd, double unit, double max_ratio) {
  estimate e;
  e.value = std::exp(chart) / unit;
  e.lo = std::exp(chart - kZ95 * sd) / unit, e.hi = std::exp(chart + kZ95 * sd) / unit;
  e.determined = std::isfinite(sd) && e.hi / e.lo < max_ratio;
  return e;
}

estimate angle_estimate(double rad, double sd) {
  constexpr double kDeterminedWithinDeg = 45.0;
  const double deg = rad * 180.0 / kPi, s = sd * 180.0 / kPi;
  return {deg, deg - kZ95 * s, deg + kZ95 * s, std::isfinite(s) && kZ95 * s < kDeterminedWithinDeg};
}

std::pair<estimate, estimate> polar_estimate(std::complex<double> c, double var_re, double var_im, double cov_re_im) {
  Eigen::Matrix2d cov;
  cov << var_re, cov_re_im, cov_re_im, var_im;
  return polar_estimate(c, cov);
}

double robust_scale(std::vector<double> magnitudes) { return clipped_scale(std::move(magnitudes)); }
double row_scatter_of(const std::vector<std::complex<double>>& vectors) { return row_scatter(vectors); }

std::complex<double> forward_force_response(const response_fit& fit, std::size_t probe, double w) {
  return probe_reading(point_of(fit.theta, fit.probe_angle_deg[probe].value * kPi / 180.0), w, 1.0, cplx(0.0, -1.0));
}

std::vector<double> row_scatter_noise(const order_table& table) {
  std::vector<double> out;
  for (const auto& o : table.orders)
    if (o.order == 1) out.push_back(row_scatter(o.vector));
  return out;
}

std::vector<double> residual_noise(const std::vector<std::vector<std::complex<double>>>& residual, const std::vector<std::size_t>& rows, std::size_t parameters) {
  std::vector<double> out;
  for (const auto& r : residual) {
    std::vector<double> parts;
    for (const std::size_t i : rows) parts.push_back(std::abs(r[i].real())), parts.push_back(std::abs(r[i].imag()));
    if (parts.empty()) {
      out.push_back(0.0);
      continue;
    }
    const double n = static_cast<double>(parts.size()), per_probe = static_cast<double>(parameters) / static_cast<double>(residual.size());
    out.push_back(clipped_scale(std::move(parts)) * std::sqrt(n / std::max(1.0, n - per_probe)));
  }
  return out;
}

std::vector<double> residual_noise(const response_fit& fit) { return residual_noise(fit.residual, fit.rows, fit.theta.empty() ? 0 : fit.parameters); }

void check_fittable(const order_table& table) {
  if (std::none_of(table.orders.begin(), table.orders.end(), [](const tracked_order& o) { return o.order == 1; }))
    throw input_error(table.source + ": no 1X columns (amp_1x, phase_1x): the response fit reads the 1X");
  if (table.rows() < 8) throw input_error(table.source + ": " + std::to_string(table.rows()) + " rows: too few for a fit of the 1X response");
  // A critical speed is fitted inside the table's speeds: rows at one speed have no such range.
  if (!(table.rpm.back() > table.rpm.front() * (1.0 + 1e-9)))
    throw input_error(table.source + ": every row is at " + format_digits(table.rpm.front()) + " rpm: a response against speed needs rows at more than one speed");
}

namespace {

// The fit's problem: the table's 1X columns, the rows fitted, each probe's declared angle and
// noise, the table's speed range, and the coordinates the parts free.
problem set_up(const order_table& table, const response_parts& parts, const response_fit_options& options) {
  problem pr{table, parts, {}, options.rows, {}, {}, false, {}};
  for (std::size_t o = 0; o < table.orders.size(); ++o)
    if (table.orders[o].order == 1) pr.orders.push_back(o);
  if (pr.orders.empty()) throw input_error(table.source + ": no 1X columns (amp_1x, phase_1x): the response fit reads the 1X");
  if (pr.rows.empty()) {
    pr.rows.resize(table.rows());
    for (std::size_t i = 0; i < table.rows(); ++i) pr.rows[i] = i;
  }
  for (const std::size_t o : pr.orders) pr.beta.push_back(table.orders[o].probe_angle);
  const bool any_undeclared = std::any_of(pr.beta.begin(), pr.beta.end(), [](const auto& b) { return !b.has_value(); });
  if (any_undeclared && pr.orders.size() > 1)
    throw input_error(table.source + ": the table has " + std::to_string(pr.orders.size()) +
                      " probes: declare each one's angle (" + setting("probe_angles") + " NAME=DEG, or '# probe_angle_deg.NAME: ...')");
  pr.beta_fitted = any_undeclared && parts.anisotropy;
  if (pr.rows.size() < 8) throw input_error(table.source + ": " + std::to_string(pr.rows.size()) + " rows: too few for a fit of the 1X response");
  // Noise per probe from every row of the table (not only the fitted ones), floored at the
  // numbers' own precision so a noise-free table still weighs its rows.
  if (!options.noise_m.empty() && options.noise_m.size() != pr.orders.size()) throw input_error("fit_response: one noise per probe");
  for (std::size_t p = 0; p < pr.orders.size(); ++p) {
    const auto& v = table.orders[pr.orders[p]].vector;
    double largest = 0.0;
    for (const cplx& x : v) largest = std::max(largest, std::abs(x));
    pr.sigma.push_back(std::max(options.noise_m.empty() ? row_scatter(v) : options.noise_m[p], 1e-12 * largest));
    if (!(pr.sigma.back() > 0.0)) throw input_error(table.source + ": every 1X amplitude of " + table.orders[pr.orders[p]].amplitude_column + " is 0: nothing to fit");
  }
  double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  for (const std::size_t i : pr.rows) lo = std::min(lo, table.rpm[i]), hi = std::max(hi, table.rpm[i]);
  pr.w_lo = lo * kRpmToRadS, pr.w_hi = hi * kRpmToRadS;
  check_fittable(table);
  if (parts.sweep) {
    for (std::size_t i = 0; i < table.rows(); ++i) {
      const bool steady = !table.dwell.empty() && table.dwell[i];
      pr.swept_row.push_back(steady ? -1 : static_cast<std::ptrdiff_t>(pr.speeds.size()));
      if (!steady) pr.speeds.push_back(table.rpm[i] * kRpmToRadS);
    }
    if (pr.speeds.size() < 8) throw numerical_error(table.source + ": a sweep needs at least 8 rows outside the table's dwell; it has " + std::to_string(pr.speeds.size()));
    pr.sweep_ref = pr.speeds.front();  // the lowest swept speed (rows in rising speed)
    pr.held_rate = options.sweep_rate;
    pr.rate_start = pr.held_rate > 0.0 ? pr.held_rate : options.sweep_rate_start;
  }
  pr.lay_out();
  return pr;
}

// A steady fit's point swept at rate alpha (rad/s^2): each mode moved back by the lag the sweep
// puts on its peak (a steady fit of a swept table puts the peak where the sweep left it): the
// resonance's group delay 1 / (zeta w) times alpha while that is small, at most the fast
// passage's sqrt(2 pi alpha) (the peak forms about a beat period after the critical speed).
std::vector<double> swept_start(const problem& pr, std::vector<double> f, double alpha) {
  f[ln_sweep] = std::log(alpha / (pr.sweep_ref * pr.sweep_ref));
  for (const auto& [ws, zs] : {std::pair{ln_wx, ln_zx}, std::pair{ln_wy, ln_zy}}) {
    const double wm = std::exp(f[ws]), lag = std::min(alpha / (std::exp(f[zs]) * wm), std::sqrt(2.0 * kPi * alpha));
    f[ws] = std::log(std::max(wm - pr.direction * lag, 0.5 * wm));
  }
  return f;
}

// The rate at which the table's rows are blocks of N revolutions end to end, as an order tracker
// that reports every block writes them: between two rows the shaft turns 2 pi N, so under a
// constant alpha Omega_2^2 - Omega_1^2 = 4 pi N alpha. The median over consecutive rows (in the
// file's order, the sweep's direction) with speeds from half the lowest to twice the highest
// critical speed of `f` (where the sweep rings); 0 where no such pair moves the sweep's way.
double contiguous_rate(const problem& pr, const std::vector<double>& f) {
  const double lo = 0.5 * std::min(std::exp(f[ln_wx]), std::exp(f[ln_wy])), hi = 2.0 * std::max(std::exp(f[ln_wx]), std::exp(f[ln_wy]));
  std::vector<std::size_t> by_line;  // the swept rows (not the dwell's)
  for (std::size_t i = 0; i < pr.table.rows(); ++i)
    if (pr.swept_row[i] >= 0) by_line.push_back(i);
  std::stable_sort(by_line.begin(), by_line.end(), [&](std::size_t a, std::size_t b) { return pr.table.line[a] < pr.table.line[b]; });
  std::vector<double> rates;
  for (std::size_t k = 1; k < by_line.size(); ++k) {
    const double w1 = pr.table.rpm[by_line[k - 1]] * kRpmToRadS, w2 = pr.table.rpm[by_line[k]] * kRpmToRadS;
    const double rate = pr.direction * (w2 * w2 - w1 * w1) / (4.0 * kPi * pr.revolutions);
    if (w1 >= lo && w1 <= hi && rate > 0.0) rates.push_back(rate);
  }
  if (rates.empty()) return 0.0;
  std::nth_element(rates.begin(), rates.begin() + static_cast<std::ptrdiff_t>(rates.size() / 2), rates.end());
  return rates[rates.size() / 2];
}

// The starts of the fits, best first within each family. Each family of starts (a scan, the
// splits, a grid, cross-coupling switched on) is ranked on its own by its projected residual, and
// the best few of each are fitted: a family whose starts lie closer in residual is not always the
// one whose basin holds the fit (two close modes seen by one probe: the scan's best starts were
// lower than every split and led elsewhere).
std::vector<std::vector<double>> starts_of(problem& pr, const response_fit* start, fit_starts how) {
  const response_parts& parts = pr.parts;
  std::vector<std::pair<double, std::vector<double>>> starts;
  std::vector<std::vector<double>> from;
  const auto rank_family = [&] {
    std::stable_sort(starts.begin(), starts.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    for (std::size_t i = 0; i < std::min(kGridStarts, starts.size()); ++i) from.push_back(starts[i].second);
    starts.clear();
  };
  const int angles = pr.beta_fitted ? kGridAngles : 1;
  const bool grid = how == fit_starts::grid || !start || start->theta.empty();
  const auto add = [&](std::vector<double> f) {
    const std::vector<double> q = pr.clamp(pr.reduce(f));
    starts.emplace_back(pr.cost(q), q);
  };
  // A steady fit swept: its point with the sweep's rate at each eta / zeta^2 of the grid for its
  // lightest damped mode (eta = alpha / w^2 of that mode), and at the rate that makes the rows
  // blocks of N revolutions end to end (contiguous_rate). Only these: the steady families were
  // the steady fit's to search, and each costs a sweep's response per start.
  if (parts.sweep && grid && start && !start->theta.empty() && !start->parts.sweep) {
    const bool x_lighter = start->theta[ln_zx] <= start->theta[ln_zy] || !parts.anisotropy;
    const double w = std::exp(start->theta[x_lighter ? ln_wx : ln_wy]), z = std::exp(start->theta[x_lighter ? ln_zx : ln_zy]);
    if (pr.rate_start > 0.0) add(swept_start(pr, start->theta, pr.rate_start));
    else
      for (double ratio = kSweepStartLo; ratio < kSweepStartHi * kSweepStartStep; ratio *= kSweepStartStep) add(swept_start(pr, start->theta, ratio * z * z * w * w));
    rank_family();
    if (const double alpha = pr.held_rate > 0.0 ? 0.0 : contiguous_rate(pr, start->theta); alpha > 0.0) add(swept_start(pr, start->theta, alpha));
    rank_family();
    return from;
  }
  const double ln_lo = std::log(pr.w_lo), ln_hi = std::log(pr.w_hi);
  std::vector<double> scan;  // ln w, 1 % apart, over the table's speeds
  for (double u = ln_lo; u < ln_hi + 0.5 * kScanStep; u += kScanStep) scan.push_back(u);
  if (grid && !parts.anisotropy) {
    for (const double u : scan)
      for (const double z : kScanZetas) {
        std::vector<double> f(kSlots, 0.0);
        f[ln_wx] = f[ln_wy] = u, f[ln_zx] = f[ln_zy] = std::log(z);
        add(f);
      }
  } else if (grid && start && !start->theta.empty() && !start->parts.anisotropy && !parts.sweep) {
    // (A swept fit that adds anisotropy to a swept one starts from it as it is: the steady fit of
    // its parts, swept, brings the two modes the steady scan found.)
    // Keep the isotropic fit's mode on one axis, scan the other's (either axis when the probes'
    // angles are declared; with beta fitted the axes are interchangeable).
    for (int keep = 0; keep < (pr.beta_fitted ? 1 : 2); ++keep)
      for (const double u : scan)
        for (const double z : kScanZetas)
          for (int g = 0; g < angles; ++g) {
            std::vector<double> f = start->theta;
            f[keep == 0 ? ln_wy : ln_wx] = u, f[keep == 0 ? ln_zy : ln_zx] = std::log(z);
            f[probe_beta] = kPi * g / angles;
            add(f);
          }
    rank_family();
    for (const double split : kSplits)
      for (const double sign : {-1.0, 1.0})
        for (int g = 0; g < angles; ++g) {
          std::vector<double> f = start->theta;
          f[ln_wx] -= sign * 0.5 * std::log(split), f[ln_wy] += sign * 0.5 * std::log(split);
          f[probe_beta] = kPi * g / angles;
          add(f);
        }
  } else if (grid && !parts.sweep) {  // (a swept fit with both modes starts from a fit that has them)
    std::vector<double> speeds;
    for (int i = 0; i < kGridSpeeds; ++i) speeds.push_back(ln_lo + (ln_hi - ln_lo) * i / (kGridSpeeds - 1));
    for (int a = 0; a < kGridSpeeds; ++a)
      for (int b = pr.beta_fitted ? a : 0; b < kGridSpeeds; ++b)
        for (const double z : {0.02, 0.1})
          for (int g = 0; g < angles; ++g) {
            std::vector<double> f(kSlots, 0.0);
            f[ln_wx] = speeds[static_cast<std::size_t>(a)], f[ln_wy] = speeds[static_cast<std::size_t>(b)];
            f[ln_zx] = f[ln_zy] = std::log(z);
            f[probe_beta] = kPi * g / angles;
            add(f);
          }
  }
  rank_family();
  // A previous fit without cross-coupling, with it switched on at a tenth of its range in each
  // pattern (a seal's follower pair k_xy = -k_yx either way, a symmetric pair either way): from
  // off, the fit can stay in the basin where it is not needed.
  if (grid && start && !start->theta.empty() && parts.cross_coupling && !start->parts.cross_coupling)
    for (const auto& [a, b] : {std::pair{1.0, -1.0}, std::pair{-1.0, 1.0}, std::pair{1.0, 1.0}, std::pair{-1.0, -1.0}})
      for (int g = 0; g < (start->parts.anisotropy || !pr.beta_fitted ? 1 : angles); ++g) {
        std::vector<double> f = start->theta;
        f[k_xy] = 0.1 * kCrossBound * a, f[k_yx] = 0.1 * kCrossBound * b;
        if (!start->parts.anisotropy && pr.beta_fitted) f[probe_beta] = kPi * g / angles;
        add(f);
      }
  rank_family();
  rank_family();
  // A previous fit's point as it is (a part it lacks starts from off: equal modes, no
  // cross-coupling), with each grid angle when beta is new.
  if (start && !start->theta.empty() && !(parts.sweep && !start->parts.sweep))
    for (int g = 0; g < (start->parts.anisotropy || !pr.beta_fitted ? 1 : kGridAngles); ++g) {
      std::vector<double> f = start->theta;
      if (!start->parts.anisotropy && pr.beta_fitted) f[probe_beta] = kPi * g / kGridAngles;
      from.push_back(pr.clamp(pr.reduce(f)));
    }
  return from;
}

// One probe without a declared angle: the support axes have no names, so the modes are labelled
// by critical speed (a the lower), the frame turned to put x on mode a's axis (an exact symmetry
// of the model: every spatial angle turns by -90 degrees), and the probe's angle put in [0, 180)
// (turning it by 180 degrees flips its reading).
void canonical_frame(const problem& pr, std::vector<double>& best, std::vector<cplx>& amp) {
  if (!pr.beta_fitted) return;
  const cplx j(0.0, 1.0);
  if (best[ln_wx] > best[ln_wy]) {
    std::swap(best[ln_wx], best[ln_wy]), std::swap(best[ln_zx], best[ln_zy]);
    best[probe_beta] -= kPi / 2.0;
    amp[0] *= -j;
    if (pr.parts.shaft_bow) amp.back() *= -j;
    const double kxy = best[k_xy], kyx = best[k_yx];
    best[k_xy] = -kyx, best[k_yx] = -kxy;
  }
  const auto turn = [&](double by) {
    best[probe_beta] += by, amp[0] = -amp[0];
    if (pr.parts.shaft_bow) amp.back() = -amp.back();
  };
  while (best[probe_beta] < 0.0) turn(kPi);
  while (best[probe_beta] >= kPi) turn(-kPi);
}

// The residuals' series for their correlation factor: each probe's real and imaginary parts
// along the fitted rows (in speed order).
std::vector<residual_series> row_series(std::size_t probes, std::size_t rows) {
  std::vector<residual_series> out;
  for (std::size_t p = 0; p < probes; ++p)
    for (Eigen::Index part = 0; part < 2; ++part)
      out.push_back({static_cast<Eigen::Index>(2 * p * rows) + part, static_cast<Eigen::Index>(rows), 2});
  return out;
}

// The covariance of every coordinate and amplitude (re, im) at the fit (ref/inference: scaled by
// chi^2/dof where the residual exceeds the noise, and by the residuals' correlation over
// neighbouring rows; directions the data do not constrain get an infinite variance). The
// amplitudes' columns: the residual is data - A x, its derivative along a unit amplitude -A e_c.
fit_covariance covariance_at(problem& pr, const std::vector<double>& best_q, const std::vector<cplx>& amp, const Eigen::VectorXd& r) {
  const std::size_t n = best_q.size(), l = pr.amplitudes();
  Eigen::MatrixXd jf(r.size(), static_cast<Eigen::Index>(n + 2 * l));
  const least_squares_problem at_amplitudes = solver_problem(pr, &amp);
  const Eigen::VectorXd u = Eigen::Map<const Eigen::VectorXd>(best_q.data(), static_cast<Eigen::Index>(n));
  jf.leftCols(static_cast<Eigen::Index>(n)) = forward_difference_jacobian(at_amplitudes, u, r, solver_options().difference_step);
  std::vector<cplx> unit(l, 0.0), zero(l, 0.0), ignored;
  const Eigen::VectorXd at_zero = pr.residuals(best_q, ignored, &zero);
  for (std::size_t c = 0; c < l; ++c)
    for (int part = 0; part < 2; ++part) {
      std::fill(unit.begin(), unit.end(), cplx(0.0));
      unit[c] = part == 0 ? cplx(1.0) : cplx(0.0, 1.0);
      jf.col(static_cast<Eigen::Index>(n + 2 * c + static_cast<std::size_t>(part))) = pr.residuals(best_q, ignored, &unit) - at_zero;
    }
  return covariance_of(jf, r, 1.0, row_series(pr.orders.size(), pr.rows.size()));
}

// The modes, unbalance, probes' angles and runouts, bow and cross-coupling with their 95 %
// intervals, and how much the parts cancel.
void estimates_into(response_fit& f, const problem& pr, const std::vector<double>& best, const std::vector<cplx>& amp, const fit_covariance& cc) {
  const evidence_rules rules;
  const std::size_t n = pr.free.size(), l = pr.amplitudes();
  const auto cov2 = [&](std::size_t k) {
    Eigen::Matrix2d c = cc.cov.block(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(k), 2, 2);
    if (cc.unconstrained[k] || cc.unconstrained[k + 1]) c.setConstant(std::numeric_limits<double>::infinity());
    return c;
  };
  // A slot's standard deviation (an isotropic rotor's y slots are its x slots).
  const auto sd_of = [&](std::size_t slot) {
    if (!pr.parts.anisotropy && slot == ln_wy) slot = ln_wx;
    if (!pr.parts.anisotropy && slot == ln_zy) slot = ln_zx;
    const auto at = std::find(pr.free.begin(), pr.free.end(), slot);
    return at == pr.free.end() ? 0.0 : cc.standard_deviation(static_cast<Eigen::Index>(at - pr.free.begin()));
  };
  // Critical speeds and damping ratios: determined when their 95 % interval is within the evidence
  // rules' ratio (a factor of 2 either way), and not at an edge of the table's speeds.
  for (int m = 0; m < (pr.parts.anisotropy ? 2 : 1); ++m) {
    const std::size_t w_slot = m == 0 ? ln_wx : ln_wy, z_slot = m == 0 ? ln_zx : ln_zy;
    response_mode mode;
    mode.axis = !pr.parts.anisotropy ? "both" : pr.beta_fitted ? (m == 0 ? "a" : "b") : (m == 0 ? "x" : "y");
    mode.critical_speed_rpm = log_estimate(best[w_slot], sd_of(w_slot), kRpmToRadS, rules.max_interval_ratio);
    mode.damping_ratio = log_estimate(best[z_slot], sd_of(z_slot), 1.0, rules.max_interval_ratio);
    mode.at_edge = best[w_slot] <= std::log(pr.w_lo) + 1e-9 || best[w_slot] >= std::log(pr.w_hi) - 1e-9;
    if (mode.at_edge) mode.critical_speed_rpm.determined = mode.damping_ratio.determined = false;
    f.modes.push_back(mode);
  }
  if (f.modes.size() == 2 && f.modes[1].critical_speed_rpm.value < f.modes[0].critical_speed_rpm.value) std::swap(f.modes[0], f.modes[1]);
  std::tie(f.unbalance_m, f.unbalance_phase_deg) = polar_estimate(amp[0], cov2(n));
  for (std::size_t p = 0; p < pr.orders.size(); ++p) {
    f.probes.push_back(pr.table.orders[pr.orders[p]].probe);
    if (pr.beta[p]) {
      const double deg = *pr.beta[p] * 180.0 / kPi;
      f.probe_angle_deg.push_back({deg, deg, deg, true});
    } else if (pr.beta_fitted) {
      f.probe_angle_deg.push_back(angle_estimate(best[probe_beta], sd_of(probe_beta)));
    } else {  // an isotropic rotor, one probe: every angle reads alike (the unbalance phase takes it)
      f.probe_angle_deg.push_back({0.0, 0.0, 180.0, false});
    }
    f.probe_angle_fitted.push_back(pr.beta_fitted);
    const auto [ra, rp] = polar_estimate(amp[1 + p], cov2(n + 2 * (1 + p)));
    f.runout_m.push_back(ra), f.runout_phase_deg.push_back(rp);
    f.noise_m.push_back(pr.sigma[p]);
  }
  if (pr.parts.shaft_bow) std::tie(f.bow_m, f.bow_phase_deg) = polar_estimate(amp.back(), cov2(n + 2 * (l - 1)));
  // How much the model's parts (the unbalance's response, the bow's, each runout) cancel: the
  // RMS over the fitted rows of the sum of their sizes over the RMS of their sum.
  double parts_sq = 0.0, sum_sq = 0.0;
  const auto at_rows = pr.parts_at_rows(best, amp);
  for (std::size_t p = 0; p < pr.orders.size(); ++p)
    for (const std::size_t i : pr.rows) {
      double size = 0.0;
      cplx sum = 0.0;
      for (std::size_t c = 0; c < l; ++c) size += std::abs(at_rows[p][i][c]), sum += at_rows[p][i][c];
      parts_sq += size * size, sum_sq += std::norm(sum);
    }
  f.cancellation = sum_sq > 0.0 ? std::sqrt(parts_sq / sum_sq) : std::numeric_limits<double>::infinity();
  if (pr.parts.sweep) {
    // The rate in rpm/s, from its chart ln(|alpha| / w_lo^2); determined as a critical speed is, and
    // not at either end of its range (at the slow end the table is quasi-steady).
    f.sweep_rpm_per_s = log_estimate(best[ln_sweep] + 2.0 * std::log(pr.sweep_ref), sd_of(ln_sweep), kRpmToRadS, rules.max_interval_ratio);
    f.sweep_rate_held = pr.held_rate > 0.0;
    if (f.sweep_rate_held) {  // given: its own value, not the table's estimate
      const double rpm_per_s = pr.held_rate / kRpmToRadS;
      f.sweep_rpm_per_s = {rpm_per_s, rpm_per_s, rpm_per_s, true};
    }
    f.sweep_at_slow_bound = !f.sweep_rate_held && best[ln_sweep] <= std::log(kSweepSlowest) + 1e-9;
    if (f.sweep_at_slow_bound || (!f.sweep_rate_held && best[ln_sweep] >= pr.sweep_fastest() - 1e-9)) f.sweep_rpm_per_s.determined = false;
    f.sweep_direction = pr.direction;
    f.sweep_revolutions = pr.revolutions;
  }
  if (pr.parts.cross_coupling) {
    const double w2 = std::exp(best[ln_wx] + best[ln_wy]);
    for (const std::size_t slot : {k_xy, k_yx}) {
      const double val = best[slot] * w2, s = sd_of(slot) * w2;
      const bool at_bound = std::abs(best[slot]) >= kCrossBound - 1e-9;
      (slot == k_xy ? f.k_xy_over_m : f.k_yx_over_m) = {val, val - kZ95 * s, val + kZ95 * s, !at_bound && std::isfinite(s) && std::abs(val) > kZ95 * s};
      f.cross_coupling_at_bound = f.cross_coupling_at_bound || at_bound;
    }
  }
}

// chi^2 against its 0.1 % bound, widened by the noise estimate's own uncertainty (a relative error
// s in the noise moves chi^2/dof by 2 s; the two added in quadrature), and the model and residual
// at every row of the table (fitted or not: a fold's held-out rows too).
void quality_into(response_fit& f, const problem& pr, double noise_relative_error) {
  const double ratio = f.chi2 / static_cast<double>(f.dof);
  const double chi2_bound = boost::math::quantile(boost::math::chi_squared(static_cast<double>(f.dof)), 0.999) / static_cast<double>(f.dof) - 1.0;
  f.chi2_bound = 1.0 + std::hypot(chi2_bound, 3.29 * 2.0 * noise_relative_error);
  f.consistent_with_noise = ratio <= f.chi2_bound;
  double sum2 = 0.0;
  std::size_t count = 0;
  f.model.assign(pr.orders.size(), {}), f.residual.assign(pr.orders.size(), {});
  const auto at_rows = pr.parts.sweep ? pr.parts_at_rows(f.theta, f.amplitudes) : std::vector<std::vector<std::vector<cplx>>>{};
  for (std::size_t p = 0; p < pr.orders.size(); ++p)
    for (std::size_t i = 0; i < pr.table.rows(); ++i) {
      cplx mdl = 0.0;
      if (pr.parts.sweep)
        for (const cplx& part : at_rows[p][i]) mdl += part;
      else
        mdl = response_at(f, p, pr.table.rpm[i]);
      f.model[p].push_back(mdl);
      f.residual[p].push_back(pr.table.orders[pr.orders[p]].vector[i] - mdl);
    }
  for (std::size_t p = 0; p < pr.orders.size(); ++p)
    for (const std::size_t i : pr.rows) sum2 += std::norm(f.residual[p][i]), ++count;
  f.rms_residual_m = std::sqrt(sum2 / static_cast<double>(2 * count));  // per component, as the noise
}

}  // namespace

namespace {

// The best of a fit's starts, each taken by the solver: its coordinates, chi^2 and how much lower
// its minimum may lie.
struct fitted_point {
  std::vector<double> q;
  double cost = std::numeric_limits<double>::infinity(), remaining = 0.0;
};
fitted_point best_from(problem& pr, const std::vector<std::vector<double>>& starts) {
  fitted_point best;
  for (const auto& q0 : starts) {
    const auto [q, remaining] = fit_from(pr, q0);
    const double c = pr.cost(q);
    if (c < best.cost) best = {q, c, remaining};
  }
  return best;
}

// The rescue scan (kRescue* above) of the swept fit at pr's direction and block, about the steady
// fit `steady`: the best distinct points of the grid, each fitted by the solver (on the machine's
// threads, each on its own copy of the problem); the best of those fits.
fitted_point aliased_rate_scan(problem& pr, const std::vector<double>& steady) {
  const bool x_lighter = steady[ln_zx] <= steady[ln_zy] || !pr.parts.anisotropy;
  const std::size_t ws = x_lighter ? ln_wx : ln_wy, zs = x_lighter ? ln_zx : ln_zy;
  const double w = std::exp(steady[ws]);
  std::vector<double> rates;
  for (double eta = kRescueEtaLo; std::log(eta * w * w / (pr.sweep_ref * pr.sweep_ref)) <= pr.sweep_fastest(); eta *= kRescueRateStep) rates.push_back(eta * w * w);
  const std::size_t regimes = std::size(kRescueRegimes);
  const std::size_t lags = static_cast<std::size_t>(std::lround((kRescueLagHi - kRescueLagLo) / kRescueLagStep)) + 1;
  // Point (i, j, k): rate i, regime j, lag k; a point not evaluated keeps an infinite cost.
  std::vector<double> cost(rates.size() * regimes * lags, std::numeric_limits<double>::infinity());
  std::vector<std::vector<double>> point(cost.size());
  const auto evaluate = [&](const std::vector<std::size_t>& cells) {  // cells i * lags + k, every regime
    parallel_for(cells.size(), 0, [&](std::size_t c) {
      const std::size_t i = cells[c] / lags, k = cells[c] % lags;
      for (std::size_t j = 0; j < regimes; ++j) {
        std::vector<double> f = swept_start(pr, steady, rates[i]);  // (the other mode moved back by its own lag)
        const double lag = (kRescueLagLo + kRescueLagStep * static_cast<double>(k)) * std::sqrt(2.0 * kPi * rates[i]);
        f[ws] = std::log(std::max(w - pr.direction * lag, 0.5 * w));
        f[zs] = 0.5 * std::log(rates[i] / (w * w * kRescueRegimes[j]));
        const std::size_t at = (i * regimes + j) * lags + k;
        point[at] = pr.clamp(pr.reduce(f));
        cost[at] = pr.swept_cost(point[at]);
      }
    });
    pr.evaluations += static_cast<int>(cells.size() * regimes);
  };
  // Coarse to fine (above): the cells (rate, lag) within kRescueCoarse - 1 steps of the best
  // coarse ones, every regime of each.
  std::vector<std::size_t> coarse;
  for (std::size_t i = 0; i < rates.size(); i += kRescueCoarse)
    for (std::size_t k = 0; k < lags; k += kRescueCoarse) coarse.push_back(i * lags + k);
  evaluate(coarse);
  const auto cell_cost = [&](std::size_t cell) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < regimes; ++j) best = std::min(best, cost[((cell / lags) * regimes + j) * lags + cell % lags]);
    return best;
  };
  std::stable_sort(coarse.begin(), coarse.end(), [&](std::size_t a, std::size_t b) { return cell_cost(a) < cell_cost(b); });
  std::vector<bool> done(rates.size() * lags, false);
  for (const std::size_t cell : coarse) done[cell] = true;
  std::vector<std::size_t> fine;
  const auto reach = static_cast<std::ptrdiff_t>(kRescueCoarse) - 1;
  for (std::size_t c = 0; c < std::min(coarse.size(), kRescueRefined); ++c) {
    if (!std::isfinite(cell_cost(coarse[c]))) break;
    const auto i0 = static_cast<std::ptrdiff_t>(coarse[c] / lags), k0 = static_cast<std::ptrdiff_t>(coarse[c] % lags);
    for (std::ptrdiff_t i = std::max<std::ptrdiff_t>(0, i0 - reach); i <= std::min<std::ptrdiff_t>(static_cast<std::ptrdiff_t>(rates.size()) - 1, i0 + reach); ++i)
      for (std::ptrdiff_t k = std::max<std::ptrdiff_t>(0, k0 - reach); k <= std::min<std::ptrdiff_t>(static_cast<std::ptrdiff_t>(lags) - 1, k0 + reach); ++k) {
        const std::size_t cell = static_cast<std::size_t>(i) * lags + static_cast<std::size_t>(k);
        if (!done[cell]) done[cell] = true, fine.push_back(cell);
      }
  }
  std::sort(fine.begin(), fine.end());
  evaluate(fine);
  std::vector<std::size_t> order(cost.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return cost[a] < cost[b]; });
  std::vector<std::size_t> picked;
  const auto apart = [&](std::size_t a, std::size_t b) {
    const auto d = [](std::size_t x, std::size_t y) { return x > y ? x - y : y - x; };
    const std::size_t n = regimes * lags;  // (the regimes are one basin's: only rate and speed set a point apart)
    return d(a / n, b / n) >= static_cast<std::size_t>(kRescueApart) || d(a % lags, b % lags) >= static_cast<std::size_t>(kRescueApart);
  };
  for (const std::size_t i : order) {
    if (!std::isfinite(cost[i]) || picked.size() == kRescueStarts) break;
    if (std::all_of(picked.begin(), picked.end(), [&](std::size_t j) { return apart(i, j); })) picked.push_back(i);
  }
  std::vector<fitted_point> fits(picked.size());
  std::vector<int> evaluations(picked.size(), 0);
  parallel_for(picked.size(), 0, [&](std::size_t j) {
    problem own = pr;
    own.evaluations = 0;
    fits[j] = best_from(own, {point[picked[j]]});
    evaluations[j] = own.evaluations;
  });
  fitted_point best;
  for (std::size_t j = 0; j < fits.size(); ++j) {
    pr.evaluations += evaluations[j];
    if (fits[j].cost < best.cost) best = fits[j];
  }
  return best;
}

// The fit at its best point: the amplitudes, the canonical frame, the covariance, the estimates
// and the quality.
response_fit finish(problem& pr, const fitted_point& at, const response_fit_options& options) {
  std::vector<cplx> amp;
  pr.residuals(at.q, amp);
  std::vector<double> best = pr.full(at.q);
  canonical_frame(pr, best, amp);
  const std::vector<double> best_q = pr.reduce(best);
  const Eigen::VectorXd r = pr.residuals(best_q, amp, &amp);
  const fit_covariance cc = covariance_at(pr, best_q, amp, r);
  response_fit f;
  f.parts = pr.parts;
  f.chi2 = r.squaredNorm();
  f.chi2_uncertainty = at.remaining;
  f.parameters = best_q.size() + 2 * pr.amplitudes();
  f.dof = cc.dof;
  estimates_into(f, pr, best, amp, cc);
  f.theta = best;
  f.amplitudes = amp;
  f.rows = pr.rows;
  f.evaluations = pr.evaluations;
  quality_into(f, pr, options.noise_relative_error);
  return f;
}

// The 95 % point of chi^2 with one degree of freedom: a profile's interval.
constexpr double kProfile95 = 3.841458820694124;

// Every estimate of `f` widened to cover `other`'s interval (the same model at another value of a
// discrete coordinate that fits as well); determined only where both are.
void widen_by(response_fit& f, const response_fit& other) {
  const auto widen = [](estimate& a, const estimate& b) {
    a.lo = std::min(a.lo, b.lo), a.hi = std::max(a.hi, b.hi), a.determined = a.determined && b.determined;
  };
  for (std::size_t m = 0; m < std::min(f.modes.size(), other.modes.size()); ++m) {
    widen(f.modes[m].critical_speed_rpm, other.modes[m].critical_speed_rpm);
    widen(f.modes[m].damping_ratio, other.modes[m].damping_ratio);
  }
  widen(f.unbalance_m, other.unbalance_m), widen(f.unbalance_phase_deg, other.unbalance_phase_deg);
  for (std::size_t p = 0; p < f.probes.size(); ++p) {
    widen(f.probe_angle_deg[p], other.probe_angle_deg[p]);
    widen(f.runout_m[p], other.runout_m[p]), widen(f.runout_phase_deg[p], other.runout_phase_deg[p]);
  }
  if (f.parts.shaft_bow) widen(f.bow_m, other.bow_m), widen(f.bow_phase_deg, other.bow_phase_deg);
  if (f.parts.cross_coupling) widen(f.k_xy_over_m, other.k_xy_over_m), widen(f.k_yx_over_m, other.k_yx_over_m);
  if (!f.sweep_rate_held) widen(f.sweep_rpm_per_s, other.sweep_rpm_per_s);
}

// A sweep's direction and block as given (options), as the fit it starts from had them, or every
// candidate: both directions where the table's row order says neither, every block of
// kSweepRevolutions where none is declared.
std::pair<std::vector<int>, std::vector<double>> sweep_candidates(const order_table& table, const response_fit* start, const response_fit_options& o) {
  const bool swept_start = start && start->parts.sweep && !start->theta.empty();
  std::vector<int> directions;
  if (o.sweep_direction != 0) directions = {o.sweep_direction};
  else if (swept_start) directions = {start->sweep_direction};
  else if (const int d = sweep_direction_of(table); d != 0) directions = {d};
  else directions = {1, -1};
  std::vector<double> blocks;
  if (o.revolutions_per_row > 0.0) blocks = {o.revolutions_per_row};
  else if (!o.sweep_blocks.empty()) blocks = o.sweep_blocks;
  else if (swept_start) blocks = {start->sweep_revolutions};
  else blocks.assign(std::begin(kSweepRevolutions), std::end(kSweepRevolutions));
  return {directions, blocks};
}

}  // namespace

std::optional<timed_sweep> sweep_of_times(const order_table& table) {
  if (table.time_s.empty()) return std::nullopt;
  if (table.time_s.size() != table.rows())
    throw input_error(table.source + ": the time_s column has " + std::to_string(table.time_s.size()) + " values for " + std::to_string(table.rows()) + " rows");
  std::vector<std::size_t> swept;  // the rows outside the table's dwell (its speed stands still)
  for (std::size_t i = 0; i < table.rows(); ++i)
    if (table.dwell.empty() || !table.dwell[i]) swept.push_back(i);
  const double n = static_cast<double>(swept.size());
  if (swept.size() < 3) throw input_error(table.source + ": a sweep's rate from the time_s column needs at least 3 rows outside the table's dwell");
  double tm = 0.0, wm = 0.0;
  for (const std::size_t i : swept) tm += table.time_s[i], wm += table.rpm[i] * kRpmToRadS;
  tm /= n, wm /= n;
  double stt = 0.0, stw = 0.0;
  for (const std::size_t i : swept) stt += (table.time_s[i] - tm) * (table.time_s[i] - tm), stw += (table.time_s[i] - tm) * (table.rpm[i] * kRpmToRadS - wm);
  timed_sweep s;
  s.alpha = stw / stt;
  double ss = 0.0;
  for (const std::size_t i : swept) {
    const double d = table.rpm[i] * kRpmToRadS - wm - s.alpha * (table.time_s[i] - tm);
    ss += d * d, s.departure_rpm = std::max(s.departure_rpm, std::abs(d) / kRpmToRadS);
  }
  s.alpha_sd = std::sqrt(ss / (n - 2.0) / stt);
  s.range_rpm = table.rpm[swept.back()] - table.rpm[swept.front()];
  if (!(std::abs(s.alpha) > 0.0) || !(std::abs(s.alpha) > 2.0 * s.alpha_sd))
    throw input_error(table.source + ": the speed does not change with the time_s column (" + format_digits(s.alpha / kRpmToRadS) + " +- " +
                      format_digits(2.0 * s.alpha_sd / kRpmToRadS) + " rpm/s): it is no run-up or coast-down");
  return s;
}

int sweep_direction_of(const order_table& table) {
  // The rows' file lines (or times, where the table has a time_s column) in rising speed: a
  // run-up's rise with the speed, a coast-down's fall. A sweep's speed column jitters a little (a
  // few reversals); shuffled rows reverse half the time, so a direction needs three times as many
  // steps one way as the other. A dwell's rows are left out (their speeds jitter about one).
  std::vector<std::size_t> swept;
  for (std::size_t i = 0; i < table.rows(); ++i)
    if (table.dwell.empty() || !table.dwell[i]) swept.push_back(i);
  std::size_t rises = 0, falls = 0;
  for (std::size_t k = 1; k < swept.size(); ++k) {
    const std::size_t i = swept[k], h = swept[k - 1];
    const bool later = table.time_s.empty() ? table.line[i] > table.line[h] : table.time_s[i] > table.time_s[h];
    const bool earlier = table.time_s.empty() ? table.line[i] < table.line[h] : table.time_s[i] < table.time_s[h];
    rises += later, falls += earlier;
  }
  if (rises > 3 * falls) return 1;
  if (falls > 3 * rises) return -1;
  return 0;
}

response_fit fit_response(const order_table& table, const response_parts& parts, const response_fit_options& options) {
  // An anisotropic fit without a start splits the isotropic fit's mode (two close critical
  // speeds fall between the grid's points).
  const response_fit* start = options.start;
  response_fit isotropic;
  if (parts.anisotropy && !start) {
    response_parts iso = parts;
    iso.anisotropy = false;
    isotropic = fit_response(table, iso, options);
    start = &isotropic;
  }
  response_fit steady;
  if (parts.sweep && (!start || start->theta.empty())) {  // a swept fit starts from the steady fit of its parts
    response_parts still = parts;
    still.sweep = false;
    response_fit_options o = options;
    o.start = start;
    steady = fit_response(table, still, o);
    start = &steady;
  }
  if (!parts.sweep) {
    problem pr = set_up(table, parts, options);
    const fitted_point best = best_from(pr, starts_of(pr, start, options.starts));
    if (!std::isfinite(best.cost)) throw numerical_error(table.source + ": the 1X response fit found no finite residual from any start");
    return finish(pr, best, options);
  }
  // A sweep: per direction, the first block from the starts, every other block from the best
  // point so far (the block changes how the ringing reads, little where the sweep goes) and from
  // the rate that makes its rows blocks end to end; the fit with the lowest chi^2 kept.
  const auto [directions, blocks] = sweep_candidates(table, start, options);
  std::optional<problem> kept;
  fitted_point best;
  int evaluations = 0;
  struct tried_block {
    int direction;
    double revolutions;
    fitted_point at;
  };
  std::vector<tried_block> tried;
  for (const int direction : directions) {
    std::optional<fitted_point> previous;
    for (const double revolutions : blocks) {
      problem pr = set_up(table, parts, options);
      pr.direction = direction, pr.revolutions = revolutions;
      // A held rate too fast for this block (it would reach zero speed): not a block of this sweep.
      if (pr.held_rate > 0.0 && pr.held_ln_sweep() > pr.sweep_fastest()) continue;
      std::vector<std::vector<double>> from;
      if (!previous) {
        from = starts_of(pr, start, options.starts);
      } else {
        from.push_back(pr.clamp(previous->q));
        if (start && !start->parts.sweep && !start->theta.empty() && !(pr.held_rate > 0.0))
          if (const double alpha = contiguous_rate(pr, start->theta); alpha > 0.0) from.push_back(pr.clamp(pr.reduce(swept_start(pr, start->theta, alpha))));
      }
      const fitted_point here = best_from(pr, from);
      evaluations += pr.evaluations;
      if (std::isfinite(here.cost)) tried.push_back({direction, revolutions, here});
      if (here.cost < best.cost) best = here, kept.emplace(std::move(pr));
      if (std::isfinite(here.cost) && (!previous || here.cost < previous->cost)) previous = here;  // (a block no start fits starts none)
    }
  }
  if (!kept && options.sweep_rate > 0.0 && evaluations == 0)
    throw input_error(table.source + ": a sweep of " + format_digits(options.sweep_rate / kRpmToRadS) + " rpm/s is too fast for blocks of " +
                      format_digits(blocks.front()) + (blocks.size() > 1 ? " or more" : "") + " revolutions at the table's lowest speed (a block would reach zero speed)");
  if (!kept) throw numerical_error(table.source + ": the swept 1X response fit found no finite residual from any start");
  response_fit f = finish(*kept, best, options);
  // Where the rate was searched from the steady fit (neither held nor started at another fit's)
  // and the fit leaves more than the noise, whether or not it found a rate (its starts may all end
  // at the slow bound, as one compiler's round-off took tests/swept_response_test.cpp's sparse fast
  // sweep): the rescue scan at its block and direction, and where that fits better, every block of
  // that direction from its point.
  const bool rate_searched = !(options.sweep_rate > 0.0) && !(options.sweep_rate_start > 0.0) && start && !start->parts.sweep && !start->theta.empty();
  if (rate_searched && !f.consistent_with_noise) {
    const int direction = kept->direction;
    const double scanned = kept->revolutions;
    problem pr = set_up(table, parts, options);
    pr.direction = direction, pr.revolutions = scanned;
    const fitted_point rescued = aliased_rate_scan(pr, start->theta);
    evaluations += pr.evaluations;
    if (rescued.cost < best.cost) {
      for (const double revolutions : blocks) {
        problem at = set_up(table, parts, options);
        at.direction = direction, at.revolutions = revolutions;
        if (at.held_rate > 0.0 && at.held_ln_sweep() > at.sweep_fastest()) continue;
        const fitted_point here = revolutions == scanned ? rescued : best_from(at, {at.clamp(rescued.q)});
        evaluations += at.evaluations;
        if (!std::isfinite(here.cost)) continue;
        const auto same = std::find_if(tried.begin(), tried.end(), [&](const tried_block& t) { return t.direction == direction && t.revolutions == revolutions; });
        if (same == tried.end()) tried.push_back({direction, revolutions, here});
        else if (here.cost < same->at.cost) same->at = here;
        if (here.cost < best.cost) best = here, kept.emplace(std::move(at));
      }
      f = finish(*kept, best, options);
    }
  }
  // The block and direction are fitted among a few values: where another fits as well (its chi^2
  // within the 95 % point of one coordinate's, 3.84, scaled as the covariance is; within it too
  // where its unfinished descent may reach it, so that no round-off decides), the estimates take
  // its intervals too (a profile over the discrete coordinate: at a slow sweep the block changes
  // the read little, and its choice must not make the intervals miss).
  const double scale = std::max(1.0, f.chi2 / static_cast<double>(std::max<std::size_t>(f.dof, 1)));
  f.sweep_alternatives.push_back(f.sweep_revolutions * f.sweep_direction);
  for (const tried_block& t : tried) {
    if (t.revolutions == f.sweep_revolutions && t.direction == f.sweep_direction) continue;
    if (!(t.at.cost - t.at.remaining <= best.cost + kProfile95 * scale)) continue;
    problem pr = set_up(table, parts, options);
    pr.direction = t.direction, pr.revolutions = t.revolutions;
    const response_fit other = finish(pr, t.at, options);
    widen_by(f, other);
    f.sweep_alternatives.push_back(t.revolutions * t.direction);
  }
  f.evaluations = evaluations;
  f.sweep_revolutions_fitted = blocks.size() > 1 || (start && start->parts.sweep && start->sweep_revolutions_fitted && options.revolutions_per_row <= 0.0);
  return f;
}

std::complex<double> response_at(const response_fit& fit, std::size_t probe, double rpm) {
  const auto [unbalance, bow] = reading(point_of(fit.theta, fit.probe_angle_deg[probe].value * kPi / 180.0), rpm * kRpmToRadS);
  cplx v = fit.amplitudes[0] * unbalance + fit.amplitudes[1 + probe];
  if (fit.parts.shaft_bow) v += fit.amplitudes.back() * bow;
  return v;
}

}  // namespace rubref
