#include "ref/identification/contact_forces.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <boost/math/distributions/chi_squared.hpp>
#include <set>

#include "ref/base/errors.hpp"
#include "ref/identification/frols.hpp"

namespace rubref {

namespace {
// Derivatives with windows split at y = delta; a periodic cycle is tiled three times so that its
// windows wrap around, and the middle copy is kept.
std::pair<derivatives, derivatives> differentiate_xy(const dwell& d, double clearance, const derivative_settings& ds) {
  const std::size_t n = d.size(), copies = d.periodic ? 3 : 1;
  std::vector<double> x, y;
  for (std::size_t c = 0; c < copies; ++c) {
    x.insert(x.end(), d.x.begin(), d.x.end());
    y.insert(y.end(), d.y.begin(), d.y.end());
  }
  // Segments: runs of samples on one side of y = delta (the force law switches between them).
  std::vector<int> side(y.size());
  for (std::size_t i = 0; i < y.size(); ++i) side[i] = (i ? side[i - 1] : 0) + (i && (y[i] > clearance) != (y[i - 1] > clearance));
  derivatives dx = differentiate(x, d.dt, ds, side), dy = differentiate(y, d.dt, ds, side);
  if (d.periodic) {
    for (auto* v : {&dx.d1, &dx.d2, &dy.d1, &dy.d2, &dy.d1_gain}) *v = std::vector<double>(v->begin() + n, v->begin() + 2 * n);
  }
  return {std::move(dx), std::move(dy)};
}
}  // namespace

dwell_forces contact_forces(const dwell& d, const linear_part& lin, double clearance, const derivative_settings& ds) {
  const std::size_t n = d.size();
  const auto [dx, dy] = differentiate_xy(d, clearance, ds);
  dwell_forces f;
  f.source = &d;
  f.vx = dx.d1;
  f.ax = dx.d2;
  f.vy = dy.d1;
  f.ay = dy.d2;
  f.vy_gain = dy.d1_gain;
  f.z.resize(n);
  f.fx.resize(n);
  f.fn.resize(n);
  f.contact.resize(n);
  const double w = d.omega(), unbalance = lin.m * lin.e * w * w;
  for (std::size_t i = 0; i < n; ++i) {
    const double phase = w * d.t[i] + lin.phase;
    f.z[i] = d.y[i] - clearance;
    f.fx[i] = lin.m * f.ax[i] + lin.c_x * f.vx[i] + lin.k_x * d.x[i] - unbalance * std::cos(phase);
    f.fn[i] = -(lin.m * f.ay[i] + lin.c_y * f.vy[i] + lin.k_y * d.y[i] - unbalance * std::sin(phase));
    f.contact[i] = f.z[i] > 0.0 && std::isfinite(f.fx[i]) && std::isfinite(f.fn[i]);
  }
  return f;
}

friction_estimate estimate_friction(const dwell_forces& f) {
  double peak = 0.0;
  for (std::size_t i = 0; i < f.fn.size(); ++i)
    if (f.contact[i]) peak = std::max(peak, f.fn[i]);
  std::vector<double> ratio;
  double fxfn = 0.0, fnfn = 0.0;
  for (std::size_t i = 0; i < f.fn.size(); ++i) {
    if (!f.contact[i] || f.fn[i] < kFrictionForceShare * peak || !(f.fn[i] > 0.0)) continue;
    ratio.push_back(f.fx[i] / f.fn[i]);
    fxfn += f.fx[i] * f.fn[i];
    fnfn += f.fn[i] * f.fn[i];
  }
  friction_estimate e{f.source->rpm, ratio.size(), 0.0, 0.0, 0.0, 0.0};
  if (ratio.empty()) return e;
  for (double r : ratio) e.mean += r / ratio.size();
  for (double r : ratio) e.std_dev += (r - e.mean) * (r - e.mean);
  e.std_dev = ratio.size() > 1 ? std::sqrt(e.std_dev / (ratio.size() - 1)) : 0.0;
  std::nth_element(ratio.begin(), ratio.begin() + ratio.size() / 2, ratio.end());
  e.median = ratio[ratio.size() / 2];
  e.slope = fxfn / fnfn;
  return e;
}

std::string_view to_string(linear_method m) { return m == linear_method::harmonic ? "harmonic" : "equation-error"; }

linear_method parse_linear_method(const std::string& name) {
  if (name == "harmonic") return linear_method::harmonic;
  if (name == "equation-error") return linear_method::equation_error;
  throw input_error("unknown linear-part method '" + name + "' (harmonic, equation-error)");
}

namespace {

// A row of the linear part's regression; unknowns c_x/m, k_x/m, c_y/m, k_y/m, p = e cos(phase),
// q = e sin(phase):
//   x'' + (c_x/m) x' + (k_x/m) x = w^2 (p cos wt - q sin wt)
//   y'' + (c_y/m) y' + (k_y/m) y = w^2 (p sin wt + q cos wt)
struct linear_rows {
  std::vector<std::array<double, 6>> rows;
  std::vector<double> rhs;
  void add(const std::array<double, 6>& row, double r) { rows.push_back(row), rhs.push_back(r); }
};

// Eq. 1 at every sample, with Savitzky-Golay derivatives.
void equation_error_rows(const dwell& d, const derivative_settings& ds, linear_rows& out) {
  const derivatives dx = differentiate(d.x, d.dt, ds), dy = differentiate(d.y, d.dt, ds);
  const double w = d.omega(), w2 = w * w;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const double c = std::cos(w * d.t[i]), s = std::sin(w * d.t[i]);
    out.add({dx.d1[i], d.x[i], 0.0, 0.0, -w2 * c, w2 * s}, -dx.d2[i]);
    out.add({0.0, 0.0, dy.d1[i], d.y[i], -w2 * s, -w2 * c}, -dy.d2[i]);
  }
}

// One dwell's mean and 1X by least squares: (a0, ac, as) for x and y, and the RMS beyond them.
struct one_x_fit {
  double ac, as, bc, bs, beyond;
};
one_x_fit fit_one_x(const dwell& d) {
  const double w = d.omega();
  const Eigen::Index n = static_cast<Eigen::Index>(d.size());
  Eigen::MatrixXd B(n, 3);
  Eigen::MatrixXd xy(n, 2);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t = d.t[static_cast<std::size_t>(i)];
    B(i, 0) = 1.0, B(i, 1) = std::cos(w * t), B(i, 2) = std::sin(w * t);
    xy(i, 0) = d.x[static_cast<std::size_t>(i)], xy(i, 1) = d.y[static_cast<std::size_t>(i)];
  }
  const Eigen::MatrixXd a = B.colPivHouseholderQr().solve(xy);  // columns: x, y; rows: mean, cos, sin
  return {a(1, 0), a(2, 0), a(1, 1), a(2, 1), std::sqrt((xy - B * a).squaredNorm() / static_cast<double>(2 * n))};
}

