#include "ref/loop/loop.hpp"

#include <Eigen/Dense>
#include <unsupported/Eigen/LevenbergMarquardt>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>

#include "ref/errors.hpp"
#include "ref/identification/identify.hpp"
#include "ref/parameter_io.hpp"
#include "ref/rig/rig_system.hpp"

namespace rubref {

namespace {
std::string str(double v) {
  std::ostringstream o;
  o.precision(4);
  o << v;
  return o.str();
}

}  // namespace

// Probe noise from the data: 4th differences remove the orbit (its 4th difference at 10 kHz is
// ~1e-10 m) and leave noise with variance 70 sigma^2; the median absolute value ignores impacts.
double estimate_noise(const std::vector<loop_dwell>& dwells) {
  std::vector<double> a;
  for (const auto& ld : dwells)
    for (const auto* v : {&ld.data.x, &ld.data.y})
      for (std::size_t i = 4; i < v->size(); ++i)
        a.push_back(std::abs((*v)[i] - 4 * (*v)[i - 1] + 6 * (*v)[i - 2] - 4 * (*v)[i - 3] + (*v)[i - 4]));
  if (a.empty()) return 0.0;
  std::nth_element(a.begin(), a.begin() + static_cast<std::ptrdiff_t>(a.size() / 2), a.end());
  return 1.4826 * a[a.size() / 2] / std::sqrt(70.0);
}

// Re-bases a dwell's times on its keyphasor: the notch passes between the sample before a pulse
// and the pulse, so every pulse brackets the passage time to one sample; revolutions apart, the
// brackets of all pulses intersect in a much narrower one.
void align_by_keyphasor(loop_dwell& ld, std::vector<std::string>& notes) {
  dwell& d = ld.data;
  if (d.keyphasor.empty()) return;
  const double period = 60.0 / d.rpm;
  std::vector<std::size_t> pulses;
  for (std::size_t i = 1; i < d.size(); ++i)
    if (d.keyphasor[i] > 0.5 && !(d.keyphasor[i - 1] > 0.5)) pulses.push_back(i);
  if (pulses.empty()) {
    notes.push_back(d.source + ": no keyphasor pulse; times taken as recorded");
    return;
  }
  const double first = d.t[pulses.front()];
  double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity(), mean = 0.0;
  // Closed brackets, widened by a hair: with a sample rate that is a whole multiple of the speed
  // the notch can pass exactly at a sample, and rounding puts that pulse on either side of it.
  const double hair = 1e-6 * d.dt;
  for (const std::size_t i : pulses) {
    const double revs = std::round((d.t[i] - first) / period);
    const double t = d.t[i] - revs * period;
    lo = std::max(lo, t - d.dt - hair);
    hi = std::min(hi, t + hair);
    mean += t / static_cast<double>(pulses.size());
  }
  double t0 = 0.5 * (lo + hi), width = hi - lo;
  if (!(hi > lo)) {  // the brackets disagree: the speed is not what the record states
    notes.push_back(d.source + ": keyphasor pulses are not one revolution of " + str(d.rpm) + " rpm apart");
    t0 = mean - 0.5 * d.dt;
    width = d.dt;
  }
  for (double& t : d.t) t -= t0;
  ld.timing_sigma = width / std::sqrt(12.0);  // uniform within the bracket
}

// The linear part from the dwells without contact, by harmonic balance on their 1X components
// (steady response of Eq. 1 without contact): with X, Y the 1X phasors of x and y and
// E = e exp(i phase),
//   (k_x - m w^2 + i c_x w) X = m w^2 E,   (k_y - m w^2 + i c_y w) Y = -i m w^2 E,
// linear in (k_x, c_x, k_y, c_y, Re E, Im E). The 1X phasor averages every revolution, so noise
// barely enters; it needs two speeds or more.
parameters fit_linear_harmonic(const std::vector<loop_dwell>& dwells, double mass) {
  std::vector<const loop_dwell*> free;
  for (const auto& d : dwells)
    if (!d.contact) free.push_back(&d);
  std::vector<double> speeds;
  for (const auto* d : free) speeds.push_back(d->data.rpm);
  std::sort(speeds.begin(), speeds.end());
  if (std::unique(speeds.begin(), speeds.end()) - speeds.begin() < 2)
    throw input_error("the loop fits the linear part on dwells without contact and needs them at two speeds or more (found " +
                      std::to_string(speeds.end() - speeds.begin() > 0 ? std::unique(speeds.begin(), speeds.end()) - speeds.begin() : 0) + ")");
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(4 * static_cast<Eigen::Index>(free.size()), 6);
  Eigen::VectorXd b(A.rows());
  Eigen::Index row = 0;
  for (const auto* ld : free) {
    const dwell& d = ld->data;
    const double w = d.omega(), mw2 = mass * w * w;
    std::complex<double> X, Y;
    double mx = 0.0, my = 0.0;
    for (std::size_t i = 0; i < d.size(); ++i) mx += d.x[i] / d.size(), my += d.y[i] / d.size();
    for (std::size_t i = 0; i < d.size(); ++i) {
      const auto e = std::polar(2.0 / static_cast<double>(d.size()), -w * d.t[i]);
      X += (d.x[i] - mx) * e;
      Y += (d.y[i] - my) * e;
    }
    const std::complex<double> I(0.0, 1.0);
    // x: k_x X + c_x i w X - mw2 E = mw2 X ; y: k_y Y + c_y i w Y + i mw2 E = mw2 Y
    const std::complex<double> ax[6] = {X, I * w * X, 0.0, 0.0, -mw2, -mw2 * I};
    const std::complex<double> ay[6] = {0.0, 0.0, Y, I * w * Y, I * mw2, I * mw2 * I};
    for (int j = 0; j < 6; ++j) {
      A(row, j) = ax[j].real();
      A(row + 1, j) = ax[j].imag();
      A(row + 2, j) = ay[j].real();
      A(row + 3, j) = ay[j].imag();
    }
    b[row] = (mw2 * X).real();
    b[row + 1] = (mw2 * X).imag();
    b[row + 2] = (mw2 * Y).real();
    b[row + 3] = (mw2 * Y).imag();
    row += 4;
  }
  const Eigen::VectorXd v = A.colPivHouseholderQr().solve(b);
  parameters p;
  p.m = mass;
  p.k_x = v[0];
  p.c_x = v[1];
  p.k_y = v[2];
  p.c_y = v[3];
  p.e = std::hypot(v[4], v[5]);
  p.unbalance_phase = std::atan2(v[5], v[4]);
  return p;
}

// Contact shows in the orbit even where it is not at the top (contact_angle): impacts put
// orders |k| >= 3 into the orbit, which no effect without contact does (unbalance, bow and
// preload are orders 0 and 1, misalignment and runout order 2, and misorientation keeps orders).
// RMS per probe of what orders -2..2 leave of one averaged revolution.
double high_order_content(const dwell& cycle) {
  const std::size_t n = cycle.size();
  const double w = cycle.omega();
  std::vector<std::complex<double>> z(n);
  for (std::size_t i = 0; i < n; ++i) z[i] = {cycle.x[i], cycle.y[i]};
  std::vector<std::complex<double>> rest = z;
  for (int k = -2; k <= 2; ++k) {
    std::complex<double> c;
    for (std::size_t i = 0; i < n; ++i) c += z[i] * std::polar(1.0 / static_cast<double>(n), -k * w * cycle.t[i]);
    for (std::size_t i = 0; i < n; ++i) rest[i] -= c * std::polar(1.0, k * w * cycle.t[i]);
  }
  double sq = 0.0;
  for (const auto& v : rest) sq += std::norm(v);
  return std::sqrt(sq / (2.0 * static_cast<double>(n)));
}

namespace {

using json = nlohmann::ordered_json;

// Two-sided 0.1 % point of the standard normal: the validity checks' false-alarm rate.
constexpr double kZ = 3.29;
// The noise estimate (MAD of 4th differences, ~1e5 samples) is good to about 1 %; a residual
// more than 5 % above it carries 10 % more energy than noise does.
constexpr double kNoiseRatioLimit = 1.05;
// Relative finite-difference step of the fit's Jacobian, in scaled coordinates: orbit changes of
// ~1e-9..1e-7 m, far above the 1e-13 m integration error and small enough to stay linear.
constexpr double kStep = 1e-3;
// A candidate is refitted only if its linearised score reaches this share of the best one's:
// a far weaker linear signal rarely overtakes after the refit, and each refit costs a fit.
constexpr double kRefitScoreShare = 0.1;
// How often a round may hand over to a better base fit (each costs one refit and a rescoring).
constexpr int kMaxBaseRestarts = 2;
// Orders |k| >= 3 above this many times the averaged noise (sigma / sqrt(revolutions)) mean
// contact: noise alone stays below ~1.5x, the lightest contact the loop meets is ~100x.
constexpr double kContactDistortion = 5.0;
// Golden-section steps of an effect's profile between two trial values: the bracket shrinks to
// 0.618^10 < 1 % of its width, a start well inside the refit's reach.
constexpr int kProfileIterations = 10;

// ---- fitting --------------------------------------------------------------------------------

struct fit_problem {
  orbit_predictor* predictor;
  std::vector<fit_coordinate> coords;  // model coordinates (shifts follow them in u)
  std::vector<std::size_t> shifted;    // dwells whose shift is fitted
  model_point base;
  std::vector<double> shift_scale;     // s, per fitted dwell

