#include "ref/loop/paper_fit.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <set>

#include "ref/format/record.hpp"

#include "ref/base/errors.hpp"
#include "ref/identification/identify.hpp"

namespace rubref {

namespace {
// The harmonic balance's physical floor: a damping ratio no rotor kit goes below (rolling bearings
// alone give ~0.005) and a stiffness of a hundredth of m w^2 at the dwells' speeds.
constexpr double kMinDampingRatio = 1e-3;
constexpr double kMinStiffnessShare = 1e-2;
}  // namespace

// The linear part from the dwells without contact, by harmonic balance on their 1X components
// (steady response of Eq. 1 without contact): with X, Y the 1X phasors of x and y and
// E = e exp(i phase),
//   (k_x - m w^2 + i c_x w) X = m w^2 E,   (k_y - m w^2 + i c_y w) Y = -i m w^2 E,
// linear in (k_x, c_x, k_y, c_y, Re E, Im E). The 1X phasor averages every revolution, so noise
// barely enters; it needs two speeds or more.
parameters fit_linear_harmonic(const std::vector<loop_dwell>& dwells, double mass, std::vector<std::string>* notes) {
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
  // Least squares with the stiffnesses and dampers (columns 0-3) bounded below by a physical
  // floor. An effect the model lacks biases the balance (a shaft bow's 1X force does not grow with
  // w^2 like the unbalance's), and with two or three speeds it can give a negative damper, a model
  // that runs away at every speed and leaves the loop nothing to fit. A bounded linear least
  // squares problem is solved exactly by the best feasible one of its active sets: each subset of
  // the four at its floor, the rest free.
  double w_mean = 0.0;
  for (const auto* ld : free) w_mean += ld->data.omega() / static_cast<double>(free.size());
  const double floor[4] = {kMinStiffnessShare * mass * w_mean * w_mean, 2.0 * kMinDampingRatio * mass * w_mean,
                           kMinStiffnessShare * mass * w_mean * w_mean, 2.0 * kMinDampingRatio * mass * w_mean};
  Eigen::VectorXd v = A.colPivHouseholderQr().solve(b);
  const auto feasible = [&](const Eigen::VectorXd& x) {
    for (int j = 0; j < 4; ++j)
      if (!(x[j] >= floor[j])) return false;
    return true;
  };
  if (!feasible(v)) {
    double best = std::numeric_limits<double>::infinity();
    Eigen::VectorXd chosen;
    for (int set = 1; set < 16; ++set) {
      std::vector<Eigen::Index> free_columns;
      Eigen::VectorXd x = Eigen::VectorXd::Zero(6), rhs = b;
      for (int j = 0; j < 6; ++j) {
        if (j < 4 && (set >> j & 1)) {
          x[j] = floor[j];
          rhs -= A.col(j) * floor[j];
        } else {
          free_columns.push_back(j);
        }
      }
      Eigen::MatrixXd Af(A.rows(), static_cast<Eigen::Index>(free_columns.size()));
      for (std::size_t i = 0; i < free_columns.size(); ++i) Af.col(static_cast<Eigen::Index>(i)) = A.col(free_columns[i]);
      const Eigen::VectorXd xf = Af.colPivHouseholderQr().solve(rhs);
      for (std::size_t i = 0; i < free_columns.size(); ++i) x[free_columns[i]] = xf[static_cast<Eigen::Index>(i)];
      const double rss = (A * x - b).squaredNorm();
      if (feasible(x) && rss < best) best = rss, chosen = x;
    }
    if (notes) {
      static const char* names[4] = {"k_x", "c_x", "k_y", "c_y"};
      std::string which;
      for (int j = 0; j < 4; ++j)
        if (!(v[j] >= floor[j])) which += (which.empty() ? "" : ", ") + std::string(names[j]) + " = " + format_digits(v[j]);
      notes->push_back("the harmonic balance of the dwells without contact gives an unphysical linear part (" + which +
                       "): it is bounded below by a damping ratio of " + format_digits(kMinDampingRatio) + " and a stiffness of " +
                       format_digits(kMinStiffnessShare) + " m w^2; an effect the paper's model lacks (a shaft bow, a runout) biases it, and the fits go on from there");
    }
    v = chosen;
  }
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

staged_start staged_model(const std::vector<loop_dwell>& dwells, double mass, std::vector<std::string>& notes) {
  // The paper's pipeline (docs/identification.md) on the re-timed dwells: the linear part without
  // contact (here by harmonic balance), then the identified law's terms by FROLS on the contact
  // forces. (Its NLopt output-error stage is left to the before-fit, which refines every
  // coordinate on every dwell at once.)
  // (Only the dwells that repeat every revolution: the pipeline averages one revolution.)
  std::vector<dwell> plain;
  for (const auto& ld : dwells)
    if (ld.periods == 1) plain.push_back(ld.data);
  identify_settings is;
  is.mass = mass;
  // With fewer than two speeds without contact the balance cannot separate stiffness, damper and
  // unbalance: the linear part then starts from the paper's values (scaled to the mass), and the
  // before-fit fits it on every dwell, contact ones included (said in the notes).
  std::set<double> free_speeds;
  for (const auto& ld : dwells)
    if (!ld.contact) free_speeds.insert(ld.data.rpm);
  if (free_speeds.size() >= 2) {
    is.linear = fit_linear_harmonic(dwells, mass, &notes);
  } else {
    const parameters paper;
    parameters lin = paper;
    const double scale = mass / paper.m;
    lin.m = mass;
    lin.c_x *= scale, lin.c_y *= scale, lin.k_x *= scale, lin.k_y *= scale;
    is.linear = lin;
    notes.push_back("the records hold " + std::to_string(free_speeds.size()) +
                    " speed(s) without contact, too few for the harmonic balance of the linear part: it starts from the paper's (scaled to the "
                    "mass), and the before-fit fits it on every dwell");
  }
  is.average = averaging::always;  // every dwell here repeats each revolution (periods == 1)
  // The staged start as validated by the loop's campaign: the weak form's own terms, refined by
  // the orbit fit (the structure comparison is identify's default; not yet measured on the loop).
  is.compare_structures = false;
  is.library = "z1,z3,zd2";  // Eq. 5's terms: the loop's base model is the identified law
  is.frols.rho = 0.0;
  is.frols.err_threshold = 0.0;
  is.bootstrap = 0;
  model_point start;
  start.p.m = mass;
  start.p.clearance = dwells.front().data.clearance;  // for the report; every dwell uses its own
  start.shift.assign(dwells.size(), 0.0);
  const parameters& lin = *is.linear;
  start.p.c_x = lin.c_x;
  start.p.c_y = lin.c_y;
  start.p.k_x = lin.k_x;
  start.p.k_y = lin.k_y;
  start.p.e = lin.e;
  start.p.unbalance_phase = lin.unbalance_phase;
  staged_start out;
  try {
    const identification id = identify(plain, is);
    // The law's start: identify's coefficients where positive (else the paper's Table 2 value:
    // the fit searches logarithms), and its mu (Fig. 5's mean on the samples route; on noisy
    // records the weak form's, refined by the orbit fit, docs/identification.md §5).
    const auto with_law = [&](parameters p, const std::vector<term_estimate>& terms, double mu) {
      for (const auto& t : terms) {
        if (t.name == "z1" && t.value > 0.0) p.k1 = t.value;
        if (t.name == "z3" && t.value > 0.0) p.k3 = t.value;
        if (t.name == "zd2" && t.value > 0.0) p.c2 = t.value;
      }
      if (std::isfinite(mu) && mu > 0.0 && mu < 2.0) p.mu = mu;
      return p;
    };
    const parameters table2 = start.p;
    start.p = with_law(table2, id.estimates, id.mu);
    // The weak form's own law, where the orbit fit moved it: the before-fit's third start.
    if (!id.weak_estimates.empty()) {
      const parameters weak = with_law(table2, id.weak_estimates, std::isfinite(id.weak_mu) ? id.weak_mu : id.mu);
      if (weak.k1 != start.p.k1 || weak.k3 != start.p.k3 || weak.c2 != start.p.c2 || weak.mu != start.p.mu) out.weak_form = weak;
    }
  } catch (const input_error& e) {
    notes.push_back(std::string("FROLS start not available (") + e.what() + "); the law starts from the paper's Table 2");
  }
  out.model = std::move(start);
  return out;
}

std::vector<named_start> before_fit_starts(const model_point& staged, const std::optional<parameters>& weak_form) {
  model_point table2 = staged;
  const parameters paper;
  table2.p.k1 = paper.k1;
  table2.p.k3 = paper.k3;
  table2.p.c2 = paper.c2;
  table2.p.mu = paper.mu;
  std::vector<named_start> starts{{"staged (FROLS law)", staged}, {"staged linear part, Table 2 law", table2}};
  if (weak_form) {
    model_point weak = staged;
    weak.p = *weak_form;
    starts.push_back({"staged, the weak form's law", std::move(weak)});
  }
  return starts;
}

std::vector<std::size_t> uncomputable_dwells(const std::vector<loop_dwell>& dwells, double noise, const std::vector<named_start>& starts,
                                             const fit_orbit_options& orbits) {
  std::vector<bool> computable(dwells.size(), false);
  for (const auto& s : starts) {
    orbit_predictor predictor(dwells, noise, orbits);
    (void)predictor.residuals(s.at);
    for (std::size_t k = 0; k < dwells.size(); ++k) computable[k] = computable[k] || predictor.kinds()[k] != orbit_kind::failed;
  }
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < dwells.size(); ++k)
    if (!computable[k]) out.push_back(k);
  return out;
}

std::vector<std::size_t> dwells_without_their_orbit(const std::vector<loop_dwell>& dwells, double noise, const std::vector<named_start>& starts,
                                                    const fit_orbit_options& orbits) {
  std::vector<bool> found(dwells.size(), false);
  for (const auto& s : starts) {
    orbit_predictor predictor(dwells, noise, orbits);
    (void)predictor.residuals(s.at);
    for (std::size_t k = 0; k < dwells.size(); ++k) found[k] = found[k] || predictor.kinds()[k] == orbit_kind::periodic;
  }
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k < dwells.size(); ++k)
    if (dwells[k].periods > 1 && !found[k]) out.push_back(k);
  return out;
}

multistart_result fit_paper_model(orbit_predictor& predictor, const std::vector<loop_dwell>& dwells, const model_point& staged,
                                  const std::optional<parameters>& weak_form, double noise, int max_iterations,
                                  const std::function<bool(const fit_result&)>& is_noise) {
  const fit_problem problem = make_problem(predictor, dwells, staged, paper_coordinates(), noise);
  const std::vector<named_start> starts = before_fit_starts(staged, weak_form);
  return fit_from_starts(problem, starts, max_iterations, is_noise, static_cast<int>(starts.size()));
}

}  // namespace rubref
