#include "ref/tracking/rub_fit.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <numbers>
#include <numeric>
#include <optional>

#include <Eigen/Dense>
#include <boost/math/distributions/chi_squared.hpp>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/integrate/parameter_columns.hpp"
#include "ref/orbits/fit_orbits.hpp"
#include "ref/model/rotor_model.hpp"
#include "ref/inference/evidence.hpp"
#include "ref/inference/least_squares.hpp"
#include "variants/identified.hpp"

namespace rubref {

namespace {

using cplx = std::complex<double>;
using state6 = std::array<double, 6>;
using model = rotor_with_effects<identified>;  // Eq. 5's law (k3 = c2 = 0 unless the form has them) with the effects' terms
using namespace response_slots;
constexpr double kPi = std::numbers::pi;
constexpr double kRpmToRadS = 2.0 * kPi / 60.0;
constexpr double kZ95 = 1.959963984540054;

// The rub fit's coordinates beyond the response fit's: the unbalance and the bow (over a
// reference size, so every coordinate is of order 1 for the finite differences), ln delta,
// ln (k1/m), mu; the form's ln (k3/m), ln (c2/m), the contact angle theta, ln (k_h/m), and the
// Hunt-Crossley term's ln size at its reference penetration and its exponent p.
enum rub_slot : std::size_t { re_a = kSlots, im_a, re_b, im_b, ln_delta, ln_kappa, friction_mu, ln_cubic, ln_velocity_squared, contact_theta, ln_hertz, ln_hunt, hunt_exponent, kRubSlots };

// One period read at this many samples: a contact's harmonics above the 127th would alias onto the
// 1X and 2X, and a stiff contact's fall far below the noise by then.
constexpr std::size_t kReadSamples = 256;
// Revolutions a speed settles from the previous speed's orbit when Newton finds no stable orbit
// from it (a run-up's jump off a fold): the slowest free decay rate z w of a lightly damped rotor
// (z = 0.005 at 1000 rpm: 0.5 /s) would need more; the settled state only starts Newton again.
constexpr int kSettleRevs = 60;
// The starts: the clearance as a share of the clearance's scale (below: the rub flattens the
// peak, which the linear fit followed), the contact stiffness per unit mass in units of the lower
// critical speed squared (a stator 30 and 300 times stiffer than the supports: contact frequencies
// 5.5 and 17 times the critical speed), friction 0.1 (the fit moves it within [0, 1]); the best
// two by their residual fitted.
constexpr double kClearanceShares[] = {0.5, 0.7, 0.9};
// and the contact-free fit's damping ratios as they are and lowered: a contact-free fit widens its
// peak to follow the rub's flattening, and from its damping the model may not reach the stator.
constexpr double kDampingShares[] = {1.0, 0.5, 0.25};
constexpr double kStiffnessRatios[] = {30.0, 300.0};
constexpr double kFrictionStart = 0.1;
constexpr std::size_t kFittedStarts = 2;
// The starts are ranked from orbits at this many times the fit's tolerances (shot to 1e-9 m,
// integrated at rtol 1e-7): the ranking needs their residuals to well below a table's noise
// (>= 1e-8 m), not to the fit's 1e-12 m, and the grid was a quarter of a rub table's time.
constexpr double kRankLoosening = 1e3;
// Bounds (a box): the clearance within 5 % and twice that scale (beyond it nothing touches), the
// stiffness per unit mass from the square of the table's lowest speed (at least as stiff as a
// support whose critical speed is there) to 1e4 times the highest's (stiffer only costs steps and
// reads alike), mu in [0, 1].
constexpr double kClearanceLo = 0.05, kClearanceHi = 2.0;
constexpr double kStiffnessHi = 1e4;
// The form's terms start where each is this share of k1 z at the start's largest penetration
// (k3 z^2 / k1; c2 z_dot^2 / (k1 z) at its largest approach speed): below and above parity, the
// better fitted (a term the table does not show ends small either way). Their box: 1e-6 to 1e6
// of parity (a term beyond either end reads as none or as a wall). The stator's direction starts
// at the start's and this far either side of it (one undeclared probe: 60 degrees apart over the
// half circle a 1X table tells apart, fit_rub's contact angle).
constexpr double kTermShares[] = {0.3, 3.0};
constexpr double kTermBox = 1e6;
// The floor of a grown form's fit (fit_starts_set): the start's own point with its new terms all
// but off (this share of parity, the stator where it was). From the shares above alone a k3 try
// ended with chi^2 1.7e3 above the fit it grew (campaign seed 6464, scenario 249), and the term
// was refused for it.
constexpr double kTermNullShare = 1e-3;
// The Hunt-Crossley term is fitted as its size at a reference penetration and its exponent (lambda
// and p trade along a fit's path otherwise): a hundredth of the table's largest 1X reading, the
// scale of a rub's penetration (fixed per table, so every fit of it shares the coordinate). Its
// exponent in the effect library's range, from the library's typical value.
constexpr double kHuntReferenceShare = 1e-2;
constexpr double kHuntExponentLo = 1.0, kHuntExponentHi = 2.0, kHuntExponentStart = 1.5;
constexpr double kAngleSteps[] = {-kPi / 6.0, kPi / 6.0};
constexpr double kAngleStepsAround[] = {-kPi / 3.0, kPi / 3.0};

struct row_orbit {
  cplx x1{}, y1{}, x2{}, y2{};
  bool contact = false, periodic = true;
  double penetration = 0.0, approach = 0.0;  // the largest penetration and its rate while in contact
  bool circled = false;         // read from an unstable orbit the motion circles (circled_orbit)
  bool closed_form = false;     // the contact-free response in closed form (not shot)
  double rho = 0.0;             // its largest Floquet multiplier's modulus (shot rows with an orbit; infinite without one)
  std::optional<state6> state;  // the orbit's state at t = 0 (rows shot to an orbit, stable or circled): the next speed's start
};

// An unstable period-1 orbit the motion stays around: every multiplier outside the unit circle
// lies in the left half-plane (a flip's, -1 crossed: a period-2 motion; or a complex pair turning
// more than a quarter turn a revolution: a torus), so the motion circles the orbit and the 1X read
// over a block of revolutions (the table's instrument) averages the circling out: the orbit is the
// motion's 1X centre, to second order in the circling's size where it is born. A multiplier
// beyond +1 (a fold's, or a slow torus) is not: the motion leaves for another branch.
bool circled_orbit(const periodic_orbit<6>& o) {
  if (!o.converged) return false;
  for (const auto& mu : o.multipliers)
    if (std::abs(mu) >= 1.0 && !(mu.real() < 0.0)) return false;
  return true;
}

// A count that tasks on several threads add to (the problem's evaluations and shots): the total
// is the same whatever the thread count; copied with its problem.
struct shared_count {
  std::atomic<long long> n{0};
  shared_count() = default;
  shared_count(const shared_count& o) : n(o.n.load()) {}
  shared_count& operator=(const shared_count& o) {
    n = o.n.load();
    return *this;
  }
  void add(long long k = 1) { n.fetch_add(k, std::memory_order_relaxed); }
  long long value() const { return n.load(); }
};

struct sample_recorder {
  std::vector<state6>* out;
  template <class System>
  void on_sample(double, const state6& s, const System&) {
    out->push_back(s);
  }
  void on_event(const basic_contact_event<state6>&) {}
};

struct rub_problem {
  rub_problem(const order_table& t, const response_parts& p) : table(t), parts(p) {}
  const order_table& table;
  response_parts parts;
  std::vector<std::size_t> orders;  // the 1X column of each probe
  std::vector<double> beta;         // each probe's declared angle
  std::vector<double> sigma;
  std::vector<std::size_t> rows;    // fitted
  std::vector<std::size_t> freed;   // freed (rub_fit_options::freed_rows): shot on the path, not fitted
  std::vector<std::size_t> free;
  double w_lo = 1.0, w_hi = 1.0, ref_m = 1.0, peak_m = 1.0;
  rub_form form;
  bool undeclared = false;           // one probe, its angle not declared: the stator's direction fitted against it
  // Its angle fitted too where the supports differ (they have directions then); where they are
  // alike only the angle between probe and stator is seen, and the probe's stays at the 1X fit's.
  bool beta_fitted() const { return undeclared && parts.anisotropy; }
  double beta_of(const std::vector<double>& f, std::size_t p) const { return beta_fitted() ? f[probe_beta] : beta[p]; }
  row_path path;                     // the rows in the order the rig ran them
  std::vector<std::size_t> previous; // each row's predecessor on the path (rows(): none)
  // k3/m, c2/m, k_h/m and the Hunt-Crossley term at its reference at parity with k1 z (the form's starts and box)
  double cubic_parity = 1.0, velocity_squared_parity = 1.0, hertz_parity = 1.0, hunt_parity = 1.0;
  double hunt_reference_m = 1.0;
  // Evaluations (every row's orbit at a point) and shootings, counted by the tasks that make them
  // (starts' costs, fits and a Jacobian's rows run on the machine's threads).
  shared_count evaluations, shots;