// The four 1X balance rows of one dwell; the forcing's columns at `forcing` (4, 5 for one shared
// unbalance; a dwell's own pair otherwise), each row scaled by `weight`.
void add_harmonic_rows(const dwell& d, const one_x_fit& f, std::size_t columns, std::size_t forcing, double weight_x, double weight_y,
                       std::vector<std::vector<double>>& rows, std::vector<double>& rhs) {
  const double w = d.omega(), w2 = w * w;
  const auto row = [&](std::initializer_list<std::pair<std::size_t, double>> entries, double r, double weight) {
    std::vector<double> v(columns, 0.0);
    for (const auto& [j, x] : entries) v[j] += weight * x;
    rows.push_back(std::move(v));
    rhs.push_back(weight * r);
  };
  row({{0, w * f.as}, {1, f.ac}, {forcing, -w2}}, w2 * f.ac, weight_x);
  row({{0, -w * f.ac}, {1, f.as}, {forcing + 1, w2}}, w2 * f.as, weight_x);
  row({{2, w * f.bs}, {3, f.bc}, {forcing + 1, -w2}}, w2 * f.bc, weight_y);
  row({{2, -w * f.bc}, {3, f.bs}, {forcing, -w2}}, w2 * f.bs, weight_y);
}

// Least squares on rows built by add_harmonic_rows: the solution and the residual sum of squares.
std::pair<Eigen::VectorXd, double> solve_rows(const std::vector<std::vector<double>>& rows, const std::vector<double>& rhs) {
  const auto n = static_cast<Eigen::Index>(rows.size()), p = static_cast<Eigen::Index>(rows.front().size());
  Eigen::MatrixXd P(n, p);
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < p; ++j) P(i, j) = rows[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
    y[i] = rhs[static_cast<std::size_t>(i)];
  }
  Eigen::VectorXd b = P.colPivHouseholderQr().solve(y);
  const double rss = (y - P * b).squaredNorm();
  return {std::move(b), rss};
}

