#include "ref/loop/residuals.hpp"

#include "ref/inference/evidence.hpp"

#include <cmath>
#include <limits>

namespace rubref {

namespace {
// Two-sided 0.1 % point of the standard normal: the validity checks' false-alarm rate.
constexpr double kZ = 3.29;
// The noise estimate (MAD of 4th differences, ~1e5 samples) is good to about 1 %; a residual
// more than 5 % above it carries 10 % more energy than noise does.
constexpr double kNoiseRatioLimit = 1.05;
// The synchronous check's limit on chi^2 / dof above 1: its 0.1 % false-alarm band, and the
// noise estimate's own error (a ratio good to kNoiseRatioLimit - 1 in RMS, twice that in energy).
double synchronous_margin(double dof) { return kZ * std::sqrt(2.0 / dof) + 2.0 * (kNoiseRatioLimit - 1.0); }
}  // namespace

double synchronous_energy::tolerance(double noise) const { return synchronous_margin(dof) * dof * noise * noise; }

error_totals errors_of(const std::vector<loop_dwell>& dwells, const orbit_predictor& pr, const Eigen::VectorXd& r) {
  error_totals out;
  double res_c = 0.0, sig_c = 0.0;
  for (std::size_t k = 0; k < dwells.size(); ++k) {
    const dwell& d = dwells[k].data;
    const auto at = static_cast<Eigen::Index>(pr.offset(k));
    const auto n = static_cast<Eigen::Index>(2 * d.size());
    const double res = r.segment(at, n).squaredNorm();
    double mx = 0.0, my = 0.0;
    for (std::size_t i = 0; i < d.size(); ++i) mx += d.x[i] / d.size(), my += d.y[i] / d.size();
    double sig = 0.0;
    for (std::size_t i = 0; i < d.size(); ++i) sig += std::pow(d.x[i] - mx, 2) + std::pow(d.y[i] - my, 2);
    out.rms.push_back(std::sqrt(res / static_cast<double>(n)));
    out.nrmse.push_back(std::sqrt(res / sig));
    if (dwells[k].contact) res_c += res, sig_c += sig;
  }
  out.nrmse_contact = sig_c > 0.0 ? std::sqrt(res_c / sig_c) : 0.0;
  return out;
}

// Shaft-order coefficients c_k = mean(z e^{-i k psi}) of the complex residual z = r_x + i r_y, with
// psi = w t / periods (orders of the motion's own frequency). The powers of e^{-i psi} are taken by
// products: one sine and cosine per sample instead of one per order.
std::vector<std::complex<double>> order_coefficients(const dwell& d, const Eigen::VectorXd& r, std::size_t at, double shift,
                                                     int orders, int periods) {
  std::vector<std::complex<double>> c(static_cast<std::size_t>(2 * orders + 1));
  const double w = d.omega() / periods;
  const auto mid = static_cast<std::size_t>(orders);
  for (std::size_t i = 0; i < d.size(); ++i) {
    const std::complex<double> z(r[static_cast<Eigen::Index>(at + 2 * i)], r[static_cast<Eigen::Index>(at + 2 * i + 1)]);
    const std::complex<double> step = std::polar(1.0, -w * (d.t[i] + shift));
    std::complex<double> up = z, down = z;  // z e^{-i k psi} for k = +j and -j
    c[mid] += z;
    for (std::size_t j = 1; j <= mid; ++j) {
      up *= step;
      down *= std::conj(step);
      c[mid + j] += up;
      c[mid - j] += down;
    }
  }
  for (auto& v : c) v /= static_cast<double>(d.size());
  return c;
}

synchronous_energy synchronous_part(const std::vector<loop_dwell>& dwells, const orbit_predictor& pr, const model_point& m,
                                    const Eigen::VectorXd& r, int orders) {
  synchronous_energy out;
  for (std::size_t k = 0; k < dwells.size(); ++k) {
    // A period-n dwell's synchronous part: the orders of its own frequency w / n up to the same shaft order.
    const dwell& d = dwells[k].data;
    const int n = dwells[k].periods, own = orders * n;
    for (const auto& ck : order_coefficients(d, r, pr.offset(k), m.shift[k], own, n)) out.energy += static_cast<double>(d.size()) * std::norm(ck);
    out.dof += 2.0 * (2.0 * own + 1.0);
  }
  return out;
}

double residual_error_of(const Eigen::VectorXd& r, double cost_uncertainty) {
  if (cost_uncertainty == 0.0) return 0.0;
  if (!(cost_uncertainty > 0.0 && cost_uncertainty < std::numeric_limits<double>::infinity())) return std::numeric_limits<double>::infinity();
  const double n = r.norm();
  return cost_uncertainty / (std::sqrt(n * n + cost_uncertainty) + n);  // sqrt(n^2 + u) - n without cancellation
}

namespace {

// A check passes at value <= limit; decided on the value, on the margin within its uncertainty.
void judge(correlation_check& c) {
  const decision fails = exceeds({c.value, c.uncertainty}, c.limit);
  c.pass = !fails.yes;
  c.on_margin = fails.on_margin;
}

}  // namespace

validity_report validity(const std::vector<loop_dwell>& dwells, const orbit_predictor& pr, const model_point& m, const Eigen::VectorXd& r,
                         double noise, int orders, int whiteness_lags, double residual_error) {
  // Each check's uncertainty is its change under a residual error of norm e = residual_error,
  // wherever the error lies (Cauchy-Schwarz): exact for the RMS, to first order for the others and
  // doubled for what the first order leaves out (they are smooth in r, and e is far below |r|
  // wherever a margin matters).
  const double e = std::max(residual_error, 0.0);
  validity_report v;
  v.noise = noise;
  const auto N = static_cast<double>(pr.orbit_rows());
  v.rms = std::sqrt(r.head(static_cast<Eigen::Index>(pr.orbit_rows())).squaredNorm() / N);
  v.noise_level = {"residual RMS / noise", noise > 0.0 ? v.rms / noise : std::numeric_limits<double>::infinity(), kNoiseRatioLimit, false};
  v.noise_level.uncertainty = noise > 0.0 ? e / std::sqrt(N) / noise : 0.0;  // RMS is 1/sqrt(N)-Lipschitz in r
  judge(v.noise_level);

  // Synchronous part: under noise alone its chi^2 / dof is 1.
  const synchronous_energy sync = synchronous_part(dwells, pr, m, r, orders);
  const double chi2 = sync.energy / (noise * noise), dof = sync.dof;
  // Q's change under an error of norm e: to first order |grad Q| e, grad Q stacking each channel's
  // sum_l 2 n rho_l grad rho_l with grad rho_l = (x shifted by +l and -l - 2 rho_l x) / c_0 (the
  // mean's removal only shrinks an error); the second order, sum_l n |d rho_l|^2 with
  // |d rho_l| <= (2 + 2 |rho_l|) e_c / |x|, at most max_c B_c e^2 (sum e_c^2 <= e^2).
  double q = 0.0, qdof = 0.0, grad2 = 0.0, b_max = 0.0;
  for (std::size_t k = 0; k < dwells.size(); ++k) {
    const dwell& d = dwells[k].data;
    // Whiteness: Box-Pierce on each probe's residual in time order.
    for (int ch = 0; ch < 2; ++ch) {
      std::vector<double> x(d.size());
      double mean = 0.0;
      for (std::size_t i = 0; i < d.size(); ++i) mean += (x[i] = r[static_cast<Eigen::Index>(pr.offset(k) + 2 * i + ch)]) / d.size();
      double c0 = 0.0;
      for (auto& xi : x) {
        xi -= mean;
        c0 += xi * xi;
      }
      const double n = static_cast<double>(x.size());
      std::vector<double> grad(x.size(), 0.0);
      double b = 0.0;  // this channel's B_c
      for (int lag = 1; lag <= whiteness_lags; ++lag) {
        const auto l = static_cast<std::size_t>(lag);
        double cl = 0.0;
        for (std::size_t i = l; i < x.size(); ++i) cl += x[i] * x[i - l];
        const double rho = cl / c0;
        q += n * rho * rho;
        if (!(c0 > 0.0 && e > 0.0)) continue;  // (no error: no uncertainty to compute)
        const double w = 2.0 * n * rho / c0;
        for (std::size_t i = 0; i < x.size(); ++i) {
          double g = -2.0 * rho * x[i];
          if (i + l < x.size()) g += x[i + l];
          if (i >= l) g += x[i - l];
          grad[i] += w * g;
        }
        const double gr = 2.0 + 2.0 * std::abs(rho);
        b += n * gr * gr / c0;
      }
      for (const double g : grad) grad2 += g * g;
      b_max = std::max(b_max, b);
      qdof += whiteness_lags;
    }
  }
  v.synchronous = {"synchronous chi^2 / dof (orders -" + std::to_string(orders) + ".." + std::to_string(orders) + ")", chi2 / dof,
                   1.0 + synchronous_margin(dof), false};
  // The energy is the residual's part on the orders (near-orthogonal over whole revolutions): it
  // moves by at most 2 sqrt(E) e + e^2.
  v.synchronous.uncertainty = noise > 0.0 ? 2.0 * (2.0 * std::sqrt(sync.energy) * e + e * e) / (noise * noise * dof) : 0.0;
  judge(v.synchronous);
  v.whiteness = {"Box-Pierce Q / dof (lags 1.." + std::to_string(whiteness_lags) + ")", q / qdof, 1.0 + kZ * std::sqrt(2.0 / qdof), false};
  v.whiteness.uncertainty = 2.0 * (std::sqrt(grad2) * e + b_max * e * e) / qdof;
  judge(v.whiteness);

  // Dependence on the state: correlation of the residual along the contact normal (y) and across
  // it (x) with the model's penetration, its rate in contact, x, and the shaft angle.
  std::vector<std::vector<double>> series(5);
  std::vector<double> ey, ex;
  for (std::size_t k = 0; k < dwells.size(); ++k) {
    const dwell& d = dwells[k].data;
    const auto& st = pr.states(k);
    if (st.size() != d.size()) continue;
    for (std::size_t i = 0; i < d.size(); ++i) {
      const double z = st[i][idx::y] - d.clearance, psi = d.omega() * (d.t[i] + m.shift[k]);
      series[0].push_back(std::max(z, 0.0));
      series[1].push_back(z > 0.0 ? st[i][idx::vy] : 0.0);
      series[2].push_back(st[i][idx::x]);
      series[3].push_back(std::cos(psi));
      series[4].push_back(std::sin(psi));
      ex.push_back(r[static_cast<Eigen::Index>(pr.offset(k) + 2 * i)]);
      ey.push_back(r[static_cast<Eigen::Index>(pr.offset(k) + 2 * i + 1)]);
    }
  }
  // The correlation with the residual b and the spread of b about its mean (|dc| <= e / spread to first order).
  const auto corr = [](const std::vector<double>& a, const std::vector<double>& b) -> std::pair<double, double> {
    const double n = static_cast<double>(a.size());
    double ma = 0, mb = 0;
    for (std::size_t i = 0; i < a.size(); ++i) ma += a[i] / n, mb += b[i] / n;
    double sab = 0, saa = 0, sbb = 0;
    for (std::size_t i = 0; i < a.size(); ++i) sab += (a[i] - ma) * (b[i] - mb), saa += (a[i] - ma) * (a[i] - ma), sbb += (b[i] - mb) * (b[i] - mb);
    return {saa > 0.0 && sbb > 0.0 ? sab / std::sqrt(saa * sbb) : 0.0, std::sqrt(sbb)};
  };
  const char* names[] = {"z+", "z_dot in contact", "x", "cos(shaft angle)", "sin(shaft angle)"};
  const double band = ex.empty() ? 0.0 : kZ / std::sqrt(static_cast<double>(ex.size()));
  for (int j = 0; j < 5; ++j)
    for (int ch = 0; ch < 2; ++ch) {
      const auto& a = series[static_cast<std::size_t>(j)];
      const auto [c, spread] = a.empty() ? std::pair{0.0, 0.0} : corr(a, ch ? ey : ex);
      correlation_check check{std::string(ch ? "e_y" : "e_x") + " vs " + names[j], std::abs(c), band, false};
      check.uncertainty = spread > 0.0 ? 2.0 * e / spread : 0.0;
      judge(check);
      check.value = c;  // reported signed; judged by its size
      v.state.push_back(check);
    }
  decision passes{true, false};
  for (const correlation_check* c : {&v.noise_level, &v.synchronous, &v.whiteness}) passes = both(passes, {c->pass, c->on_margin});
  for (const auto& c : v.state) passes = both(passes, {c.pass, c.on_margin});
  v.pass = passes.yes;
  v.on_margin = passes.on_margin;
  return v;
}

// ERR of the columns S (after removing what J already spans) on the residual r.
double err_score(const Eigen::MatrixXd& J, const Eigen::MatrixXd& S, const Eigen::VectorXd& r, double outside) {
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qj(J);
  Eigen::MatrixXd Q = qj.householderQ() * Eigen::MatrixXd::Identity(J.rows(), qj.rank());
  const Eigen::VectorXd rp = r - Q * (Q.transpose() * r);
  const Eigen::MatrixXd Sp = S - Q * (Q.transpose() * S);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qs(Sp);
  qs.setThreshold(1e-10);
  if (qs.rank() == 0 || rp.squaredNorm() + outside == 0.0) return 0.0;
  const Eigen::MatrixXd Qs = qs.householderQ() * Eigen::MatrixXd::Identity(Sp.rows(), qs.rank());
  return (Qs.transpose() * rp).squaredNorm() / (rp.squaredNorm() + outside);
}

}  // namespace rubref