  void lay_out() {
    free = {ln_wx, ln_zx};
    if (parts.anisotropy) free.push_back(ln_wy), free.push_back(ln_zy);
    if (beta_fitted()) free.push_back(probe_beta);
    if (parts.cross_coupling) free.push_back(k_xy), free.push_back(k_yx);
    free.push_back(re_a), free.push_back(im_a);
    if (parts.shaft_bow) free.push_back(re_b), free.push_back(im_b);
    free.push_back(ln_delta), free.push_back(ln_kappa), free.push_back(friction_mu);
    if (form.cubic) free.push_back(ln_cubic);
    if (form.velocity_squared) free.push_back(ln_velocity_squared);
    if (form.contact_angle) free.push_back(contact_theta);
    if (form.hertz) free.push_back(ln_hertz);
    if (form.hunt_crossley) free.push_back(ln_hunt), free.push_back(hunt_exponent);
  }
  std::vector<double> full(const std::vector<double>& q, std::vector<double> f) const {
    for (std::size_t k = 0; k < free.size(); ++k) f[free[k]] = q[k];
    if (!parts.anisotropy) f[ln_wy] = f[ln_wx], f[ln_zy] = f[ln_zx];
    return f;
  }
  std::vector<double> reduce(const std::vector<double>& f) const {
    std::vector<double> q(free.size());
    for (std::size_t k = 0; k < free.size(); ++k) q[k] = f[free[k]];
    return q;
  }
  std::vector<double> base;  // the full vector the free coordinates are laid into (fixed slots: 0)
  // Shot, settled and read as every fit's orbit (ref/orbits/fit_orbits.hpp) at the options' orbit
  // tolerances (the verdict's check tightens them), made once per problem; a problem that only
  // ranks starts loosens them (loosened).
  fit_orbit_options orbit_options = {};
  integration_options settle = fit_settling(kSettleRevs), read = fit_sampling();
  void use(const fit_orbit_options& o) {
    orbit_options = o;
    settle = fit_settling(kSettleRevs, o), read = fit_sampling(1, o);
  }
  rub_problem loosened(double scale) const {
    rub_problem out = *this;
    fit_orbit_options o = orbit_options;
    o.tolerance_scale *= scale;
    out.use(o);
    return out;
  }
  std::vector<double> clamp(std::vector<double> q) const {
    std::vector<double> f = full(q, base);
    for (const std::size_t k : {ln_wx, ln_wy}) f[k] = std::clamp(f[k], std::log(w_lo), std::log(w_hi));
    for (const std::size_t k : {ln_zx, ln_zy}) f[k] = std::clamp(f[k], std::log(1e-4), std::log(2.0));
    for (const std::size_t k : {k_xy, k_yx}) f[k] = std::clamp(f[k], -0.5, 0.5);
    f[ln_delta] = std::clamp(f[ln_delta], std::log(kClearanceLo * peak_m), std::log(kClearanceHi * peak_m));
    f[ln_kappa] = std::clamp(f[ln_kappa], 2.0 * std::log(w_lo), std::log(kStiffnessHi * w_hi * w_hi));
    f[friction_mu] = std::clamp(f[friction_mu], 0.0, 1.0);
    f[ln_cubic] = std::clamp(f[ln_cubic], std::log(cubic_parity / kTermBox), std::log(cubic_parity * kTermBox));
    f[ln_velocity_squared] = std::clamp(f[ln_velocity_squared], std::log(velocity_squared_parity / kTermBox), std::log(velocity_squared_parity * kTermBox));
    f[ln_hertz] = std::clamp(f[ln_hertz], std::log(hertz_parity / kTermBox), std::log(hertz_parity * kTermBox));
    f[ln_hunt] = std::clamp(f[ln_hunt], std::log(hunt_parity / kTermBox), std::log(hunt_parity * kTermBox));
    f[hunt_exponent] = std::clamp(f[hunt_exponent], kHuntExponentLo, kHuntExponentHi);
    f[contact_theta] = std::clamp(f[contact_theta], -kPi, kPi);
    f[probe_beta] = std::clamp(f[probe_beta], -kPi, kPi);
    return reduce(f);
  }

  // The contact-free 1X displacement (X, Y) at speed w (the equation of response_fit.hpp).
  std::pair<cplx, cplx> linear_xy(const std::vector<double>& f, double w) const {
    const double wx = std::exp(f[ln_wx]), wy = std::exp(f[ln_wy]), zx = std::exp(f[ln_zx]), zy = std::exp(f[ln_zy]);
    const double kxy = f[k_xy] * wx * wy, kyx = f[k_yx] * wx * wy;
    const cplx j(0.0, 1.0), a = cplx(f[re_a], f[im_a]) * ref_m, b = parts.shaft_bow ? cplx(f[re_b], f[im_b]) * ref_m : cplx(0.0);
    const cplx fx = a * w * w + b * wx * wx, fy = -j * (a * w * w + b * wy * wy);
    const cplx dxx(wx * wx - w * w, 2.0 * zx * wx * w), dyy(wy * wy - w * w, 2.0 * zy * wy * w), det = dxx * dyy - kxy * kyx;
    return {(dyy * fx - kxy * fy) / det, (dxx * fy - kyx * fx) / det};
  }

  // The largest Floquet multiplier's modulus of the contact-free model at speed w: exp(max Re
  // lambda T) over the linear state matrix's eigenvalues lambda (the stiffness matrix of linear_xy,
  // cross-coupling included), T one revolution.
  double contact_free_rho(const std::vector<double>& f, double w) const {
    const double wx = std::exp(f[ln_wx]), wy = std::exp(f[ln_wy]);
    Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
    a(0, 2) = a(1, 3) = 1.0;
    a(2, 0) = -wx * wx, a(2, 1) = -f[k_xy] * wx * wy, a(3, 0) = -f[k_yx] * wx * wy, a(3, 1) = -wy * wy;
    a(2, 2) = -2.0 * std::exp(f[ln_zx]) * wx, a(3, 3) = -2.0 * std::exp(f[ln_zy]) * wy;
    const double growth = Eigen::EigenSolver<Eigen::Matrix4d>(a, false).eigenvalues().real().maxCoeff();
    return std::exp(growth * 2.0 * kPi / w);
  }

  // The model per unit mass at coordinates f.
  std::pair<parameters, effect_parameters> rotor(const std::vector<double>& f) const {
    parameters p;
    const double wx = std::exp(f[ln_wx]), wy = std::exp(f[ln_wy]);
    p.m = 1.0, p.k_x = wx * wx, p.k_y = wy * wy, p.c_x = 2.0 * std::exp(f[ln_zx]) * wx, p.c_y = 2.0 * std::exp(f[ln_zy]) * wy;
    const cplx a = cplx(f[re_a], f[im_a]) * ref_m;
    p.e = std::abs(a), p.unbalance_phase = std::arg(a);
    p.clearance = std::exp(f[ln_delta]), p.k1 = std::exp(f[ln_kappa]), p.mu = f[friction_mu];
    p.k3 = form.cubic ? std::exp(f[ln_cubic]) : 0.0, p.c2 = form.velocity_squared ? std::exp(f[ln_velocity_squared]) : 0.0;
    effect_parameters fx;
    fx.contact_angle = form.contact_angle ? f[contact_theta] : 0.0;
    if (form.hertz) fx.hertz_k = std::exp(f[ln_hertz]);
    if (form.hunt_crossley) fx.hc_exponent = f[hunt_exponent], fx.hc_lambda = std::exp(f[ln_hunt]) / std::pow(hunt_reference_m, f[hunt_exponent]);
    if (parts.shaft_bow) {
      const cplx b = cplx(f[re_b], f[im_b]) * ref_m;
      fx.bow = std::abs(b), fx.bow_phase = std::arg(b);
    }
    fx.k_xy = f[k_xy] * wx * wy, fx.k_yx = f[k_yx] * wx * wy;
    return {p, fx};
  }