// Eq. 1 balanced at 1X: with x = a0 + ac cos wt + as sin wt (a0 a probe offset or a static sag,
// which the stiffness carries and the balance ignores), x' = w (as cos - ac sin), x'' = -w^2 (x - a0):
//   cos: (c_x/m) w as + (k_x/m) ac - w^2 p = w^2 ac      sin: -(c_x/m) w ac + (k_x/m) as + w^2 q = w^2 as
//   cos: (c_y/m) w bs + (k_y/m) bc - w^2 q = w^2 bc      sin: -(c_y/m) w bc + (k_y/m) bs - w^2 p = w^2 bs
// Returns the RMS of the samples minus their mean and 1X.
double harmonic_rows(const dwell& d, linear_rows& out) {
  const one_x_fit f = fit_one_x(d);
  std::vector<std::vector<double>> rows;
  std::vector<double> rhs;
  add_harmonic_rows(d, f, 6, 4, 1.0, 1.0, rows, rhs);
  for (std::size_t i = 0; i < rows.size(); ++i) out.add({rows[i][0], rows[i][1], rows[i][2], rows[i][3], rows[i][4], rows[i][5]}, rhs[i]);
  return f.beyond;
}

// Below any probe's resolution: the noise of a noise-free record is taken as this, so that its
// settling remnants (~1e-12 m) are not read as a model error (identify's beyond-1X check too).
constexpr double kResolutionFloor = 1e-9;  // m

// The one-phase test (linear_fit::phase_chi2). Each row's noise is its 1X coefficients' (the
// dwell's content beyond 1X over sqrt(samples / 2)) times the dynamic stiffness / m that
// multiplies them, |k/m - w^2 + i w c/m|, at the fit's values.
void one_phase_test(const std::vector<const dwell*>& dwells, linear_fit& fit) {
  const std::size_t D = dwells.size();
  const double m = fit.value.m;
  std::vector<std::vector<double>> shared_rows, own_rows;
  std::vector<double> shared_rhs, own_rhs;
  for (std::size_t k = 0; k < D; ++k) {
    const dwell& d = *dwells[k];
    const one_x_fit f = fit_one_x(d);
    const double w = d.omega();
    const double sc = std::max(f.beyond, kResolutionFloor) * std::sqrt(2.0 / static_cast<double>(d.size()));
    const double gx = std::hypot(fit.value.k_x / m - w * w, w * fit.value.c_x / m), gy = std::hypot(fit.value.k_y / m - w * w, w * fit.value.c_y / m);
    add_harmonic_rows(d, f, 6, 4, 1.0 / (sc * gx), 1.0 / (sc * gy), shared_rows, shared_rhs);
    add_harmonic_rows(d, f, 4 + 2 * D, 4 + 2 * k, 1.0 / (sc * gx), 1.0 / (sc * gy), own_rows, own_rhs);
  }
  fit.phase_dof = static_cast<int>(2 * (D - 1));
  fit.phase_chi2 = std::max(0.0, solve_rows(shared_rows, shared_rhs).second - solve_rows(own_rows, own_rhs).second);
  fit.phase_limit = boost::math::quantile(boost::math::chi_squared(static_cast<double>(fit.phase_dof)), 0.999);
}

}  // namespace

linear_fit fit_linear_part(const std::vector<const dwell*>& no_contact, double m, const derivative_settings& ds,
                           linear_method method) {
  std::set<double> speeds;
  for (const auto* d : no_contact) speeds.insert(d->rpm);
  if (speeds.size() < 2)
    throw input_error("the linear part needs dwells without contact at 2 or more speeds (found " + std::to_string(speeds.size()) +
                      "); give it as " + setting("linear") + " instead");
  linear_fit out;
  out.method = method;
  linear_rows lr;
  for (const auto* d : no_contact) {
    out.samples += d->size();
    if (method == linear_method::harmonic) {
      out.beyond_1x_rms.push_back(harmonic_rows(*d, lr));
    } else {
      equation_error_rows(*d, ds, lr);
    }
  }
  Eigen::MatrixXd P(static_cast<Eigen::Index>(lr.rows.size()), 6);
  Eigen::VectorXd y(static_cast<Eigen::Index>(lr.rows.size()));
  for (std::size_t i = 0; i < lr.rows.size(); ++i) {
    for (int j = 0; j < 6; ++j) P(static_cast<Eigen::Index>(i), j) = lr.rows[i][static_cast<std::size_t>(j)];
    y[static_cast<Eigen::Index>(i)] = lr.rhs[i];
  }
  const least_squares_fit ls = least_squares(P, y, {0, 1, 2, 3, 4, 5});
  const auto& b = ls.coefficients;
  const auto& se = ls.standard_errors;
  out.value = {m, b[0] * m, b[2] * m, b[1] * m, b[3] * m, std::hypot(b[4], b[5]), std::atan2(b[5], b[4])};
  const double e = out.value.e;
  // First-order propagation to e and phase from p, q (covariance between them neglected).
  out.standard_error = {se[0] * m, se[2] * m, se[1] * m, se[3] * m,
                        e > 0 ? std::hypot(b[4] * se[4], b[5] * se[5]) / e : 0.0,
                        e > 0 ? std::hypot(b[5] * se[4], b[4] * se[5]) / (e * e) : 0.0};
  out.dwells = no_contact.size();
  out.residual_rms = std::sqrt(ls.residual.squaredNorm() / static_cast<double>(lr.rows.size()));
  if (method == linear_method::harmonic && no_contact.size() >= 2) one_phase_test(no_contact, out);
  return out;
}