  Eigen::Index size() const { return static_cast<Eigen::Index>(coords.size() + shifted.size()); }
  model_point at(const Eigen::VectorXd& u) const {
    model_point m = base;
    for (std::size_t j = 0; j < coords.size(); ++j) coords[j].set(m, u[static_cast<Eigen::Index>(j)] * coords[j].scale);
    for (std::size_t j = 0; j < shifted.size(); ++j)
      m.shift[shifted[j]] = u[static_cast<Eigen::Index>(coords.size() + j)] * shift_scale[j];
    return m;
  }
  Eigen::VectorXd of(const model_point& m) const {
    Eigen::VectorXd u(size());
    for (std::size_t j = 0; j < coords.size(); ++j) u[static_cast<Eigen::Index>(j)] = coords[j].get(m) / coords[j].scale;
    for (std::size_t j = 0; j < shifted.size(); ++j) u[static_cast<Eigen::Index>(coords.size() + j)] = m.shift[shifted[j]] / shift_scale[j];
    return u;
  }
  // The Jacobian in u: model coordinates by forward differences, shifts analytically.
  Eigen::MatrixXd jacobian(const Eigen::VectorXd& u, const Eigen::VectorXd& r0) const {
    Eigen::MatrixXd J(r0.size(), size());
    for (std::size_t j = 0; j < coords.size(); ++j) {
      Eigen::VectorXd v = u;
      v[static_cast<Eigen::Index>(j)] += kStep;
      J.col(static_cast<Eigen::Index>(j)) = (predictor->residuals(at(v)) - r0) / kStep;
    }
    if (!shifted.empty()) {
      const model_point m = at(u);
      predictor->residuals(m);  // the states at u for the analytic columns
      const Eigen::MatrixXd S = predictor->shift_columns(m);
      for (std::size_t j = 0; j < shifted.size(); ++j)
        J.col(static_cast<Eigen::Index>(coords.size() + j)) = S.col(static_cast<Eigen::Index>(shifted[j])) * shift_scale[j];
    }
    return J;
  }
};

struct lm_functor : Eigen::DenseFunctor<double> {
  const fit_problem* problem;
  lm_functor(const fit_problem& p, int values) : Eigen::DenseFunctor<double>(static_cast<int>(p.size()), values), problem(&p) {}
  int operator()(const InputType& u, ValueType& f) const {
    f = problem->predictor->residuals(problem->at(u));
    return 0;
  }
  int df(const InputType& u, JacobianType& J) const {
    const Eigen::VectorXd r0 = problem->predictor->residuals(problem->at(u));
    J = problem->jacobian(u, r0);
    return 0;
  }
};

// Levenberg-Marquardt (Eigen's MINPACK port) from the problem's base point.
model_point fit(const fit_problem& problem, const Eigen::VectorXd& start, int max_evaluations) {
  problem.predictor->anchor(problem.at(start));
  Eigen::VectorXd u = start;
  lm_functor f(problem, static_cast<int>(problem.predictor->rows()));
  Eigen::LevenbergMarquardt<lm_functor> lm(f);
  lm.setMaxfev(max_evaluations);
  lm.setXtol(1e-12);
  lm.setFtol(1e-12);
  lm.minimize(u);
  return problem.at(u);
}

fit_problem make_problem(orbit_predictor& predictor, const std::vector<loop_dwell>& dwells, const model_point& base,
                         std::vector<fit_coordinate> coords) {
  fit_problem p{&predictor, std::move(coords), {}, base, {}};
  for (std::size_t k = 0; k < dwells.size(); ++k)
    if (std::isfinite(dwells[k].timing_sigma)) {
      p.shifted.push_back(k);
      p.shift_scale.push_back(std::max(dwells[k].timing_sigma, 1e-9));
    }
  return p;
}

// A dip search's hops (fit_coordinate::dip_search): the hops at most, and the share of the
// residual a hop must land below. From a fit in a wrong dip, the right one was the lowest of its
// scan's other dips in every hop docs/loop.md measures, so one dip is refitted per hop (each
// refit is a fit of every coordinate); the stator's dips differ by factors of 1.5-3.5, and a
// hop that gains less than 10 % follows a slope the fit already descends, not a comb.
constexpr int kSearchHops = 4;
constexpr double kHopGain = 0.9;
// Evaluations of the fit of the profiled coordinates at each envelope value: a few coordinates
// and the shifts, from the staged model.
constexpr int kEnvelopeEvaluations = 20;
// A dip within this relative distance of the fit's value is the fit's own.
constexpr double kOwnDip = 0.02;

// The coordinate of an effect that has a dip search, or end(): such an effect is refitted by it.
std::vector<fit_coordinate>::const_iterator dip_searched(const std::vector<fit_coordinate>& ec) {
  return std::find_if(ec.begin(), ec.end(), [](const fit_coordinate& q) { return q.search.has_value(); });
}

// The refit of an effect whose coordinate `j` of `problem` (its base: the current model, the
// effect off, leaving `base_rss`) has a dip search: the envelope on the staged model, a fit from
// its best value, then hops between dips while a refit lands lower. Returns the lowest fit.
model_point search_dips(const fit_problem& problem, std::size_t j, double base_rss, const model_point& staged,
                        const std::vector<loop_dwell>& dwells, int max_evaluations,
                        const std::function<void(const std::string&)>& progress) {
  const fit_coordinate& coordinate = problem.coords[j];
  const auto& search = *coordinate.search;
  orbit_predictor& predictor = *problem.predictor;
  const auto rss_at = [&](const model_point& m) {  // on its own orbits, as every refit is judged
    predictor.anchor(m);
    return predictor.residuals(m).squaredNorm();
  };
  // The envelope on the staged model (the linear part from the dwells without contact, which the
  // effect does not reach; a fit without the effect has bent it towards the contacts).
  std::vector<fit_coordinate> profiled;
  for (const auto& name : search.profiled)
    for (const auto& c : problem.coords)
      if (c.name == name) profiled.push_back(c);
  model_point start = problem.base;
  double start_rss = std::numeric_limits<double>::infinity(), start_value = 0.0;
  for (const double value : search.envelope) {
    model_point m = problem.base;
    m.p = staged.p;
    coordinate.set(m, value);
    const fit_problem inner = make_problem(predictor, dwells, m, profiled);
    m = fit(inner, inner.of(m), kEnvelopeEvaluations);
    if (const double rss = rss_at(m); rss < start_rss) start = m, start_rss = rss, start_value = value;
  }
  model_point at = fit(problem, problem.of(start), max_evaluations);
  double at_rss = rss_at(at);
  progress("      " + coordinate.name + ": envelope best " + str(start_value) + ", fitted " + str(coordinate.get(at)) + " (residual " +
           str(at_rss) + " m^2, without the effect " + str(base_rss) + ")");
  // Hops refine a fit that explains more than the model without the effect; one that explains
  // less sits in no dip worth refining.
  if (!(at_rss < base_rss)) return at;
  const int steps = static_cast<int>(std::log(search.factor) / search.step);
  for (int hop = 0; hop < kSearchHops; ++hop) {
    predictor.anchor(at);
    const double value = coordinate.get(at);
    std::vector<std::pair<double, double>> scan;  // (value, residual)
    for (int i = -steps; i <= steps; ++i) {
      model_point q = at;
      const double v = value * std::exp(i * search.step);
      if (search.move(q, v)) scan.emplace_back(v, predictor.residuals(q).squaredNorm());
    }
    std::vector<std::pair<double, double>> dips;  // (residual, value), lowest first
    for (std::size_t i = 1; i + 1 < scan.size(); ++i)
      if (scan[i].second < scan[i - 1].second && scan[i].second < scan[i + 1].second && std::abs(std::log(scan[i].first / value)) > kOwnDip)
        dips.emplace_back(scan[i].second, scan[i].first);
    std::sort(dips.begin(), dips.end());
    if (dips.empty()) break;
    model_point q = at;
    search.move(q, dips.front().second);
    const model_point next = fit(problem, problem.of(q), max_evaluations);
    const double next_rss = rss_at(next);
    if (!(next_rss < kHopGain * at_rss)) break;
    at = next;
    at_rss = next_rss;
    progress("      " + coordinate.name + ": hop " + std::to_string(hop + 1) + " to " + str(coordinate.get(at)) + " (residual " + str(at_rss) + " m^2)");
  }
  return at;
}

// An effect at its profile's best value (the trace's trial grid): on the current point, with the
// base coordinates' linear correction (u of the base problem), and on the staged model.
struct trial_point {
  model_point at;
  Eigen::VectorXd corrected;
  model_point staged;
};

// ---- residual analysis ------------------------------------------------------------------------

struct error_totals {
  double nrmse_contact = 0.0;
  std::vector<double> rms, nrmse;  // per dwell
};

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

// Shaft-order coefficients c_k = mean(z e^{-i k psi}) of the complex residual z = r_x + i r_y.
std::vector<std::complex<double>> order_coefficients(const dwell& d, const Eigen::VectorXd& r, std::size_t at, double shift,
                                                     int orders) {
  std::vector<std::complex<double>> c(static_cast<std::size_t>(2 * orders + 1));
  const double w = d.omega();
  for (std::size_t i = 0; i < d.size(); ++i) {
    const std::complex<double> z(r[static_cast<Eigen::Index>(at + 2 * i)], r[static_cast<Eigen::Index>(at + 2 * i + 1)]);
    const double psi = w * (d.t[i] + shift);
    for (int k = -orders; k <= orders; ++k) c[static_cast<std::size_t>(k + orders)] += z * std::polar(1.0, -k * psi);
  }
  for (auto& v : c) v /= static_cast<double>(d.size());
  return c;
}

validity_report validity(const std::vector<loop_dwell>& dwells, const orbit_predictor& pr, const model_point& m,
                         const Eigen::VectorXd& r, double noise, const loop_settings& s) {
  validity_report v;
  v.noise = noise;
  const auto N = static_cast<double>(pr.orbit_rows());
  v.rms = std::sqrt(r.head(static_cast<Eigen::Index>(pr.orbit_rows())).squaredNorm() / N);
  v.noise_level = {"residual RMS / noise", noise > 0.0 ? v.rms / noise : std::numeric_limits<double>::infinity(), kNoiseRatioLimit, false};
  v.noise_level.pass = v.noise_level.value <= v.noise_level.limit;

  // Synchronous part: under noise alone its chi^2 / dof is 1.
  const synchronous_energy sync = synchronous_part(dwells, pr, m, r, s.orders);
  const double chi2 = sync.energy / (noise * noise), dof = sync.dof;
  double q = 0.0, qdof = 0.0;
  for (std::size_t k = 0; k < dwells.size(); ++k) {
    const dwell& d = dwells[k].data;
    // Whiteness: Box-Pierce on each probe's residual in time order.
    for (int ch = 0; ch < 2; ++ch) {
      std::vector<double> e(d.size());
      double mean = 0.0;
      for (std::size_t i = 0; i < d.size(); ++i) mean += (e[i] = r[static_cast<Eigen::Index>(pr.offset(k) + 2 * i + ch)]) / d.size();
      double c0 = 0.0;
      for (auto& x : e) {
        x -= mean;
        c0 += x * x;
      }
      for (int lag = 1; lag <= s.whiteness_lags; ++lag) {
        double cl = 0.0;
        for (std::size_t i = static_cast<std::size_t>(lag); i < e.size(); ++i) cl += e[i] * e[i - static_cast<std::size_t>(lag)];
        q += static_cast<double>(e.size()) * std::pow(cl / c0, 2);
      }
      qdof += s.whiteness_lags;
    }
  }
  v.synchronous = {"synchronous chi^2 / dof (orders -" + std::to_string(s.orders) + ".." + std::to_string(s.orders) + ")", chi2 / dof,
                   1.0 + kZ * std::sqrt(2.0 / dof) + 2.0 * (kNoiseRatioLimit - 1.0), false};
  v.synchronous.pass = v.synchronous.value <= v.synchronous.limit;
  v.whiteness = {"Box-Pierce Q / dof (lags 1.." + std::to_string(s.whiteness_lags) + ")", q / qdof, 1.0 + kZ * std::sqrt(2.0 / qdof), false};
  v.whiteness.pass = v.whiteness.value <= v.whiteness.limit;

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
  const auto corr = [](const std::vector<double>& a, const std::vector<double>& b) {
    const double n = static_cast<double>(a.size());
    double ma = 0, mb = 0;
    for (std::size_t i = 0; i < a.size(); ++i) ma += a[i] / n, mb += b[i] / n;
    double sab = 0, saa = 0, sbb = 0;
    for (std::size_t i = 0; i < a.size(); ++i) sab += (a[i] - ma) * (b[i] - mb), saa += (a[i] - ma) * (a[i] - ma), sbb += (b[i] - mb) * (b[i] - mb);
    return saa > 0.0 && sbb > 0.0 ? sab / std::sqrt(saa * sbb) : 0.0;
  };
  const char* names[] = {"z+", "z_dot in contact", "x", "cos(shaft angle)", "sin(shaft angle)"};
  const double band = ex.empty() ? 0.0 : kZ / std::sqrt(static_cast<double>(ex.size()));
  for (int j = 0; j < 5; ++j)
    for (int ch = 0; ch < 2; ++ch) {
      const double c = series[static_cast<std::size_t>(j)].empty() ? 0.0 : corr(series[static_cast<std::size_t>(j)], ch ? ey : ex);
      v.state.push_back({std::string(ch ? "e_y" : "e_x") + " vs " + names[j], c, band, std::abs(c) <= band});
    }
  v.pass = v.noise_level.pass && v.synchronous.pass && v.whiteness.pass &&
           std::all_of(v.state.begin(), v.state.end(), [](const correlation_check& c) { return c.pass; });
  return v;
}

// ERR of the columns S (after removing what J already spans) on the residual r.
double err_score(const Eigen::MatrixXd& J, const Eigen::MatrixXd& S, const Eigen::VectorXd& r) {
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qj(J);
  Eigen::MatrixXd Q = qj.householderQ() * Eigen::MatrixXd::Identity(J.rows(), qj.rank());
  const Eigen::VectorXd rp = r - Q * (Q.transpose() * r);
  const Eigen::MatrixXd Sp = S - Q * (Q.transpose() * S);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qs(Sp);
  qs.setThreshold(1e-10);
  if (qs.rank() == 0 || rp.squaredNorm() == 0.0) return 0.0;
  const Eigen::MatrixXd Qs = qs.householderQ() * Eigen::MatrixXd::Identity(Sp.rows(), qs.rank());
  return (Qs.transpose() * rp).squaredNorm() / rp.squaredNorm();
}

double bic(double rss, double n, std::size_t k) { return n * std::log(rss / n) + static_cast<double>(k) * std::log(n); }

std::vector<std::pair<std::string, double>> effect_params(const effect_info& e, const effect_parameters& fx, std::vector<std::string>* held) {
  std::vector<std::pair<std::string, double>> out;
  const auto coords = effect_coordinates(e);
  for (const auto& q : e.parameters) {
    out.emplace_back(std::string(q.key), fx.*q.member);
    if (!q.is_switch && held) {
      // A shape parameter is fitted only through an amplitude-phase pair; others are held.
      bool fitted = false;
      for (const auto& c : coords) fitted = fitted || (c.name.find("_cos") != std::string::npos && q.key.starts_with("phi"));
      if (!fitted) held->push_back(std::string(q.key));
    }
  }
  return out;
}

}  // namespace

synchronous_energy synchronous_part(const std::vector<loop_dwell>& dwells, const orbit_predictor& pr, const model_point& m,
                                    const Eigen::VectorXd& r, int orders) {
  synchronous_energy out;
  for (std::size_t k = 0; k < dwells.size(); ++k) {
    const dwell& d = dwells[k].data;
    for (const auto& ck : order_coefficients(d, r, pr.offset(k), m.shift[k], orders)) out.energy += static_cast<double>(d.size()) * std::norm(ck);
    out.dof += 2.0 * (2.0 * orders + 1.0);
  }
  return out;
}

loop_result run_loop(const std::vector<std::pair<record, std::string>>& records, const loop_settings& s) {
  if (records.empty()) throw input_error("loop needs at least one record");
  loop_result out;
  // Dwells, their clearance and mass, timing by keyphasor.
  double mass = s.mass;
  out.mass_source = mass > 0.0 ? "given" : "";
  for (const auto& [r, name] : records) {
    for (auto& d : split_dwells(r, name)) {
      if (!(d.clearance > 0.0)) d.clearance = s.clearance;
      if (!(d.clearance > 0.0)) throw input_error(name + ": no clearance_m metadata; give --clearance");
      loop_dwell ld{std::move(d), name};
      align_by_keyphasor(ld, out.notes);
      out.dwells.push_back(std::move(ld));
    }
    if (!(mass > 0.0) && r.find("m_kg")) {
      mass = r.number("m_kg");
      if (!(mass > 0.0 && std::isfinite(mass))) throw input_error(name + ": m_kg must be a finite mass > 0");
      out.mass_source = "m_kg of " + name;
    }
  }
  if (!(mass > 0.0)) {
    mass = parameters{}.m;
    out.mass_source = "the paper's (no m_kg metadata)";
  }
  out.noise = estimate_noise(out.dwells);
  const double noise = std::max(out.noise, 1e-12);
  // Only synchronous dwells can be fitted: the loop's models repeat every revolution. A dwell
  // whose revolutions differ from their mean by more than kSpreadLimit x the noise (noise alone
  // gives about 1x) holds subharmonic, quasi-periodic or chaotic motion, or a drifting speed.
  constexpr double kSpreadLimit = 2.0;
  std::vector<loop_dwell> kept;
  for (auto& ld : out.dwells) {
    const averaged_dwell a = synchronous_average(ld.data);
    ld.contact = std::any_of(a.cycle.y.begin(), a.cycle.y.end(), [&](double y) { return y > ld.data.clearance; }) ||
                 high_order_content(a.cycle) > kContactDistortion * noise / std::sqrt(static_cast<double>(a.revolutions));
    if (a.spread > kSpreadLimit * noise) {
      out.excluded.push_back({ld.record, ld.data.rpm, ld.contact, a.spread});
      out.notes.push_back(ld.data.source + ": not synchronous (revolutions differ by " + str(a.spread * 1e6) + " um RMS, noise " +
                          str(noise * 1e6) + " um); left out of the fit");
    } else {
      kept.push_back(std::move(ld));
    }
  }
  out.dwells = std::move(kept);
  if (std::none_of(out.dwells.begin(), out.dwells.end(), [](const loop_dwell& d) { return d.contact; })) {
    if (out.excluded.empty()) throw input_error("no dwell reaches its clearance: there is no contact for the loop to fit");
    out.unexplained = true;  // contact only where the motion does not repeat: nothing synchronous to fit
    out.error_before = out.error_after = std::numeric_limits<double>::quiet_NaN();
    out.notes.push_back("no synchronous dwell with contact: the loop cannot fit these records");
    return out;
  }

  // Step 1a: the paper's pipeline (docs/identification.md) on the re-timed dwells: the linear
  // part without contact (here by harmonic balance), then the identified law's terms by FROLS on
  // the contact forces. (Its NLopt output-error stage is left to step 1b, which refines every
  // coordinate on every dwell at once.)
  std::vector<dwell> plain;
  for (const auto& ld : out.dwells) plain.push_back(ld.data);
  identify_settings is;
  is.mass = mass;
  is.linear = fit_linear_harmonic(out.dwells, mass);
  is.average_revolutions = true;
  is.library = "z1,z3,zd2";  // Eq. 5's terms: the loop's base model is the identified law
  is.frols.rho = 0.0;
  is.frols.err_threshold = 0.0;
  is.bootstrap = 0;
  model_point start;
  start.p.m = mass;
  start.p.delta = out.dwells.front().data.clearance;  // for the report; every dwell uses its own
  start.shift.assign(out.dwells.size(), 0.0);
  {
    const parameters& lin = *is.linear;
    start.p.c_x = lin.c_x;
    start.p.c_y = lin.c_y;
    start.p.k_x = lin.k_x;
    start.p.k_y = lin.k_y;
    start.p.e = lin.e;
    start.p.unbalance_phase = lin.unbalance_phase;
  }
  try {
    const identification id = identify(plain, is);
    // The law's start: FROLS's coefficients where positive (else the paper's Table 2 value: the
    // fit searches logarithms), mu from the friction ratio (Fig. 5).
    for (const auto& t : id.estimates) {
      if (t.name == "z1" && t.value > 0.0) start.p.k1 = t.value;
      if (t.name == "z3" && t.value > 0.0) start.p.k3 = t.value;
      if (t.name == "zd2" && t.value > 0.0) start.p.c2 = t.value;
    }
    if (std::isfinite(id.mu_mean) && id.mu_mean > 0.0 && id.mu_mean < 2.0) start.p.mu = id.mu_mean;
  } catch (const input_error& e) {
    out.notes.push_back(std::string("FROLS start not available (") + e.what() + "); the law starts from the paper's Table 2");
  }
  out.initial = start;

  // Step 1b: every coordinate of the paper's model together, on the orbits of all dwells.
  s.progress("      every coordinate together (Levenberg-Marquardt) ...");
  orbit_predictor predictor(out.dwells, noise);
  const double N = static_cast<double>(predictor.orbit_rows());
  std::vector<fit_coordinate> coords = paper_coordinates(start);
  {
    const fit_problem problem = make_problem(predictor, out.dwells, start, coords);
    out.before = fit(problem, problem.of(start), s.max_fit_evaluations);
  }
  model_point current = out.before;
  predictor.anchor(current);
  Eigen::VectorXd r = predictor.residuals(current);
  Eigen::VectorXd r_before = r;

  out.validity_before = validity(out.dwells, predictor, current, r, noise, s);
  out.error_before = errors_of(out.dwells, predictor, r).nrmse_contact;
  {
    const auto& v = out.validity_before;
    s.progress("      before: NRMSE " + str(out.error_before) + ", residual " + str(v.rms * 1e6) + " um against noise " + str(v.noise * 1e6) +
               " um; synchronous " + str(v.synchronous.value) + " (limit " + str(v.synchronous.limit) + "), whiteness " +
               str(v.whiteness.value) + " (limit " + str(v.whiteness.limit) + ")");
  }

  // Step 3: trace.
  std::vector<const effect_info*> remaining;
  for (const auto& e : effect_library()) remaining.push_back(&e);
  bool valid = out.validity_before.pass;
  int base_restarts = 0;
  for (int round = 0; round < s.max_effects && !valid && !remaining.empty(); ++round) {
    s.progress("[2/3] trace round " + std::to_string(round + 1) + ": scoring " + std::to_string(remaining.size()) + " effects ...");
    predictor.anchor(current);
    const fit_problem base = make_problem(predictor, out.dwells, current, coords);
    const Eigen::VectorXd u0 = base.of(current);
    const Eigen::VectorXd r0 = predictor.residuals(current);
    const Eigen::MatrixXd J = base.jacobian(u0, r0);
    const double rss0 = r0.squaredNorm();
    // What the trace must explain is what fails the synchronous check: the residual's shaft
    // orders above their noise expectation. (Against rss - N sigma^2 instead, a residual within
    // 1 % of the noise is dominated by the noise estimate's own ~1 % error: docs/loop.md, Hertz.)
    const synchronous_energy sync0 = synchronous_part(out.dwells, predictor, current, r0, s.orders);
    const auto share_removed = [&](const synchronous_energy& base, double energy_after) {
      const double excess = base.excess(noise);
      return excess > 0.0 ? (base.energy - energy_after) / excess : 0.0;
    };
    // The residual's part the base coordinates cannot remove (to first order).
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qj(J);
    const Eigen::MatrixXd Qj = qj.householderQ() * Eigen::MatrixXd::Identity(J.rows(), qj.rank());
    const auto project_out = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd { return v - Qj * (Qj.transpose() * v); };
    const double P0 = project_out(r0).squaredNorm();
    std::vector<effect_candidate> cands;
    std::vector<Eigen::VectorXd> gauss_newton;  // by candidate, in `remaining` order
    std::vector<std::optional<trial_point>> trial_start;  // by candidate
    for (const auto* e : remaining) {
      const auto ec = effect_coordinates(*e);
      Eigen::MatrixXd S(r0.size(), static_cast<Eigen::Index>(ec.size()));
      for (std::size_t j = 0; j < ec.size(); ++j) {
        model_point m = current;
        ec[j].set(m, kStep * ec[j].scale);
        S.col(static_cast<Eigen::Index>(j)) = (predictor.residuals(m) - r0) / kStep;
      }
      cands.push_back({std::string(e->name), err_score(J, S, r0)});
      // The Gauss-Newton step with the effect's columns: where its refit starts.
      Eigen::MatrixXd JS(J.rows(), J.cols() + S.cols());
      JS << J, S;
      const Eigen::VectorXd step = -JS.colPivHouseholderQr().solve(r0);
      gauss_newton.push_back(step);
      // An effect with trial values (it enters nonlinearly) is also scored by its profile: the
      // residual left, after the base coordinates' linear correction, with the effect at a value
      // (the trials, then a golden-section search between the best one's neighbours). Its share
      // of the base's residual is the linear score's analogue; the best value, base corrected, is
      // the start of its refit.
      trial_start.emplace_back();
      for (std::size_t j = 0; j < ec.size(); ++j) {
        if (!ec[j].trials) continue;
        const auto& grid = *ec[j].trials;
        const auto left = [&](double value) {
          model_point m = current;
          grid.apply(m, value);
          return project_out(predictor.residuals(m)).squaredNorm();
        };
        std::vector<std::pair<double, double>> tried{{0.0, P0}};  // (value, residual left); 0 is off
        for (const double value : grid.values) tried.emplace_back(value, left(value));
        std::sort(tried.begin(), tried.end());
        const auto best_at = static_cast<std::size_t>(
            std::min_element(tried.begin(), tried.end(), [](const auto& a, const auto& b) { return a.second < b.second; }) - tried.begin());
        double lo = tried[best_at == 0 ? 0 : best_at - 1].first, hi = tried[std::min(best_at + 1, tried.size() - 1)].first;
        const bool geometric = lo > 0.0;  // magnitudes a decade apart: search their logarithm
        const auto value_at = [&](double x) { return geometric ? std::exp(x) : x; };
        double a = geometric ? std::log(lo) : lo, b = geometric ? std::log(hi) : hi;
        double best_value = tried[best_at].first, best_left = tried[best_at].second;
        constexpr double kGolden = 0.6180339887498949;
        double x1 = b - kGolden * (b - a), x2 = a + kGolden * (b - a), f1 = left(value_at(x1)), f2 = left(value_at(x2));
        for (int it = 0; it < kProfileIterations; ++it) {
          if (f1 < f2) b = x2, x2 = x1, f2 = f1, x1 = b - kGolden * (b - a), f1 = left(value_at(x1));
          else a = x1, x1 = x2, f1 = f2, x2 = a + kGolden * (b - a), f2 = left(value_at(x2));
        }
        for (const auto& [x, f] : {std::pair{x1, f1}, std::pair{x2, f2}})
          if (f < best_left) best_value = value_at(x), best_left = f;
        const double score = P0 > 0.0 ? 1.0 - best_left / P0 : 0.0;
        if (score <= cands.back().score) continue;
        cands.back().score = score;
        model_point m = current;
        grid.apply(m, best_value);
        Eigen::VectorXd u = base.of(m) - qj.solve(predictor.residuals(m));  // effect there, base corrected (J factored once)
        model_point staged = m;  // the same trial on the staged model (step 1a)
        staged.p = out.initial.p;
        grid.apply(staged, best_value);
        trial_start.back() = trial_point{m, u, staged};
      }
    }
    std::vector<std::size_t> rank(cands.size());
    for (std::size_t i = 0; i < rank.size(); ++i) rank[i] = i;
    std::stable_sort(rank.begin(), rank.end(), [&](std::size_t a, std::size_t b) { return cands[a].score > cands[b].score; });
    {
      std::vector<effect_candidate> sorted;
      std::vector<Eigen::VectorXd> steps;
      std::vector<std::optional<trial_point>> trials;
      for (const std::size_t i : rank) sorted.push_back(cands[i]), steps.push_back(gauss_newton[i]), trials.push_back(trial_start[i]);
      cands = std::move(sorted);
      gauss_newton = std::move(steps);
      trial_start = std::move(trials);
    }
    s.progress("      best scores: " + cands[0].name + (cands.size() > 1 ? ", " + cands[1].name : std::string()) + "; refitting ...");
    int best = -1;
    model_point best_point;
    double best_rss = 0.0, best_energy = 0.0;  // the winner's residual energy, all and synchronous
    const auto refit = [&](int c) {
      auto& cand = cands[static_cast<std::size_t>(c)];
      auto with = coords;
      const auto ec = effect_coordinates(find_effect(cand.name));
      with.insert(with.end(), ec.begin(), ec.end());
      const fit_problem problem = make_problem(predictor, out.dwells, current, with);
      const auto searched = dip_searched(ec);
      model_point fitted;
      if (searched != ec.end()) {  // its coordinate's dip search is its refit
        fitted = search_dips(problem, coords.size() + static_cast<std::size_t>(searched - ec.begin()), rss0, out.initial, out.dwells,
                             s.max_fit_evaluations, s.progress);
      } else {
        // Start from the Gauss-Newton point if it is better than the current one (the effect at 0).
        Eigen::VectorXd start = problem.of(current);
        Eigen::VectorXd gn = start;
        const Eigen::VectorXd& step = gauss_newton[static_cast<std::size_t>(c)];
        const auto nb = static_cast<Eigen::Index>(coords.size());
        gn.head(nb) += step.head(nb);
        gn.segment(nb, static_cast<Eigen::Index>(ec.size())) = step.tail(static_cast<Eigen::Index>(ec.size()));
        gn.tail(start.size() - nb - static_cast<Eigen::Index>(ec.size())) += step.segment(nb, start.size() - nb - static_cast<Eigen::Index>(ec.size()));
        predictor.anchor(current);
        // Starts: the effect off (the current point), its Gauss-Newton point, and for an effect
        // with a trial grid its profile's best value: as it is, base corrected (the linear
        // correction may overshoot far from the current point), and on the staged model (a base
        // fit without the effect may have gone where no law fits). A trial effect's refit starts
        // from its profile, not from off: its profile already says off is not where it fits. A
        // start that wins only by moving the base is caught by the fair comparison below.
        const auto& trial = trial_start[static_cast<std::size_t>(c)];
        std::vector<Eigen::VectorXd> starts{gn};
        if (trial) {
          const auto shifts = start.size() - nb - static_cast<Eigen::Index>(ec.size());
          Eigen::VectorXd corrected = problem.of(trial->at);
          corrected.head(nb) = trial->corrected.head(nb);
          corrected.tail(shifts) = trial->corrected.tail(shifts);
          starts.push_back(problem.of(trial->at));
          starts.push_back(corrected);
          starts.push_back(problem.of(trial->staged));
        } else {
          starts.insert(starts.begin(), start);
        }
        double rss_start = std::numeric_limits<double>::infinity();
        for (const auto& u : starts)
          if (const double rss = predictor.residuals(problem.at(u)).squaredNorm(); rss < rss_start) start = u, rss_start = rss;
        fitted = fit(problem, start, s.max_fit_evaluations);
      }
      predictor.anchor(fitted);  // judged on its own orbits
      const Eigen::VectorXd rf = predictor.residuals(fitted);
      cand.refitted = true;
      cand.bic_drop = bic(rss0, N, with.size() - ec.size()) - bic(rf.squaredNorm(), N, with.size());
      const double energy_after = synchronous_part(out.dwells, predictor, fitted, rf, s.orders).energy;
      cand.excess_share = share_removed(sync0, energy_after);
      cand.error_after = errors_of(out.dwells, predictor, rf).nrmse_contact;
      if (cand.bic_drop > s.min_bic_drop && cand.excess_share >= s.min_excess_share &&
          (best < 0 || cand.bic_drop > cands[static_cast<std::size_t>(best)].bic_drop)) {
        best = c;
        best_point = fitted;
        best_rss = rf.squaredNorm();
        best_energy = energy_after;
      }
    };
    for (int c = 0; c < std::min<int>(s.refit_candidates, static_cast<int>(cands.size())); ++c) {
      if (cands[static_cast<std::size_t>(c)].score < kRefitScoreShare * cands.front().score) break;
      refit(c);
    }
    // Before the round gives up, an effect whose linear score says little (its coordinate has a
    // dip search: at a rigid stator the compliance is a series spring that k1 absorbs) is refitted
    // whatever its score, by its search.
    if (best < 0)
      for (int c = 0; c < static_cast<int>(cands.size()); ++c) {
        const auto& cand = cands[static_cast<std::size_t>(c)];
        const auto ec = effect_coordinates(find_effect(cand.name));
        if (!cand.refitted && dip_searched(ec) != ec.end()) {
          s.progress("      nothing passes; searching " + cand.name + " ...");
          refit(c);
        }
      }
    if (best < 0) {
      out.last_round = cands;
      break;
    }
    // A fair comparison: the winner's refit moves the base coordinates too, and may gain only
    // because the base leaves a local minimum of its own (a misorientation record's before-fit,
    // docs/loop.md). So the base is refitted without the effect from where the winner ended; if
    // that lands lower, the winner must pass the significance rule against it too, else the
    // refitted base becomes the base and the round is scored again.
    if (base_restarts < kMaxBaseRestarts) {
      const Eigen::VectorXd bs = base.of(best_point);
      if (bs != u0) {
        const model_point refit_base = fit(base, bs, s.max_fit_evaluations);
        predictor.anchor(refit_base);
        const Eigen::VectorXd rb = predictor.residuals(refit_base);
        const double rss_b = rb.squaredNorm();
        if (rss_b < rss0) {
          const std::size_t ne = effect_coordinates(find_effect(cands[static_cast<std::size_t>(best)].name)).size();
          const double fair_drop = bic(rss_b, N, coords.size()) - bic(best_rss, N, coords.size() + ne);
          const double fair_share = share_removed(synchronous_part(out.dwells, predictor, refit_base, rb, s.orders), best_energy);
          if (!(fair_drop > s.min_bic_drop && fair_share >= s.min_excess_share)) {
            ++base_restarts;
            --round;  // no effect was added
            const std::string note = "the model without " + cands[static_cast<std::size_t>(best)].name + ", refitted from where its refit ended, explains its gain (BIC " +
                                     str(bic(rss0, N, coords.size()) - bic(rss_b, N, coords.size())) + " lower than before; the effect's own drop " +
                                     str(fair_drop) + ", share " + str(fair_share) + ")";
            out.notes.push_back("trace: " + note + ": the round is scored again on the refitted base");
            s.progress("      " + note + ": scoring again");
            current = refit_base;
            if (out.effects.empty()) {  // still the paper's model: its best fit is the "before"
              out.before = current;
              r_before = rb;
              out.validity_before = validity(out.dwells, predictor, current, rb, noise, s);
              out.error_before = errors_of(out.dwells, predictor, rb).nrmse_contact;
              valid = out.validity_before.pass;
            } else {
              valid = validity(out.dwells, predictor, current, rb, noise, s).pass;
            }
            continue;
          }
        }
      }
    }
    const auto& chosen = cands[static_cast<std::size_t>(best)];
    const effect_info& e = find_effect(chosen.name);
    loop_step step;
    step.effect = chosen.name;
    step.params = effect_params(e, best_point.fx, &step.held);
    step.error_after_adding = chosen.error_after;
    step.bic_drop = chosen.bic_drop;
    step.excess_share = chosen.excess_share;
    step.candidates = cands;
    out.effects.push_back(std::move(step));
    const auto ec = effect_coordinates(e);
    coords.insert(coords.end(), ec.begin(), ec.end());
    remaining.erase(std::find(remaining.begin(), remaining.end(), &e));
    current = best_point;
    predictor.anchor(current);
    r = predictor.residuals(current);
    valid = validity(out.dwells, predictor, current, r, noise, s).pass;
  }
  out.after = current;
  for (auto& step : out.effects) {  // the final estimates (later effects refine earlier ones)
    step.held.clear();
    step.params = effect_params(find_effect(step.effect), current.fx, &step.held);
  }
  predictor.anchor(current);
  r = predictor.residuals(current);
  out.validity_after = validity(out.dwells, predictor, current, r, noise, s);
  out.unexplained = !out.validity_after.pass;
  const error_totals eb = errors_of(out.dwells, predictor, r_before), ea = errors_of(out.dwells, predictor, r);
  out.error_after = ea.nrmse_contact;
  for (std::size_t k = 0; k < out.dwells.size(); ++k) {
    const auto& ld = out.dwells[k];
    out.errors.push_back({ld.record, ld.data.rpm, ld.contact, ld.data.size(), eb.rms[k], ea.rms[k], eb.nrmse[k], ea.nrmse[k]});
  }

  // Spectrum by order, RMS over contact dwells, and the plot dwell (largest error before).
  out.spectrum.orders.clear();
  for (int k = -s.orders; k <= s.orders; ++k) out.spectrum.orders.push_back(k);
  out.spectrum.before.assign(out.spectrum.orders.size(), 0.0);
  out.spectrum.after.assign(out.spectrum.orders.size(), 0.0);
  double contact_dwells = 0.0, worst = -1.0;
  for (std::size_t k = 0; k < out.dwells.size(); ++k) {
    if (!out.dwells[k].contact) continue;
    contact_dwells += 1.0;
    const auto cb = order_coefficients(out.dwells[k].data, r_before, predictor.offset(k), out.before.shift[k], s.orders);
    const auto ca = order_coefficients(out.dwells[k].data, r, predictor.offset(k), out.after.shift[k], s.orders);
    for (std::size_t j = 0; j < cb.size(); ++j) out.spectrum.before[j] += std::norm(cb[j]), out.spectrum.after[j] += std::norm(ca[j]);
    if (eb.rms[k] > worst) worst = eb.rms[k], out.plot_dwell = k;
  }
  for (auto* v : {&out.spectrum.before, &out.spectrum.after})
    for (double& x : *v) x = std::sqrt(x / std::max(contact_dwells, 1.0));
  {
    const std::size_t k = out.plot_dwell;
    const dwell& d = out.dwells[k].data;
    const double period = 60.0 / d.rpm;
    for (std::size_t i = 0; i < d.size(); ++i) {
      const double tau = d.t[i] + out.after.shift[k];
      out.plot_phase.push_back(360.0 * phase_in_period(tau, period) / period);
      out.plot_x.push_back(d.x[i]);
      out.plot_y.push_back(d.y[i]);
      const auto at = static_cast<Eigen::Index>(predictor.offset(k) + 2 * i);
      out.plot_x_before.push_back(d.x[i] + r_before[at]);
      out.plot_y_before.push_back(d.y[i] + r_before[at + 1]);
      out.plot_x_after.push_back(d.x[i] + r[at]);
      out.plot_y_after.push_back(d.y[i] + r[at + 1]);
    }
  }
  return out;
}

namespace {

json check_json(const correlation_check& c) { return {{"name", c.name}, {"value", c.value}, {"limit", c.limit}, {"pass", c.pass}}; }

json validity_json(const validity_report& v) {
  json j{{"noise_m", v.noise}, {"residual_rms_m", v.rms}, {"pass", v.pass}};
  j["checks"] = json::array({check_json(v.noise_level), check_json(v.synchronous), check_json(v.whiteness)});
  for (const auto& c : v.state) j["checks"].push_back(check_json(c));
  return j;
}

json candidates_json(const std::vector<effect_candidate>& cs) {
  json a = json::array();
  for (const auto& c : cs) {
    json j{{"name", c.name}, {"score", c.score}, {"refitted", c.refitted}};
    if (c.refitted) {
      j["bic_drop"] = c.bic_drop;
      j["excess_share"] = c.excess_share;
      j["error_after"] = c.error_after;
    }
    a.push_back(j);
  }
  return a;
}

std::string fmt(double v, int digits = 4) {
  std::ostringstream o;
  o.precision(digits);
  o << v;
  return o.str();
}

}  // namespace

json to_json(const loop_result& r) {
  json j;
  j["error_before"] = r.error_before;
  j["error_after"] = r.error_after;
  j["error_definition"] = "orbit NRMSE over the dwells with contact: sqrt(sum |model - measured|^2 / sum |measured - dwell mean|^2)";
  j["effects"] = json::array();
  for (const auto& e : r.effects) {
    json params;
    for (const auto& [k, v] : e.params) params[k] = v;
    j["effects"].push_back({{"name", e.effect},
                            {"params", params},
                            {"held", e.held},
                            {"error_after_adding", e.error_after_adding},
                            {"bic_drop", e.bic_drop},
                            {"excess_share", e.excess_share},
                            {"candidates", candidates_json(e.candidates)}});
  }
  j["unexplained"] = r.unexplained;
  if (!r.last_round.empty()) j["rejected_round"] = candidates_json(r.last_round);
  j["excluded"] = json::array();
  for (const auto& e : r.excluded)
    j["excluded"].push_back({{"record", e.record}, {"rpm", e.rpm}, {"contact", e.contact}, {"revolution_spread_m", e.spread}});
  j["noise_m"] = r.noise;
  j["mass_source"] = r.mass_source;
  j["model_staged"] = to_json(r.initial.p);
  j["model_before"] = to_json(r.before.p);
  j["model_after"] = to_json(r.after.p);
  j["validity_before"] = validity_json(r.validity_before);
  j["validity_after"] = validity_json(r.validity_after);
  j["records"] = json::array();
  for (const auto& e : r.errors)
    j["records"].push_back({{"record", e.record},
                            {"rpm", e.rpm},
                            {"contact", e.contact},
                            {"samples", e.samples},
                            {"rms_before_m", e.rms_before},
                            {"rms_after_m", e.rms_after},
                            {"error_before", e.nrmse_before},
                            {"error_after", e.nrmse_after}});
  j["residual_spectrum"] = {{"orders", r.spectrum.orders}, {"before_m", r.spectrum.before}, {"after_m", r.spectrum.after}};
  j["notes"] = r.notes;
  return j;
}

std::string to_markdown(const loop_result& r) {
  std::ostringstream o;
  o << "# rubref loop report\n\n";
  o << "| | before | after |\n|---|---|---|\n";
  o << "| orbit NRMSE (contact dwells) | " << fmt(r.error_before) << " | " << fmt(r.error_after) << " |\n";
  o << "| residual RMS | " << fmt(r.validity_before.rms * 1e6) << " um | " << fmt(r.validity_after.rms * 1e6) << " um |\n";
  o << "| residual consistent with noise (" << fmt(r.noise * 1e6) << " um) | " << (r.validity_before.pass ? "yes" : "no") << " | "
    << (r.validity_after.pass ? "yes" : "no") << " |\n\n";
  o << "Effects added, in order:";
  if (r.effects.empty()) o << " none.";
  o << "\n\n";
  if (!r.effects.empty()) {
    o << "| # | effect | parameters | error after adding | BIC drop | share of synchronous excess removed |\n|---|---|---|---|---|---|\n";
    int i = 1;
    for (const auto& e : r.effects) {
      std::string ps;
      for (const auto& [k, v] : e.params) ps += (ps.empty() ? "" : ", ") + k + " = " + fmt(v);
      if (!e.held.empty()) {
        std::string h;
        for (const auto& k : e.held) h += (h.empty() ? "" : ", ") + k;
        ps += " (held: " + h + ")";
      }
      o << "| " << i++ << " | " << e.effect << " | " << ps << " | " << fmt(e.error_after_adding) << " | " << fmt(e.bic_drop, 6) << " | "
        << fmt(e.excess_share, 3) << " |\n";
    }
    o << "\n";
  }
  o << (r.unexplained ? "**Unexplained:** the final residual is not noise, and no effect of the library passes the significance rule.\n\n"
                      : "The final residual is consistent with probe noise.\n\n");
  if (!r.plot_x.empty()) o << "![orbit](orbit.png)\n\n![residual spectrum](residual_spectrum.png)\n\n![residual](residual.png)\n\n";
  o << "## Validity checks (after)\n\n| check | value | limit | pass |\n|---|---|---|---|\n";
  for (const auto* c : {&r.validity_after.noise_level, &r.validity_after.synchronous, &r.validity_after.whiteness})
    o << "| " << c->name << " | " << fmt(c->value) << " | " << fmt(c->limit) << " | " << (c->pass ? "yes" : "no") << " |\n";
  for (const auto& c : r.validity_after.state)
    o << "| corr " << c.name << " | " << fmt(c.value) << " | " << fmt(c.limit) << " | " << (c.pass ? "yes" : "no") << " |\n";
  o << "\n## Per dwell\n\n| record | rpm | contact | samples | NRMSE before | NRMSE after | RMS before [um] | RMS after [um] |\n"
       "|---|---|---|---|---|---|---|---|\n";
  for (const auto& e : r.errors)
    o << "| " << e.record << " | " << e.rpm << " | " << (e.contact ? "yes" : "no") << " | " << e.samples << " | " << fmt(e.nrmse_before) << " | "
      << fmt(e.nrmse_after) << " | " << fmt(e.rms_before * 1e6) << " | " << fmt(e.rms_after * 1e6) << " |\n";
  for (const auto& n : r.notes) o << "\nNote: " << n << "\n";
  return o.str();
}

json plot_data(const loop_result& r) {
  if (r.plot_x.empty()) return json::object();
  const auto& d = r.dwells[r.plot_dwell];
  return {{"title", d.record + ", " + fmt(d.data.rpm) + " rpm"},
          {"clearance_m", d.data.clearance},
          {"phase_deg", r.plot_phase},
          {"x_m", r.plot_x},
          {"y_m", r.plot_y},
          {"x_before_m", r.plot_x_before},
          {"y_before_m", r.plot_y_before},
          {"x_after_m", r.plot_x_after},
          {"y_after_m", r.plot_y_after},
          {"orders", r.spectrum.orders},
          {"spectrum_before_m", r.spectrum.before},
          {"spectrum_after_m", r.spectrum.after}};
}

}  // namespace rubref