  // One row's steady orbit at speed w, shot from `guess`; where Newton finds no stable orbit,
  // settled from there and shot again; where it still finds none, the unstable orbit the motion
  // circles if a shot found one (circled_orbit; the settled shot's where both did), else a transient's last
  // revolution (periodic false). Its 1X and 2X read from one period at kReadSamples. A failed
  // integration is a numerical_error.
  row_orbit shot_row(const parameters& p, const effect_parameters& fx, double w, const state6& guess) {
    row_orbit o;
    const model sys(p, fx, w);
    const double period = sys.period();
    std::optional<state6> on, circled;  // a stable orbit; an unstable one the motion circles
    double rho_on = 0.0, rho_circled = 0.0;
    const auto largest = [](const periodic_orbit<6>& orbit) {
      double m = 0.0;
      for (const auto& mu : orbit.multipliers) m = std::max(m, std::abs(mu));
      return m;
    };
    const auto shoot = [&](const state6& g) {
      shots.add();
      const auto orbit = shoot_fit_orbit(sys, g, 0.0, 1, orbit_options);
      if (orbit.stable()) on = orbit.state, rho_on = largest(orbit);
      else if (circled_orbit(orbit)) circled = orbit.state, rho_circled = largest(orbit);
    };
    shoot(guess);
    state6 start = guess;
    if (!on) {
      null_observer none;
      start = integrate_hybrid(sys, start_state(sys, guess, 0.0), kSettleRevs * period, settle, sample_grid{}, none).s;
      shoot(start);
    }
    if (!on && circled) on = circled, o.circled = true;
    o.periodic = on.has_value() && !o.circled;
    o.rho = o.periodic ? rho_on : o.circled ? rho_circled : std::numeric_limits<double>::infinity();
    std::vector<state6> samples;
    sample_recorder rec{&samples};
    integrate_hybrid(sys, start_state(sys, on ? *on : start, 0.0), period, read, sample_grid(0.0, period / static_cast<double>(kReadSamples), kReadSamples),
                     rec);
    if (on) o.state = *on;
    if (samples.size() != kReadSamples) throw numerical_error("rub fit: a period read " + std::to_string(samples.size()) + " samples");
    double top = -std::numeric_limits<double>::infinity();
    const double nx = std::sin(fx.contact_angle), ny = std::cos(fx.contact_angle);
    for (std::size_t k = 0; k < kReadSamples; ++k) {
      const double t = period * static_cast<double>(k) / static_cast<double>(kReadSamples);
      const cplx e1 = std::polar(2.0 / kReadSamples, -w * t), e2 = std::polar(2.0 / kReadSamples, -2.0 * w * t);
      o.x1 += samples[k][0] * e1, o.y1 += samples[k][1] * e1, o.x2 += samples[k][0] * e2, o.y2 += samples[k][1] * e2;
      const double z = nx * samples[k][idx::x] + ny * samples[k][idx::y] - p.clearance;
      top = std::max(top, z);
      if (z > 0.0) o.approach = std::max(o.approach, nx * samples[k][idx::vx] + ny * samples[k][idx::vy]);
    }
    o.contact = top > 0.0;
    o.penetration = std::max(top, 0.0);
    return o;
  }

  // The guess a row is shot from when no warm orbit is given: the previous speed's orbit, else
  // the contact-free response (a transient's state as a start, tried, led the fits astray:
  // campaign seed 1, scenario 33).
  static state6 contact_free_state(cplx x, cplx y, double w) {
    const cplx j(0.0, 1.0);
    return {x.real(), y.real(), (j * w * x).real(), (j * w * y).real(), 0.0, 0.0};
  }

  // Whether the contact-free response (x, y) stays off the stator: its largest reach along the
  // stator's normal, |n . (x, y)|, within the clearance.
  static bool off_stator(const parameters& p, const effect_parameters& fx, cplx x, cplx y) {
    return std::abs(std::sin(fx.contact_angle) * x + std::cos(fx.contact_angle) * y) <= p.clearance;
  }

  // Every row's steady orbit, along the rows' path (the order the rig ran them): closed form while
  // the contact-free response stays off the stator and the previous row on the path did not touch;
  // else shot (shot_row) from `warm`'s orbit at that row (a finite difference stays on the branch
  // its base point followed), the previous row's, or the contact-free response.
  std::vector<row_orbit> orbits(const std::vector<double>& f, const std::vector<row_orbit>* warm) {
    evaluations.add();
    const auto [p, fx] = rotor(f);
    std::vector<row_orbit> out(table.rows());
    for (const std::size_t i : path.order) {
      const double w = table.rpm[i] * kRpmToRadS;
      const auto [x, y] = linear_xy(f, w);
      const bool warm_shot = warm && (*warm)[i].state;
      const std::size_t before = previous[i];
      const bool previous_contact = before < table.rows() && out[before].contact;
      if (!warm_shot && !previous_contact && off_stator(p, fx, x, y)) {
        out[i].x1 = x, out[i].y1 = y;
        out[i].closed_form = true;
        continue;
      }
      const state6 guess = warm_shot ? *(*warm)[i].state : before < table.rows() && out[before].state ? *out[before].state : contact_free_state(x, y, w);
      out[i] = shot_row(p, fx, w, guess);
    }
    return out;
  }

  // Weighted residuals (re, im per probe and row) at coordinates q; each probe's runout solved
  // (the mean of data minus model over the fitted rows) or given. Nothing where some row's orbit
  // cannot be computed: the point is rejected, never read.
  std::optional<Eigen::VectorXd> residuals(const std::vector<double>& q, const std::vector<row_orbit>* warm, std::vector<row_orbit>* read,
                                           std::vector<cplx>& runout, const std::vector<cplx>* fixed) {
    std::vector<row_orbit> o;
    const std::vector<double> f = full(q, base);
    try {
      o = orbits(f, warm);
    } catch (const numerical_error&) {
      return std::nullopt;
    }
    Eigen::VectorXd r(static_cast<Eigen::Index>(2 * rows.size() * orders.size()));
    runout.assign(orders.size(), 0.0);
    for (std::size_t p = 0; p < orders.size(); ++p) {
      const double c = std::cos(beta_of(f, p)), s = std::sin(beta_of(f, p));
      const auto reading = [&](std::size_t i) { return c * o[i].x1 + s * o[i].y1; };
      if (fixed) {
        runout[p] = (*fixed)[p];
      } else {
        for (const std::size_t i : rows) runout[p] += table.orders[orders[p]].vector[i] - reading(i);
        runout[p] /= static_cast<double>(rows.size());
      }
      for (std::size_t k = 0; k < rows.size(); ++k) {
        const cplx e = (table.orders[orders[p]].vector[rows[k]] - reading(rows[k]) - runout[p]) / sigma[p];
        const auto at = static_cast<Eigen::Index>(2 * (p * rows.size() + k));
        r(at) = e.real(), r(at + 1) = e.imag();
      }
    }
    if (read) *read = std::move(o);
    return r;
  }