namespace {
// The phase phi that brings a dwell's 1X, turned back by it, closest to the linear part's at w:
// x = Re(X e^{iwt}), X = ac - i as, and shifting t by phi / w turns X into X e^{-i phi}.
double best_phase(const one_x_fit& f, const linear_part& L, double w) {
  using cplx = std::complex<double>;
  const cplx force = L.m * L.e * w * w * std::polar(1.0, L.phase);
  const cplx gx = force / cplx(L.k_x - L.m * w * w, L.c_x * w), gy = cplx(0.0, -1.0) * force / cplx(L.k_y - L.m * w * w, L.c_y * w);
  const cplx X(f.ac, -f.as), Y(f.bc, -f.bs);
  return std::arg(std::conj(gx) * X + std::conj(gy) * Y);
}
}  // namespace

double one_x_shift(const dwell& d, const linear_part& lin) { return best_phase(fit_one_x(d), lin, d.omega()) / d.omega(); }

std::vector<double> shaft_angle_shifts(const std::vector<const dwell*>& no_contact, double m) {
  const std::size_t D = no_contact.size();
  std::vector<one_x_fit> fits;
  for (const auto* d : no_contact) fits.push_back(fit_one_x(*d));
  // Start: the phases of a fit with every dwell's own forcing (p_d, q_d): 4 + 2D linear unknowns.
  std::vector<double> phase(D, 0.0);
  {
    std::vector<std::vector<double>> rows;
    std::vector<double> rhs;
    for (std::size_t k = 0; k < D; ++k) add_harmonic_rows(*no_contact[k], fits[k], 4 + 2 * D, 4 + 2 * k, 1.0, 1.0, rows, rhs);
    const Eigen::VectorXd b = solve_rows(rows, rhs).first;
    for (std::size_t k = 0; k < D; ++k) phase[k] = std::atan2(b[static_cast<Eigen::Index>(5 + 2 * k)], b[static_cast<Eigen::Index>(4 + 2 * k)]);
  }
  std::vector<double> shift(D, 0.0);
  for (int iteration = 0; iteration < 50; ++iteration) {
    std::vector<dwell> shifted;
    for (std::size_t k = 0; k < D; ++k) {
      dwell c = *no_contact[k];
      shift[k] = phase[k] / c.omega();
      for (double& t : c.t) t += shift[k];
      shifted.push_back(std::move(c));
    }
    std::vector<const dwell*> view;
    for (const auto& c : shifted) view.push_back(&c);
    linear_fit f = fit_linear_part(view, m, {}, linear_method::harmonic);
    double moved = 0.0;
    for (std::size_t k = 0; k < D; ++k) {
      const double best = best_phase(fits[k], f.value, no_contact[k]->omega());
      moved = std::max(moved, std::abs(std::remainder(best - phase[k], 2.0 * std::numbers::pi)));
      phase[k] = best;
    }
    if (moved < 1e-9) break;
  }
  // A phase common to every dwell is the unbalance's own: taken out (circular mean), so that
  // dwells on a keyphasor keep its angle up to their timing error.
  std::complex<double> sum = 0.0;
  for (const double p : phase) sum += std::polar(1.0, p);
  const double common = std::arg(sum);
  for (std::size_t k = 0; k < D; ++k) shift[k] = std::remainder(phase[k] - common, 2.0 * std::numbers::pi) / no_contact[k]->omega();
  return shift;
}

}  // namespace rubref