  // The residuals' derivative at q, whose rows' orbits are `at`, from the orbits' exact
  // sensitivities (ref/integrate/parameter_columns.hpp; docs/loop.md, "Exact sensitivities"): a
  // shot row's 1X from one flow of its orbit's sensitivities in every free coordinate (a circled
  // orbit's too: the implicit-function theorem asks only that no multiplier lie at 1), a
  // closed-form row's from central differences of the closed form; the sources are central
  // differences of the moved models at the same states. A row whose orbit is a transient's last
  // revolution, or whose sensitivities cannot be had, has none: with rows_lacking::differenced
  // that row alone is differenced (forward, the solver's step, as the whole evaluation would be:
  // shot from `at`'s orbits), else, or where that fails too, nothing (the caller differences every
  // row then). rows_lacking::every_shot_row differences every shot row so (the test of that path).
  enum class rows_lacking { none, differenced, every_shot_row };
  std::optional<Eigen::MatrixXd> exact_jacobian(const std::vector<double>& q, const std::vector<row_orbit>& at, const std::vector<cplx>* fixed,
                                                rows_lacking lacking_rows) {
    // The sources' step in the coordinates (each of order 1: logarithms, shares, sizes over ref_m).
    constexpr double kStep = 1e-4;
    constexpr int kColumns = kFitColumnsPerFlow;
    using columns_system = fit_columns_system<identified>;
    const std::size_t n = q.size();
    const std::vector<double> f = full(q, base);
    std::vector<std::vector<double>> up(n), down(n);
    for (std::size_t k = 0; k < n; ++k) {
      std::vector<double> a = q, b = q;
      a[k] += kStep, b[k] -= kStep;
      up[k] = full(a, base), down[k] = full(b, base);
    }
    const std::pair<parameters, effect_parameters> here = rotor(f);  // named: the row tasks below capture it
    const parameters& p = here.first;
    const effect_parameters& fx = here.second;
    const integration_options opt = fit_shooting(1, orbit_options).integration;
    const double tolerance = orbit_options.orbit_error();
    const double difference_step = default_of("rub_fit", "difference_step");
    Eigen::MatrixXcd dX = Eigen::MatrixXcd::Zero(static_cast<Eigen::Index>(table.rows()), static_cast<Eigen::Index>(n)), dY = dX;
    // Row i's 1X at coordinates g as orbits(g, &at) reads it, its previous row taken as `at` has it.
    const auto reading_moved = [&](std::size_t i, const std::vector<double>& g) -> std::optional<std::pair<cplx, cplx>> {
      const double w = table.rpm[i] * kRpmToRadS;
      const auto [pg, fg] = rotor(g);
      const auto [x, y] = linear_xy(g, w);
      const std::size_t before = previous[i];
      const bool previous_contact = before < table.rows() && at[before].contact;
      if (!at[i].state && !previous_contact && off_stator(pg, fg, x, y)) return std::pair{x, y};
      const state6 guess = at[i].state ? *at[i].state : before < table.rows() && at[before].state ? *at[before].state : contact_free_state(x, y, w);
      try {
        const row_orbit o = shot_row(pg, fg, w, guess);
        return std::pair{o.x1, o.y1};
      } catch (const numerical_error&) {
        return std::nullopt;
      }
    };
    // Row i differenced in every coordinate: forward, backward where the forward point fails
    // (forward_difference_jacobian's rule).
    const auto difference_row = [&](std::size_t i) {
      const auto r = static_cast<Eigen::Index>(i);
      for (std::size_t k = 0; k < n; ++k) {
        const double h = difference_step * std::max(1.0, std::abs(q[k]));
        bool done = false;
        for (const double signed_h : {h, -h}) {
          std::vector<double> g = q;
          g[k] += signed_h;
          if (const auto xy = reading_moved(i, full(g, base))) {
            dX(r, static_cast<Eigen::Index>(k)) = (xy->first - at[i].x1) / signed_h, dY(r, static_cast<Eigen::Index>(k)) = (xy->second - at[i].y1) / signed_h;
            done = true;
            break;
          }
        }
        if (!done) return false;
      }
      return true;
    };
    // Row by row on the machine's threads: each task writes its own row of dX and dY.
    std::vector<char> lacking(rows.size(), 0);  // a row whose derivative cannot be had
    parallel_for(rows.size(), 0, [&](std::size_t m) {
      const std::size_t i = rows[m];
      const double w = table.rpm[i] * kRpmToRadS;
      const auto r = static_cast<Eigen::Index>(i);
      if (at[i].closed_form) {
        for (std::size_t k = 0; k < n; ++k) {
          const auto [xu, yu] = linear_xy(up[k], w);
          const auto [xd, yd] = linear_xy(down[k], w);
          dX(r, static_cast<Eigen::Index>(k)) = (xu - xd) / (2.0 * kStep), dY(r, static_cast<Eigen::Index>(k)) = (yu - yd) / (2.0 * kStep);
        }
        return;
      }
      const auto exact_row = [&]() {
        if (!at[i].state) return false;
        const model sys(p, fx, w);
        const double period = sys.period();
        for (std::size_t first = 0; first < n; first += kColumns) {
          const std::size_t count = std::min<std::size_t>(kColumns, n - first);
          std::vector<model> ups, downs;
          for (std::size_t c = 0; c < count; ++c) {
            const auto [pu, fu] = rotor(up[first + c]);
            const auto [pd, fd] = rotor(down[first + c]);
            ups.emplace_back(pu, fu, w), downs.emplace_back(pd, fd, w);
            if (ups.back().moving_states() != sys.moving_states() || downs.back().moving_states() != sys.moving_states()) return false;
          }
          try {
            const columns_system aug(sys, std::move(ups), std::move(downs), std::vector<double>(count, 2.0 * kStep));
            const auto oc = periodic_orbit_columns(aug, *at[i].state, 0.0, 1, opt,
                                                   sample_grid(0.0, period / static_cast<double>(kReadSamples), kReadSamples), tolerance);
            // The 1X as orbits() reads it: (2 / K) sum of the samples turned by e^{-i w t}.
            for (std::size_t s = 0; s < kReadSamples; ++s) {
              const double t = period * static_cast<double>(s) / static_cast<double>(kReadSamples);
              const cplx e1 = std::polar(2.0 / kReadSamples, -w * t);
              for (std::size_t c = 0; c < count; ++c) {
                const auto col = static_cast<Eigen::Index>(first + c);
                dX(r, col) += oc.at[s](idx::x, static_cast<Eigen::Index>(c)) * e1;
                dY(r, col) += oc.at[s](idx::y, static_cast<Eigen::Index>(c)) * e1;
              }
            }
          } catch (const numerical_error&) {
            return false;
          }
        }
        return true;
      };
      if (lacking_rows != rows_lacking::every_shot_row && exact_row()) return;
      dX.row(r).setZero(), dY.row(r).setZero();
      if (lacking_rows == rows_lacking::none || !difference_row(i)) lacking[m] = 1;
    });
    if (std::find(lacking.begin(), lacking.end(), 1) != lacking.end()) return std::nullopt;
    // Residual (data - reading - runout) / sigma: the reading's derivative, less its mean over the
    // fitted rows where the runout is solved (the mean of data - reading); a fitted probe angle's
    // column the reading's own turn (the orbits do not move with it).
    Eigen::MatrixXd J(static_cast<Eigen::Index>(2 * rows.size() * orders.size()), static_cast<Eigen::Index>(n));
    const auto beta_column = static_cast<std::size_t>(std::find(free.begin(), free.end(), probe_beta) - free.begin());
    for (std::size_t pr = 0; pr < orders.size(); ++pr) {
      const double c = std::cos(beta_of(f, pr)), s = std::sin(beta_of(f, pr));
      for (std::size_t k = 0; k < n; ++k) {
        const auto col = static_cast<Eigen::Index>(k);
        const auto d_reading = [&](std::size_t i) {
          const auto r = static_cast<Eigen::Index>(i);
          return c * dX(r, col) + s * dY(r, col) + (k == beta_column ? -s * at[i].x1 + c * at[i].y1 : cplx(0.0));
        };
        cplx mean = 0.0;
        if (!fixed) {
          for (const std::size_t i : rows) mean += d_reading(i);
          mean /= static_cast<double>(rows.size());
        }
        for (std::size_t m = 0; m < rows.size(); ++m) {
          const cplx e = -(d_reading(rows[m]) - mean) / sigma[pr];
          const auto row = static_cast<Eigen::Index>(2 * (pr * rows.size() + m));
          J(row, col) = e.real(), J(row + 1, col) = e.imag();
        }
      }
    }
    if (!J.allFinite()) return std::nullopt;
    return J;
  }

  // The residuals' derivative at q (residuals r0 there, its rows' orbits `at`): exact
  // (exact_jacobian, a row without sensitivities differenced alone) where it can be had, else
  // forward differences of whole evaluations, every row started from `at`.
  Eigen::MatrixXd jacobian(const std::vector<double>& q, const Eigen::VectorXd& r0, const std::vector<row_orbit>& at, const std::vector<cplx>* fixed) {
    if (auto J = exact_jacobian(q, at, fixed, rows_lacking::differenced)) return *J;
    return differenced_jacobian(q, r0, at, fixed);
  }
  Eigen::MatrixXd differenced_jacobian(const std::vector<double>& q, const Eigen::VectorXd& r0, const std::vector<row_orbit>& at, const std::vector<cplx>* fixed) {
    least_squares_problem warm;
    warm.residuals = [this, fixed, &at](const Eigen::VectorXd& v) {
      std::vector<cplx> ignored;
      return residuals(std::vector<double>(v.data(), v.data() + v.size()), &at, nullptr, ignored, fixed);
    };
    return forward_difference_jacobian(warm, Eigen::Map<const Eigen::VectorXd>(q.data(), static_cast<Eigen::Index>(q.size())), r0,
                                       default_of("rub_fit", "difference_step"));
  }

  // The solver's problem (ref/inference/least_squares.hpp) in the free coordinates, inside their
  // box: the residuals (runouts solved for, or `fixed`), and a Jacobian whose forward differences
  // start every row from the orbits of the point they differ from (so that each stays on the
  // branch that point followed).
  // One solve's problem: a solve is one thread's, so each has its own (its recent orbits below).
  least_squares_problem solver_problem(const std::vector<cplx>* fixed = nullptr) {
    least_squares_problem lsq;
    const auto as_q = [](const Eigen::VectorXd& u) { return std::vector<double>(u.data(), u.data() + u.size()); };
    // The orbits of the solve's last few evaluations: its Jacobian is taken at its point, whose
    // orbits the evaluation that accepted it made (a point's orbits are a function of the point:
    // the same bits as evaluating it again, at none of the cost).
    struct evaluated {
      std::vector<double> q;
      std::vector<row_orbit> orbits;
    };
    constexpr std::size_t kRecent = 4;
    auto recent = std::make_shared<std::deque<evaluated>>();
    lsq.residuals = [this, fixed, as_q, recent](const Eigen::VectorXd& u) {
      std::vector<cplx> runout;
      evaluated e{as_q(u), {}};
      auto r = residuals(e.q, nullptr, &e.orbits, runout, fixed);
      if (r) {
        recent->push_back(std::move(e));
        if (recent->size() > kRecent) recent->pop_front();
      }
      return r;
    };
    lsq.jacobian = [this, fixed, as_q, recent](const Eigen::VectorXd& u, const Eigen::VectorXd& r0) {
      const std::vector<double> q = as_q(u);
      for (auto e = recent->rbegin(); e != recent->rend(); ++e)
        if (e->q == q) return jacobian(q, r0, e->orbits, fixed);
      std::vector<row_orbit> here;
      std::vector<cplx> runout;
      (void)residuals(q, nullptr, &here, runout, fixed);
      return jacobian(q, r0, here, fixed);
    };
    std::vector<double> lo(kRubSlots, -std::numeric_limits<double>::infinity()), hi(kRubSlots, std::numeric_limits<double>::infinity());
    for (const std::size_t k : {ln_wx, ln_wy}) lo[k] = std::log(w_lo), hi[k] = std::log(w_hi);
    for (const std::size_t k : {ln_zx, ln_zy}) lo[k] = std::log(1e-4), hi[k] = std::log(2.0);
    for (const std::size_t k : {k_xy, k_yx}) lo[k] = -0.5, hi[k] = 0.5;
    lo[ln_delta] = std::log(kClearanceLo * peak_m), hi[ln_delta] = std::log(kClearanceHi * peak_m);
    lo[ln_kappa] = 2.0 * std::log(w_lo), hi[ln_kappa] = std::log(kStiffnessHi * w_hi * w_hi);
    lo[friction_mu] = 0.0, hi[friction_mu] = 1.0;
    lo[ln_cubic] = std::log(cubic_parity / kTermBox), hi[ln_cubic] = std::log(cubic_parity * kTermBox);
    lo[ln_velocity_squared] = std::log(velocity_squared_parity / kTermBox), hi[ln_velocity_squared] = std::log(velocity_squared_parity * kTermBox);
    lo[ln_hertz] = std::log(hertz_parity / kTermBox), hi[ln_hertz] = std::log(hertz_parity * kTermBox);
    lo[ln_hunt] = std::log(hunt_parity / kTermBox), hi[ln_hunt] = std::log(hunt_parity * kTermBox);
    lo[hunt_exponent] = kHuntExponentLo, hi[hunt_exponent] = kHuntExponentHi;
    lo[contact_theta] = -kPi, hi[contact_theta] = kPi;
    lo[probe_beta] = -kPi, hi[probe_beta] = kPi;
    const std::vector<double> l = reduce(lo), h = reduce(hi);
    lsq.lower = Eigen::Map<const Eigen::VectorXd>(l.data(), static_cast<Eigen::Index>(l.size()));
    lsq.upper = Eigen::Map<const Eigen::VectorXd>(h.data(), static_cast<Eigen::Index>(h.size()));
    return lsq;
  }
};

}  // namespace

namespace {

// The fit's problem: every probe's declared angle (the stator is at +y of them, or at its fitted
// angle), the rows and their path, the noise, the table's speed range, the form, the coordinates
// the linear fit's parts free, and the linear fit's coordinates and amplitudes as the start f0
// (pr.base).
rub_problem set_up(const order_table& table, const response_fit& linear, const rub_fit_options& options) {
  if (linear.probes.empty() || linear.theta.empty()) throw input_error("fit_rub: the 1X fit it starts from has no probes");
  rub_problem pr(table, linear.parts);
  pr.rows = options.rows;
  pr.form = options.form ? *options.form : options.start ? options.start->form : rub_form{};
  // One probe whose angle is not declared: fitted by the 1X fit (anisotropic) or any (isotropic).
  pr.undeclared = linear.probes.size() == 1 && (linear.probe_angle_fitted[0] || !(linear.probe_angle_deg[0].hi - linear.probe_angle_deg[0].lo < 1e-9));
  if (pr.undeclared) pr.form.contact_angle = true;  // the stator's direction against the probe is unknown
  pr.path = rows_as_run(table);
  pr.previous.assign(table.rows(), table.rows());
  for (std::size_t k = 1; k < pr.path.order.size(); ++k) pr.previous[pr.path.order[k]] = pr.path.order[k - 1];
  for (std::size_t p = 0; p < linear.probes.size(); ++p) {
    if (!pr.undeclared && (linear.probe_angle_fitted[p] || !(linear.probe_angle_deg[p].hi - linear.probe_angle_deg[p].lo < 1e-9)))
      throw input_error(table.source + ": the rub fit needs every probe's angle declared where there are two (the stator is at +y of those angles)");
    const auto at = std::find_if(table.orders.begin(), table.orders.end(), [&](const tracked_order& o) { return o.order == 1 && o.probe == linear.probes[p]; });
    pr.orders.push_back(static_cast<std::size_t>(at - table.orders.begin()));
    pr.beta.push_back(linear.probe_angle_deg[p].value * kPi / 180.0);
  }
  pr.sigma = options.noise_m.empty() ? linear.noise_m : options.noise_m;
  if (pr.rows.empty())
    for (std::size_t i = 0; i < table.rows(); ++i) pr.rows.push_back(i);
  for (const std::size_t i : options.freed_rows) {
    if (i >= table.rows()) throw input_error(table.source + ": the rub fit was asked to free row " + std::to_string(i) + " of " + std::to_string(table.rows()));
    const auto at = std::find(pr.rows.begin(), pr.rows.end(), i);
    if (at != pr.rows.end()) pr.rows.erase(at), pr.freed.push_back(i);
  }
  std::sort(pr.freed.begin(), pr.freed.end());
  if (pr.rows.empty()) throw input_error(table.source + ": the rub fit has no rows left to fit");
  double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  for (const std::size_t i : pr.rows) lo = std::min(lo, table.rpm[i]), hi = std::max(hi, table.rpm[i]);
  pr.w_lo = lo * kRpmToRadS, pr.w_hi = hi * kRpmToRadS;
  pr.lay_out();
  std::vector<double> f0(kRubSlots, 0.0);
  for (std::size_t k = 0; k < kSlots; ++k) f0[k] = linear.theta[k];
  pr.ref_m = std::max(std::abs(linear.amplitudes[0]), 1e-12);
  f0[re_a] = linear.amplitudes[0].real() / pr.ref_m, f0[im_a] = linear.amplitudes[0].imag() / pr.ref_m;
  if (linear.parts.shaft_bow) f0[re_b] = linear.amplitudes.back().real() / pr.ref_m, f0[im_b] = linear.amplitudes.back().imag() / pr.ref_m;
  pr.base = f0;
  double largest_reading = 0.0;
  for (const std::size_t o : pr.orders)
    for (const cplx v : table.orders[o].vector) largest_reading = std::max(largest_reading, std::abs(v));
  pr.hunt_reference_m = kHuntReferenceShare * std::max(largest_reading, 1e-12);
  pr.use(options.orbits);
  return pr;
}

// Each start's cost (its squared residuals, infinite where some orbit cannot be computed) on the
// machine's threads, into its own slot, from orbits at kRankLoosening times the fit's tolerances
// (counted as the fit's evaluations and shots); the best kFittedStarts of them, best first, the
// last of them the best whose orbits touch where none of the others does: a start that touches
// nowhere gives the contact's coordinates no gradient, and its fit ends where it began (a
// coast-down's lower branch read contact-free fits better than a contact on the wrong branch).
// With `distinct_directions`, no two of the stator's direction: the grid's turns around the
// circle (one undeclared probe) rank nearly alike in pairs, and the best two alone are one basin.
std::vector<std::vector<double>> ranked(rub_problem& pr, const std::vector<std::vector<double>>& starts, bool distinct_directions = false) {
  rub_problem ranking = pr.loosened(kRankLoosening);
  const long long evaluations = ranking.evaluations.value(), shots = ranking.shots.value();
  std::vector<double> cost(starts.size());
  std::vector<char> touches(starts.size(), 0);
  parallel_for(starts.size(), 0, [&](std::size_t i) {
    std::vector<cplx> runout;
    std::vector<row_orbit> orbits;
    const auto r = ranking.residuals(starts[i], nullptr, &orbits, runout, nullptr);
    cost[i] = r && r->allFinite() ? r->squaredNorm() : std::numeric_limits<double>::infinity();
    touches[i] = r && std::any_of(orbits.begin(), orbits.end(), [](const row_orbit& o) { return o.contact; });
  });
  pr.evaluations.add(ranking.evaluations.value() - evaluations), pr.shots.add(ranking.shots.value() - shots);
  std::vector<std::size_t> order(starts.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return cost[a] < cost[b]; });
  std::vector<std::size_t> picked;
  const auto direction = [&](std::size_t i) { return pr.full(starts[i], pr.base)[contact_theta]; };
  for (std::size_t k = 0; k < order.size() && picked.size() < kFittedStarts; ++k)
    if (std::isfinite(cost[order[k]]) &&
        (!distinct_directions || std::none_of(picked.begin(), picked.end(), [&](std::size_t i) { return direction(i) == direction(order[k]); })))
      picked.push_back(order[k]);
  const auto touching = [&](std::size_t i) { return touches[i] != 0; };
  if (!picked.empty() && std::none_of(picked.begin(), picked.end(), touching))
    for (const std::size_t i : order)
      if (touching(i) && std::isfinite(cost[i])) {
        if (picked.size() == kFittedStarts) picked.back() = i;
        else picked.push_back(i);
        break;
      }
  std::vector<std::vector<double>> from;
  for (const std::size_t i : picked) from.push_back(starts[i]);
  return from;
}

// The form's terms at parity with k1 z at a fit's largest penetration z and approach speed v
// (k3 z^2 = k1; c2 v^2 = k1 z); where it does not touch, at a thousandth of the peak and the
// highest speed's rate through it.
void parities_from(rub_problem& pr, const std::vector<double>& f, double penetration, double approach) {
  const double kappa = std::exp(f[ln_kappa]);
  const double z = penetration > 0.0 ? penetration : 1e-3 * pr.peak_m;
  const double v = approach > 0.0 ? approach : pr.w_hi * z;
  pr.cubic_parity = kappa / (z * z), pr.velocity_squared_parity = kappa * z / (v * v);
  // k_h z^1.5 = k1 z; lambda z^p v = k1 z, as its size at the reference: (lambda z_ref^p) v (z/z_ref)^p = k1 z
  pr.hertz_parity = kappa / std::sqrt(z);
  pr.hunt_parity = kappa * z / v * std::pow(pr.hunt_reference_m / z, kHuntExponentStart);
}

// A fit's point with the form's terms it lacks (`had`) laid in: each at `share` of parity, the
// stator turned by `turn` from where it was (0: at the top).
std::vector<double> with_terms(const rub_problem& pr, std::vector<double> f, const rub_form& had, double share, double turn) {
  if (pr.form.cubic && !had.cubic) f[ln_cubic] = std::log(share * pr.cubic_parity);
  if (pr.form.velocity_squared && !had.velocity_squared) f[ln_velocity_squared] = std::log(share * pr.velocity_squared_parity);
  if (pr.form.hertz && !had.hertz) f[ln_hertz] = std::log(share * pr.hertz_parity);
  if (pr.form.hunt_crossley && !had.hunt_crossley) f[ln_hunt] = std::log(share * pr.hunt_parity), f[hunt_exponent] = kHuntExponentStart;
  if (pr.form.contact_angle) f[contact_theta] = std::remainder((had.contact_angle ? f[contact_theta] : 0.0) + turn, 2.0 * kPi);
  return f;
}

// The starts a fit is made from, and a floor: the point of the fit it grows with the new terms all
// but off, fitted only where every start ends above it (a grown form contains the one it grows, so
// its fit must not end above it; fitted always, it would add a fit to every form try, where the
// starts mostly end below it).
struct fit_starts_set {
  std::vector<std::vector<double>> fitted;
  std::optional<std::vector<double>> floor;
};

// A fit of other parts as a start: of fewer, with this fit's extra parts off (equal modes, no bow,
// no cross-coupling); of more, with its extra parts dropped (an isotropic fit keeps x's mode); its
// unbalance and bow rescaled to this fit's reference size, and the terms this form has and it
// lacks laid in at the first share.
std::vector<double> other_fit_start(const rub_problem& pr, const rub_fit& other) {
  std::vector<double> f = other.q;
  const double rescale = other.ref_m / pr.ref_m;
  for (const std::size_t k : {re_a, im_a, re_b, im_b}) f[k] *= rescale;
  return pr.clamp(pr.reduce(with_terms(pr, f, other.form, kTermShares[0], 0.0)));
}

// From a fit of a smaller form: its point with each new term at each share, the stator (where new)
// at the top and turned either side, and `form_from`'s terms where given, ranked; the best of the
// fits of other parts (`also`, with their terms); and as the floor its point with the new terms
// all but off. From one of the same form and no others: its point alone.
fit_starts_set starts_from_fit(rub_problem& pr, const rub_fit& start, const rub_fit* form_from,
                                                 const std::vector<const rub_fit*>& also) {
  pr.base = start.q;
  pr.ref_m = start.ref_m;
  parities_from(pr, start.q, start.penetration_m, start.approach_speed_m_s);
  const rub_form& had = start.form;
  const bool new_terms = (pr.form.cubic && !had.cubic) || (pr.form.velocity_squared && !had.velocity_squared) || (pr.form.hertz && !had.hertz) ||
                         (pr.form.hunt_crossley && !had.hunt_crossley);
  const bool new_angle = pr.form.contact_angle && !had.contact_angle;
  const std::vector<double> nested = pr.clamp(pr.reduce(with_terms(pr, start.q, had, kTermNullShare, 0.0)));
  if (!new_terms && !new_angle && also.empty()) return {{nested}, std::nullopt};
  std::vector<double> turns{0.0};
  if (new_angle) turns.insert(turns.end(), std::begin(kAngleSteps), std::end(kAngleSteps));
  std::vector<std::vector<double>> starts;
  for (const double share : new_terms ? std::vector<double>(std::begin(kTermShares), std::end(kTermShares)) : std::vector<double>{1.0})
    for (const double turn : turns) starts.push_back(pr.clamp(pr.reduce(with_terms(pr, start.q, had, share, turn))));
  if (form_from) {
    std::vector<double> f = start.q;
    for (const std::size_t k : {ln_cubic, ln_velocity_squared, contact_theta, ln_hertz, ln_hunt, hunt_exponent}) f[k] = form_from->q[k];
    starts.push_back(pr.clamp(pr.reduce(with_terms(pr, f, form_from->form, kTermShares[0], 0.0))));
  }
  // Ranked apart, so that they add to the starts the own fit's ranking picks and never displace
  // one (ranked by their first cost, the other fits' points outranked the start that fitted best,
  // and the grown fit ended far above it: campaign seed 6464, #186).
  auto picked = ranked(pr, starts);
  std::vector<std::vector<double>> others;
  for (const rub_fit* other : also) others.push_back(other_fit_start(pr, *other));
  const auto add = [&picked](const std::vector<double>& q) {
    if (std::find(picked.begin(), picked.end(), q) == picked.end()) picked.push_back(q);
  };
  if (!others.empty())
    if (const auto best = ranked(pr, others); !best.empty()) add(best.front());
  return {picked, nested};
}

// The starts, best first by their residual (the best kFittedStarts of them), or those from the
// given fit (starts_from_fit). The clearance's scales: the linear fit's largest amplitude along
// the stator's normal (every direction where the stator's is fitted) over the table's speeds and
// the table's largest 1X reading (a hardening branch carried past the critical speed reads larger
// than any contact-free fit); the clearance's bounds from the larger.
fit_starts_set starts_of(rub_problem& pr, const rub_fit_options& options) {
  const std::vector<double> f0 = pr.base;
  double linear_peak = 0.0, data_peak = 0.0;
  constexpr int kDirections = 36;  // 5 degrees apart: the ellipse's reach to within 0.4 %
  for (std::size_t i = 0; i < pr.table.rows(); ++i) {
    const auto [x, y] = pr.linear_xy(f0, pr.table.rpm[i] * kRpmToRadS);
    linear_peak = std::max(linear_peak, std::abs(y));
    if (pr.form.contact_angle)
      for (int d = 0; d < kDirections; ++d) linear_peak = std::max(linear_peak, std::abs(std::sin(d * kPi / kDirections) * x + std::cos(d * kPi / kDirections) * y));
    for (const std::size_t o : pr.orders) data_peak = std::max(data_peak, std::abs(pr.table.orders[o].vector[i]));
  }
  pr.peak_m = std::max(linear_peak, data_peak);
  if (!(pr.peak_m > 0.0)) throw numerical_error(pr.table.source + ": the 1X fit it starts from has no response");
  if (options.start) return starts_from_fit(pr, *options.start, options.form_from, options.also_from);
  parities_from(pr, f0, 0.0, 0.0);
  // The stator's direction where it is fitted from the grid (one undeclared probe): over the half circle.
  std::vector<double> turns{0.0};
  if (pr.form.contact_angle) turns.insert(turns.end(), std::begin(kAngleStepsAround), std::end(kAngleStepsAround));
  std::vector<std::vector<double>> starts;
  for (const double scale : {linear_peak, data_peak})
    for (const double share : kClearanceShares)
      for (const double ratio : kStiffnessRatios)
        for (const double damping : kDampingShares) {
          if (!options.grid || !(scale > 0.0)) break;
          std::vector<double> f = f0;
          f[ln_delta] = std::log(share * scale), f[ln_kappa] = std::log(ratio) + 2.0 * f0[ln_wx], f[friction_mu] = kFrictionStart;
          f[ln_zx] += std::log(damping), f[ln_zy] += std::log(damping);
          for (const double turn : turns) starts.push_back(pr.clamp(pr.reduce(with_terms(pr, f, rub_form{}, kTermShares[0], turn))));
        }
  for (const rub_fit* other : options.also_from) starts.push_back(other_fit_start(pr, *other));
  return {ranked(pr, starts, pr.form.contact_angle), std::nullopt};
}

// The best fit from the starts, by the one solver, and how much lower its minimum may lie (chi^2).
std::pair<std::vector<double>, double> best_fit(rub_problem& pr, const fit_starts_set& starts) {
  const std::vector<std::vector<double>>& from = starts.fitted;
  least_squares_options o;
  o.max_jacobians = default_count_of("rub_fit", "max_jacobians");
  o.difference_step = default_of("rub_fit", "difference_step");
  // One fit per start on the machine's threads, each into its own slot; the lowest wins, the
  // first of equals (the order a single thread would meet them in).
  std::vector<least_squares_result> fits(from.size());
  parallel_for(from.size(), 0, [&](std::size_t i) {
    fits[i] = solve_least_squares(pr.solver_problem(), Eigen::Map<const Eigen::VectorXd>(from[i].data(), static_cast<Eigen::Index>(from[i].size())), o);
  });
  std::vector<double> best_q;
  double best_cost = std::numeric_limits<double>::infinity(), best_remaining = 0.0;
  for (const auto& f : fits)
    if (f.ok && f.cost < best_cost) best_cost = f.cost, best_remaining = f.remaining, best_q.assign(f.u.data(), f.u.data() + f.u.size());
  if (starts.floor) {
    // The floor where every start ended above it: its own descent (one Jacobian: it starts at the
    // grown fit's optimum with a term that barely acts), kept where lower.
    const Eigen::Map<const Eigen::VectorXd> u(starts.floor->data(), static_cast<Eigen::Index>(starts.floor->size()));
    const auto r = pr.solver_problem().residuals(u);
    if (r && r->allFinite() && r->squaredNorm() < best_cost) {
      least_squares_options once = o;
      once.max_jacobians = 1;
      const least_squares_result f = solve_least_squares(pr.solver_problem(), u, once);
      if (f.ok && f.cost < best_cost) best_cost = f.cost, best_remaining = f.remaining, best_q.assign(f.u.data(), f.u.data() + f.u.size());
    }
  }
  if (!std::isfinite(best_cost)) throw numerical_error(pr.table.source + ": the rub fit found no point whose every orbit could be computed");
  return {best_q, best_remaining};
}

// The modes, unbalance, bow and cross-coupling with their 95 % intervals from the covariance of
// the free coordinates (its first columns), and the rows in contact.
void linear_estimates_into(rub_fit& f, const rub_problem& pr, const std::vector<double>& best, const fit_covariance& cc, const std::vector<double>& best_q) {
  const evidence_rules rules;
  const auto index_of = [&](std::size_t slot) {
    if (!pr.parts.anisotropy && slot == ln_wy) slot = ln_wx;
    if (!pr.parts.anisotropy && slot == ln_zy) slot = ln_zx;
    return static_cast<std::size_t>(std::find(pr.free.begin(), pr.free.end(), slot) - pr.free.begin());
  };
  const auto sd_of = [&](std::size_t slot) { return cc.standard_deviation(static_cast<Eigen::Index>(index_of(slot))); };
  const auto polar_of = [&](std::size_t k, double unit) {
    const auto i = static_cast<Eigen::Index>(k);
    const double inf = std::numeric_limits<double>::infinity();
    if (cc.unconstrained[k] || cc.unconstrained[k + 1]) return polar_estimate(cplx(best_q[k], best_q[k + 1]) * unit, inf, inf, inf);
    return polar_estimate(cplx(best_q[k], best_q[k + 1]) * unit, cc.cov(i, i) * unit * unit, cc.cov(i + 1, i + 1) * unit * unit, cc.cov(i, i + 1) * unit * unit);
  };
  for (int m = 0; m < (pr.parts.anisotropy ? 2 : 1); ++m) {
    const std::size_t w_slot = m == 0 ? ln_wx : ln_wy, z_slot = m == 0 ? ln_zx : ln_zy;
    response_mode mode;
    mode.axis = !pr.parts.anisotropy ? "both" : (m == 0 ? "x" : "y");
    mode.critical_speed_rpm = log_estimate(best[w_slot], sd_of(w_slot), kRpmToRadS, rules.max_interval_ratio);
    mode.damping_ratio = log_estimate(best[z_slot], sd_of(z_slot), 1.0, rules.max_interval_ratio);
    mode.at_edge = best[w_slot] <= std::log(pr.w_lo) + 1e-9 || best[w_slot] >= std::log(pr.w_hi) - 1e-9;
    if (mode.at_edge) mode.critical_speed_rpm.determined = mode.damping_ratio.determined = false;
    f.modes.push_back(mode);
  }
  if (f.modes.size() == 2 && f.modes[1].critical_speed_rpm.value < f.modes[0].critical_speed_rpm.value) std::swap(f.modes[0], f.modes[1]);
  std::tie(f.unbalance_m, f.unbalance_phase_deg) = polar_of(index_of(re_a), pr.ref_m);
  if (pr.parts.shaft_bow) std::tie(f.bow_m, f.bow_phase_deg) = polar_of(index_of(re_b), pr.ref_m);
  if (pr.parts.cross_coupling) {
    const double w2 = std::exp(best[ln_wx] + best[ln_wy]);
    for (const std::size_t slot : {k_xy, k_yx}) {
      const double val = best[slot] * w2, s = sd_of(slot) * w2;
      (slot == k_xy ? f.k_xy_over_m : f.k_yx_over_m) = {val, val - kZ95 * s, val + kZ95 * s, std::isfinite(s) && std::abs(val) > kZ95 * s};
    }
  }
  // The clearance is determined when its interval spans less than the rules' ratio and some rows
  // touch; the stiffness's interval says how far the table pins it (a stiff stator reads alike
  // over decades); the friction is determined when its interval excludes 0.
  f.clearance_m = log_estimate(best[ln_delta], sd_of(ln_delta), 1.0, rules.max_interval_ratio);
  f.clearance_m.determined = f.clearance_m.determined && f.rows_in_contact > 0;
  f.contact_stiffness_over_m = log_estimate(best[ln_kappa], sd_of(ln_kappa), 1.0, rules.max_interval_ratio);
  const double mu = best[friction_mu], s = sd_of(friction_mu);
  f.friction = {mu, std::max(0.0, mu - kZ95 * s), mu + kZ95 * s, std::isfinite(s) && mu > kZ95 * s};
  // The form's terms as the clearance (their interval's span), the stator's direction as an angle.
  if (pr.form.cubic) f.cubic_stiffness_over_m = log_estimate(best[ln_cubic], sd_of(ln_cubic), 1.0, rules.max_interval_ratio);
  if (pr.form.velocity_squared) f.velocity_squared_over_m = log_estimate(best[ln_velocity_squared], sd_of(ln_velocity_squared), 1.0, rules.max_interval_ratio);
  if (pr.form.hertz) f.hertz_over_m = log_estimate(best[ln_hertz], sd_of(ln_hertz), 1.0, rules.max_interval_ratio);
  if (pr.form.hunt_crossley) {
    // Its size at the reference decides (the coordinate fitted); lambda = that / z_ref^p, its
    // interval from the covariance of both (ln lambda = ln size - p ln z_ref).
    const double p = best[hunt_exponent], ln_ref = std::log(pr.hunt_reference_m);
    f.hunt_crossley_reference_m = pr.hunt_reference_m;
    f.hunt_crossley_at_reference = log_estimate(best[ln_hunt], sd_of(ln_hunt), 1.0, rules.max_interval_ratio);
    Eigen::VectorXd along = Eigen::VectorXd::Zero(cc.cov.rows());
    along(static_cast<Eigen::Index>(index_of(ln_hunt))) = 1.0, along(static_cast<Eigen::Index>(index_of(hunt_exponent))) = -ln_ref;
    f.hunt_crossley_over_m = log_estimate(best[ln_hunt] - p * ln_ref, cc.standard_deviation_along(along), 1.0, rules.max_interval_ratio);
    // The exponent is determined where the table pins it inside the library's range.
    const double sp = sd_of(hunt_exponent);
    f.hunt_crossley_exponent = {p, p - kZ95 * sp, p + kZ95 * sp, std::isfinite(sp) && p - kZ95 * sp >= kHuntExponentLo && p + kZ95 * sp <= kHuntExponentHi};
  }
  // A 1X table reads a stator at theta and at theta + 180 degrees alike (the model turned half a
  // turn about the shaft, the unbalance and bow with it, is the same model half a revolution later:
  // every 1X phasor turned twice by pi; its 2X changes sign): the one within 90 degrees of the top.
  f.contact_angle_deg = estimate{0.0, 0.0, 0.0, true};
  if (pr.form.contact_angle) {
    f.contact_angle_deg = angle_estimate(best[contact_theta], sd_of(contact_theta));
    const double turn = std::round(f.contact_angle_deg.value / 180.0) * 180.0;
    f.contact_angle_deg.value -= turn, f.contact_angle_deg.lo -= turn, f.contact_angle_deg.hi -= turn;
  }
  if (pr.beta_fitted()) f.probe_angle_deg = angle_estimate(best[probe_beta], sd_of(probe_beta));
  else {
    const double deg = pr.beta.front() * 180.0 / kPi;
    f.probe_angle_deg = {deg, deg, deg, true};
  }
}

// The model, its own 2X and the residual at every row, the noise test and the RMS residual.
void rows_into(rub_fit& f, const rub_problem& pr, const std::vector<double>& best, const std::vector<row_orbit>& orbits, const std::vector<cplx>& runout,
               double noise_relative_error) {
  const std::size_t probes = pr.orders.size();
  const double ratio = f.chi2 / static_cast<double>(f.dof);
  const double chi2_bound = boost::math::quantile(boost::math::chi_squared(static_cast<double>(f.dof)), 0.999) / static_cast<double>(f.dof) - 1.0;
  f.chi2_bound = 1.0 + std::hypot(chi2_bound, 3.29 * 2.0 * noise_relative_error);
  f.consistent_with_noise = ratio <= f.chi2_bound;
  double sum2 = 0.0;
  f.model.assign(probes, {}), f.residual.assign(probes, {}), f.model_2x.assign(probes, {});
  for (std::size_t p = 0; p < probes; ++p) {
    const double c = std::cos(pr.beta_of(best, p)), s = std::sin(pr.beta_of(best, p));
    for (std::size_t i = 0; i < pr.table.rows(); ++i) {
      f.model[p].push_back(c * orbits[i].x1 + s * orbits[i].y1 + runout[p]);
      f.residual[p].push_back(pr.table.orders[pr.orders[p]].vector[i] - f.model[p].back());
      f.model_2x[p].push_back(c * orbits[i].x2 + s * orbits[i].y2);
    }
  }
  for (std::size_t p = 0; p < probes; ++p)
    for (const std::size_t i : pr.rows) sum2 += std::norm(f.residual[p][i]);
  f.rms_residual_m = std::sqrt(sum2 / static_cast<double>(2 * probes * pr.rows.size()));
}

// The revolutions each row's motion takes to settle (rub_fit::settling_revolutions), from the
// fit's orbits at every row.
std::vector<double> settling_revolutions(const rub_problem& pr, const std::vector<double>& best, const std::vector<row_orbit>& orbits) {
  const std::size_t rows = pr.table.rows();
  std::vector<double> out(rows, 0.0);
  for (std::size_t i = 0; i < rows; ++i) {
    const std::size_t before = pr.previous[i];
    if (before >= rows) continue;
    double step = 0.0;  // over the noise
    for (std::size_t p = 0; p < pr.orders.size(); ++p) {
      const double c = std::cos(pr.beta_of(best, p)), s = std::sin(pr.beta_of(best, p));
      const cplx change = c * (orbits[i].x1 - orbits[before].x1) + s * (orbits[i].y1 - orbits[before].y1);
      step = std::max(step, std::abs(change) / pr.sigma[p]);
    }
    if (!(step > 1.0)) continue;
    const double rho = orbits[i].closed_form ? pr.contact_free_rho(best, pr.table.rpm[i] * kRpmToRadS) : orbits[i].rho;
    out[i] = rho < 1.0 ? std::log(step) / -std::log(rho) : std::numeric_limits<double>::infinity();
  }
  return out;
}

}  // namespace

rub_fit fit_rub(const order_table& table, const response_fit& linear, const rub_fit_options& options) {
  rub_problem pr = set_up(table, linear, options);
  const auto [best_q, remaining] = best_fit(pr, starts_of(pr, options));

  // The fit's orbits, its runouts, and the covariance of every coordinate and runout (re, im),
  // widened by the residuals' correlation over neighbouring rows (ref/inference).
  std::vector<row_orbit> orbits;
  std::vector<cplx> runout;
  const auto at = pr.residuals(best_q, nullptr, &orbits, runout, nullptr);
  if (!at) throw numerical_error(table.source + ": the rub fit's orbits cannot be computed at its own end");
  const Eigen::VectorXd& r = *at;
  const std::size_t n = best_q.size(), probes = pr.orders.size();
  Eigen::MatrixXd jf = Eigen::MatrixXd::Zero(r.size(), static_cast<Eigen::Index>(n + 2 * probes));
  jf.leftCols(static_cast<Eigen::Index>(n)) = pr.jacobian(best_q, r, orbits, &runout);
  std::vector<residual_series> series;
  for (std::size_t p = 0; p < probes; ++p) {
    for (std::size_t k = 0; k < pr.rows.size(); ++k) {
      const auto row = static_cast<Eigen::Index>(2 * (p * pr.rows.size() + k));
      jf(row, static_cast<Eigen::Index>(n + 2 * p)) = -1.0 / pr.sigma[p], jf(row + 1, static_cast<Eigen::Index>(n + 2 * p + 1)) = -1.0 / pr.sigma[p];
    }
    for (Eigen::Index part = 0; part < 2; ++part)
      series.push_back({static_cast<Eigen::Index>(2 * p * pr.rows.size()) + part, static_cast<Eigen::Index>(pr.rows.size()), 2});
  }
  const fit_covariance cc = covariance_of(jf, r, 1.0, series);
  rub_fit f;
  f.parts = linear.parts;
  f.form = pr.form;
  f.probe_angle_fitted = pr.undeclared;
  f.chi2 = r.squaredNorm();
  // Its numerical uncertainty: the solver's unfinished descent, and the orbits' error per reading
  // over the smallest noise (the residuals are whitened).
  f.chi2_uncertainty = cost_uncertainty(r, remaining, options.orbits.orbit_error() / *std::min_element(pr.sigma.begin(), pr.sigma.end()));
  // A freed row's 1X is two coordinates per probe (a mean shift that takes its residual whole).
  f.parameters = n + 2 * probes + 2 * probes * pr.freed.size();
  f.dof = cc.dof;
  for (const std::size_t i : pr.rows)
    if (orbits[i].contact) {
      if (f.rows_in_contact == 0) f.contact_from_rpm = table.rpm[i];
      f.contact_to_rpm = table.rpm[i], ++f.rows_in_contact;
      f.penetration_m = std::max(f.penetration_m, orbits[i].penetration), f.approach_speed_m_s = std::max(f.approach_speed_m_s, orbits[i].approach);
    }
  for (const std::size_t i : pr.rows) f.rows_not_periodic += orbits[i].periodic ? 0 : 1, f.rows_circled += orbits[i].circled ? 1 : 0;
  const std::vector<double> best = pr.full(best_q, pr.base);
  linear_estimates_into(f, pr, best, cc, best_q);
  f.probes = linear.probes;
  for (std::size_t p = 0; p < probes; ++p) {
    const auto k = static_cast<Eigen::Index>(n + 2 * p);
    const double inf = std::numeric_limits<double>::infinity();
    const bool open = cc.unconstrained[n + 2 * p] || cc.unconstrained[n + 2 * p + 1];
    const auto [ra, rp] = polar_estimate(runout[p], open ? inf : cc.cov(k, k), open ? inf : cc.cov(k + 1, k + 1), open ? inf : cc.cov(k, k + 1));
    f.runout_m.push_back(ra), f.runout_phase_deg.push_back(rp);
  }
  f.noise_m = pr.sigma;
  rows_into(f, pr, best, orbits, runout, options.noise_relative_error);
  f.settling_revolutions = settling_revolutions(pr, best, orbits);
  for (const std::size_t i : pr.freed) f.rows_freed.push_back({i, table.rpm[i], f.settling_revolutions[i]});
  f.q = best;
  f.ref_m = pr.ref_m;
  f.rows = pr.rows;
  f.evaluations = static_cast<int>(pr.evaluations.value());
  f.shots = static_cast<std::size_t>(pr.shots.value());
  return f;
}

std::string law_text(const rub_form& form) {
  std::string out = "k1 z";
  if (form.cubic) out += " + k3 z^3";
  if (form.velocity_squared) out += " + c2 z_dot^2";
  if (form.hertz) out += " + k_h z^1.5";
  if (form.hunt_crossley) out += " + lambda z^p z_dot";
  return out + (form.contact_angle ? ", stator's direction fitted" : ", stator at the top");
}

row_path rows_as_run(const order_table& table) {
  // More turns than a run-up, a coast-down and a run-up again: rows in no rig's order (shuffled, or
  // a speed column that wanders), followed in rising speed as the reader sorted them.
  constexpr std::size_t kMaxTurns = 2;
  row_path out;
  out.order.resize(table.rows());
  std::iota(out.order.begin(), out.order.end(), std::size_t{0});
  std::vector<std::size_t> by_line = out.order;
  std::stable_sort(by_line.begin(), by_line.end(), [&](std::size_t a, std::size_t b) { return table.line[a] < table.line[b]; });
  int direction = 0;  // of the last change of speed along the file: +1 rising, -1 falling
  for (std::size_t k = 1; k < by_line.size(); ++k) {
    const double step = table.rpm[by_line[k]] - table.rpm[by_line[k - 1]];
    const int d = step > 0.0 ? 1 : step < 0.0 ? -1 : 0;
    if (d == 0) continue;
    if (direction != 0 && d != direction) ++out.turns;
    direction = d;
  }
  out.as_run = out.turns <= kMaxTurns;
  if (out.as_run) out.order = by_line;
  return out;
}

rub_fit_jacobians rub_fit_jacobians_at(const order_table& table, const response_fit& linear, const rub_fit& fit, double step) {
  rub_fit_options options;
  options.rows = fit.rows;
  options.noise_m = fit.noise_m;
  options.start = &fit;
  rub_problem pr = set_up(table, linear, options);
  pr.base = fit.q;
  pr.ref_m = fit.ref_m;
  const std::vector<double> q = pr.reduce(fit.q);
  std::vector<row_orbit> at;
  std::vector<cplx> runout;
  if (!pr.residuals(q, nullptr, &at, runout, nullptr)) throw numerical_error(table.source + ": the rub fit's orbits cannot be computed at its end");
  rub_fit_jacobians out;
  if (auto J = pr.exact_jacobian(q, at, nullptr, rub_problem::rows_lacking::none)) out.exact = std::move(*J);
  if (auto J = pr.exact_jacobian(q, at, nullptr, rub_problem::rows_lacking::every_shot_row)) out.rows_differenced = std::move(*J);
  for (std::size_t k = 0; k < q.size(); ++k) {
    std::vector<double> a = q, b = q;
    a[k] += step, b[k] -= step;
    const auto ra = pr.residuals(a, &at, nullptr, runout, nullptr), rb = pr.residuals(b, &at, nullptr, runout, nullptr);
    if (!ra || !rb) throw numerical_error(table.source + ": the rub fit's orbits cannot be computed a step from its end");
    if (out.differenced.size() == 0) out.differenced.resize(ra->size(), static_cast<Eigen::Index>(q.size()));
    out.differenced.col(static_cast<Eigen::Index>(k)) = (*ra - *rb) / (2.0 * step);
  }
  return out;
}

response_fit linear_part(const response_fit& linear, const rub_fit& rub) {
  response_fit out = linear;
  for (std::size_t k = 0; k < kSlots; ++k) out.theta[k] = rub.q[k];
  out.amplitudes[0] = std::polar(rub.unbalance_m.value, rub.unbalance_phase_deg.value * kPi / 180.0);
  if (linear.parts.shaft_bow) out.amplitudes.back() = std::polar(rub.bow_m.value, rub.bow_phase_deg.value * kPi / 180.0);
  for (std::size_t p = 0; p < rub.runout_m.size(); ++p) out.amplitudes[1 + p] = std::polar(rub.runout_m[p].value, rub.runout_phase_deg[p].value * kPi / 180.0);
  return out;
}

}  // namespace rubref
