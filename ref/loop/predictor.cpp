#include "ref/loop/predictor.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <numeric>
#include <span>
#include <tuple>
#include <string>

#include "ref/analysis/spectrum.hpp"
#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/integrate/parameter_columns.hpp"
#include "ref/orbits/fit_orbits.hpp"

namespace rubref {

namespace {

using rig_state = std::array<double, 6>;
using model = rotor_with_effects<identified>;

// Orbits are shot and sampled as every fit's (ref/orbits/fit_orbits.hpp): to the shooting's
// 1e-12 m, far below probe resolution and far below the orbit changes the fit's finite
// differences make (>= 1e-9 m).
// Revolutions integrated from a first guess taken from the data before shooting starts: damps
// what the guess gets wrong of fast motions (contact ringing) so that Newton starts close. (Newton
// inexact while far from there, shooting_settings::coarse_while_far, halved the cost of the shots
// that fail but doubled the loop's time on docs/loop.md's stator example: docs/loop.md.)
constexpr int kFirstSettleRevs = 10;
// Revolutions the model runs from the data's state when Newton finds no periodic orbit there
// (the first shot's settle, continued).
constexpr int kFallbackSettleRevs = 30;

// Puts each sample of a flow on the sorted grid straight into its record sample's place.
struct state_recorder {
  std::vector<rig_state>* states;          // in record sample order
  const std::vector<std::size_t>* order;   // record sample of each grid point
  std::size_t count = 0;
  template <class System>
  void on_sample(double, const rig_state& s, const System&) {
    if (count < order->size()) (*states)[(*order)[count]] = s;
    ++count;
  }
  void on_event(const basic_contact_event<rig_state>&) {}
};

rig_state flow(const model& sys, const rig_state& s, double period, const integration_options& opt) {
  null_observer none;
  return integrate_hybrid(sys, start_state(sys, s, 0.0), period, opt, sample_grid{}, none).s;
}

// The flow over one period sampled on the sorted grid into `states` (record sample order); false
// when the grid's samples were not all reported.
bool sample_flow(const model& sys, const rig_state& s, double period, const integration_options& opt, const sample_grid& grid,
                 const std::vector<std::size_t>& order, std::vector<rig_state>& states) {
  states.resize(order.size());
  state_recorder rec{&states, &order};
  integrate_hybrid(sys, start_state(sys, s, 0.0), period, opt, grid, rec);
  return rec.count == order.size();
}

// The data's own state at t = 0 in the probes' axes (x, y, vx, vy): harmonics 0..H of the
// dwell's shaft phase, fitted by least squares to x and y, give the position and velocity there.
// It depends on the data alone, so each predictor fits it once per dwell (a least-squares fit on
// every sample of the dwell, which every fit's first evaluation used to repeat).
std::array<double, 4> state_in_data(const dwell& d, int periods) {
  const int kHarmonics = 8 * periods;  // of the motion's own frequency w / periods
  const double w = d.omega() / periods;
  Eigen::MatrixXd A(static_cast<Eigen::Index>(d.size()), 2 * kHarmonics + 1);
  Eigen::VectorXd bx(A.rows()), by(A.rows());
  for (std::size_t i = 0; i < d.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    A(r, 0) = 1.0;
    for (int h = 1; h <= kHarmonics; ++h) {
      A(r, 2 * h - 1) = std::cos(h * w * d.t[i]);
      A(r, 2 * h) = std::sin(h * w * d.t[i]);
    }
    bx[r] = d.x[i];
    by[r] = d.y[i];
  }
  const auto qr = A.colPivHouseholderQr();
  const Eigen::VectorXd cx = qr.solve(bx), cy = qr.solve(by);
  double x = cx[0], y = cy[0], vx = 0.0, vy = 0.0;
  for (int h = 1; h <= kHarmonics; ++h) {
    x += cx[2 * h - 1];
    y += cy[2 * h - 1];
    vx += h * w * cx[2 * h];
    vy += h * w * cy[2 * h];
  }
  return {x, y, vx, vy};
}

// A first guess of the rotor's state at t = 0: the data's, with the probes' turn undone (runout
// is small against the orbit and left in).
rig_state guess_from_data(const std::array<double, 4>& in_data, const effect_parameters& fx) {
  const auto [x, y, vx, vy] = in_data;
  const double ca = std::cos(fx.misorientation), sa = std::sin(fx.misorientation);
  return {ca * x - sa * y, sa * x + ca * y, ca * vx - sa * vy, sa * vx + ca * vy, 0.0, 0.0};
}

// Harmonics (constant, then cos h and sin h for h = 1..H) of the x and y readings at M uniform
// phases 2 pi j / M, from one FFT of x + i y (ref/analysis/spectrum.hpp): exact for readings
// without harmonics above M - H (the grid's M = 4 H).
std::pair<Eigen::VectorXd, Eigen::VectorXd> harmonics_on_grid(std::span<const double> x, std::span<const double> y, int H) {
  const auto M = static_cast<std::ptrdiff_t>(x.size());
  const directional_spectrum z = full_spectrum(x, y, 1.0, 0.0);
  const auto at = [&](std::ptrdiff_t k) { return z.coefficient[static_cast<std::size_t>(k + M / 2)]; };
  Eigen::VectorXd ax(2 * H + 1), ay(2 * H + 1);
  ax[0] = at(0).real();
  ay[0] = at(0).imag();
  for (int h = 1; h <= H; ++h) {
    // X_h = (Z_h + conj Z_-h) / 2, Y_h = (Z_h - conj Z_-h) / 2i; a real series has 2 Re X_h cos - 2 Im X_h sin.
    const std::complex<double> up = at(h), down = std::conj(at(-h));
    const std::complex<double> X = 0.5 * (up + down), Y = (up - down) / std::complex<double>(0.0, 2.0);
    ax[2 * h - 1] = 2.0 * X.real();
    ax[2 * h] = -2.0 * X.imag();
    ay[2 * h - 1] = 2.0 * Y.real();
    ay[2 * h] = -2.0 * Y.imag();
  }
  return {ax, ay};
}

// The harmonics of f(t + s) from those of f(t), with angle = w_T s: harmonic h turns by h angle.
Eigen::VectorXd turned(const Eigen::VectorXd& a, double angle) {
  Eigen::VectorXd b = a;
  const auto H = (a.size() - 1) / 2;
  for (Eigen::Index h = 1; h <= H; ++h) {
    const double c = std::cos(static_cast<double>(h) * angle), s = std::sin(static_cast<double>(h) * angle);
    b[2 * h - 1] = a[2 * h - 1] * c + a[2 * h] * s;
    b[2 * h] = a[2 * h] * c - a[2 * h - 1] * s;
  }
  return b;
}

// d/ds of turned(a, w_T s), given b = turned(a, w_T s): cos h gets h w_T b_sin, sin h gets -h w_T b_cos.
Eigen::VectorXd turned_rate(const Eigen::VectorXd& b, double w_motion) {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(b.size());
  const auto H = (b.size() - 1) / 2;
  for (Eigen::Index h = 1; h <= H; ++h) {
    d[2 * h - 1] = static_cast<double>(h) * w_motion * b[2 * h];
    d[2 * h] = -static_cast<double>(h) * w_motion * b[2 * h - 1];
  }
  return d;
}

}  // namespace

orbit_predictor::band orbit_predictor::harmonic_band(const dwell& d, int periods) {
  const std::size_t n = d.size();
  if (n < 5) throw input_error("a dwell at " + std::to_string(d.rpm) + " rpm has " + std::to_string(n) + " samples: too few to compare its orbit");
  // The band: harmonics of the motion's frequency w_T = w / periods up to a quarter of the
  // sampling rate, never more unknowns than a quarter of the samples. One revolution's samples
  // then over-determine the band twice, so the Gram matrix is well conditioned however the sample
  // phases of later revolutions fall (each adds a positive semi-definite term).
  const double w_motion = d.omega() / periods;
  const double dt = (d.t.back() - d.t.front()) / static_cast<double>(n - 1);
  const double per_revolution = 2.0 * std::numbers::pi / (d.omega() * dt);
  const int H = std::max(1, std::min(periods * static_cast<int>(std::floor(per_revolution / 4.0)), static_cast<int>((n - 1) / 4)));
  const int K = 2 * H + 1;
  // Sums of cos and sin of j w_T t over the samples, j = 0..2H (the Gram matrix's entries are
  // their half sums and differences), and the data's projections, by one rotation per harmonic.
  std::vector<double> C(static_cast<std::size_t>(2 * H + 1), 0.0), S(C.size(), 0.0);
  Eigen::VectorXd bx = Eigen::VectorXd::Zero(K), by = Eigen::VectorXd::Zero(K);
  for (std::size_t i = 0; i < n; ++i) {
    const std::complex<double> step = std::polar(1.0, w_motion * d.t[i]);
    std::complex<double> z = 1.0;
    bx[0] += d.x[i];
    by[0] += d.y[i];
    for (int j = 0; j <= 2 * H; ++j) {
      C[static_cast<std::size_t>(j)] += z.real();
      S[static_cast<std::size_t>(j)] += z.imag();
      if (j >= 1 && j <= H) {
        bx[2 * j - 1] += d.x[i] * z.real();
        bx[2 * j] += d.x[i] * z.imag();
        by[2 * j - 1] += d.y[i] * z.real();
        by[2 * j] += d.y[i] * z.imag();
      }
      z *= step;
    }
  }
  // Basis function b: 0 the constant (cos 0), 2h - 1 cos h, 2h sin h.
  const auto Cs = [&](int j) { return C[static_cast<std::size_t>(std::abs(j))]; };
  const auto Ss = [&](int j) { return j < 0 ? -S[static_cast<std::size_t>(-j)] : S[static_cast<std::size_t>(j)]; };
  const auto harmonic = [](int b) { return (b + 1) / 2; };
  const auto is_sine = [](int b) { return b > 0 && b % 2 == 0; };
  Eigen::MatrixXd G(K, K);
  for (int a = 0; a < K; ++a)
    for (int c = 0; c < K; ++c) {
      const int h = harmonic(a), g = harmonic(c);
      if (!is_sine(a) && !is_sine(c)) G(a, c) = 0.5 * (Cs(h - g) + Cs(h + g));
      else if (is_sine(a) && is_sine(c)) G(a, c) = 0.5 * (Cs(h - g) - Cs(h + g));
      else if (!is_sine(a)) G(a, c) = 0.5 * (Ss(h + g) - Ss(h - g));  // cos h sin g
      else G(a, c) = 0.5 * (Ss(h + g) + Ss(h - g));                   // sin h cos g
    }
  const Eigen::LLT<Eigen::MatrixXd> llt(G);
  if (llt.info() != Eigen::Success)
    throw numerical_error("the harmonics of the dwell at " + std::to_string(d.rpm) + " rpm are not independent at its sample times");
  band b;
  b.harmonics = H;
  b.Lt = llt.matrixU();
  const Eigen::VectorXd ax = llt.solve(bx), ay = llt.solve(by);
  b.target_x = b.Lt.triangularView<Eigen::Upper>() * ax;
  b.target_y = b.Lt.triangularView<Eigen::Upper>() * ay;
  // What the band leaves of the data, sample by sample (not |d|^2 - a_d^T B^T d: that cancels).
  for (std::size_t i = 0; i < n; ++i) {
    const std::complex<double> step = std::polar(1.0, w_motion * d.t[i]);
    std::complex<double> z = step;
    double fx = ax[0], fy = ay[0];
    for (int h = 1; h <= H; ++h, z *= step) {
      fx += ax[2 * h - 1] * z.real() + ax[2 * h] * z.imag();
      fy += ay[2 * h - 1] * z.real() + ay[2 * h] * z.imag();
    }
    b.offset += (d.x[i] - fx) * (d.x[i] - fx) + (d.y[i] - fy) * (d.y[i] - fy);
  }
  const auto M = static_cast<std::size_t>(4 * H);
  const double period = periods * 2.0 * std::numbers::pi / d.omega();
  b.grid.resize(M);
  // j spacing, as sample_grid's uniform times are (the integrator walks free arcs along such a grid).
  b.spacing = period / static_cast<double>(M);
  for (std::size_t j = 0; j < M; ++j) b.grid[j] = static_cast<double>(j) * b.spacing;
  return b;
}

double phase_in_period(double tau, double period) {
  // fmod is exact; tau - period * floor(tau / period) is not, and at a whole number of samples per
  // revolution its rounding put samples at -1e-17 s, before the revolution the integrator reports.
  double f = std::fmod(tau, period);
  if (f < 0.0) f += period;
  return f < period ? f : 0.0;
}

std::string_view to_string(orbit_kind k) {
  switch (k) {
    case orbit_kind::periodic: return "periodic";
    case orbit_kind::transient: return "transient";
    case orbit_kind::failed: return "failed";
  }
  return "?";
}

orbit_predictor::orbit_predictor(const std::vector<loop_dwell>& dwells, double noise, const fit_orbit_options& orbits)
    : dwells_(dwells), noise_(noise), orbits_(orbits), caches_(dwells.size()), kinds_(dwells.size(), orbit_kind::failed), bands_(dwells.size()) {
  orbits_.validate();
  for (const auto& d : dwells_) {
    offsets_.push_back(orbit_rows_);
    orbit_rows_ += 2 * d.data.size();
  }
  rows_ = orbit_rows_;
  for (const auto& d : dwells_)
    if (std::isfinite(d.timing_sigma)) ++rows_;
}

void orbit_predictor::sort_phases(std::size_t k, double shift, double period) {
  // Sample phases in [0, T) for this shift, sorted for one pass over the revolution (kept while
  // the shift is the same: most evaluations of a fit change the model, not the timing).
  const dwell& d = dwells_[k].data;
  cache& c = caches_[k];
  if (c.sorted && c.sorted_shift != shift && c.sorted_period == period && !c.order.empty()) {
    // A shift turns every sample's phase by the same angle: their cyclic order stays, so the
    // sorted order is the old one rotated to its new smallest phase (checked: a rounding that
    // swapped two phases falls back to the sort below). Equal phases sample equal states.
    std::vector<double> turned(c.order.size());
    std::size_t first = 0;
    for (std::size_t i = 0; i < c.order.size(); ++i) {
      turned[i] = phase_in_period(d.t[c.order[i]] + shift, period);
      if (turned[i] < turned[first]) first = i;
    }
    std::vector<double> phase(turned.size());
    std::vector<std::size_t> order(turned.size());
    bool ascending = true;
    for (std::size_t i = 0; i < turned.size(); ++i) {
      const std::size_t from = (first + i) % turned.size();
      phase[i] = turned[from];
      order[i] = c.order[from];
      ascending = ascending && (i == 0 || phase[i - 1] <= phase[i]);
    }
    c.sorted = ascending;
    if (ascending) {
      c.phase = std::move(phase);
      c.order = std::move(order);
      c.sorted_shift = shift;
    }
  }
  if (!(c.sorted && c.sorted_shift == shift && c.sorted_period == period)) {
    std::vector<std::pair<double, std::size_t>> ph(d.size());
    for (std::size_t i = 0; i < d.size(); ++i) ph[i] = {phase_in_period(d.t[i] + shift, period), i};
    std::sort(ph.begin(), ph.end());
    c.phase.resize(ph.size());
    c.order.resize(ph.size());
    for (std::size_t i = 0; i < ph.size(); ++i) std::tie(c.phase[i], c.order[i]) = ph[i];
    c.sorted = true;
    c.sorted_shift = shift;
    c.sorted_period = period;
  }
}

orbit_kind orbit_predictor::predict(std::size_t k, const model_point& m, bool harmonics, bool transient) {
  const dwell& d = dwells_[k].data;
  cache& c = caches_[k];
  parameters p = m.p;
  p.clearance = d.clearance;
  // The motion's period: `periods` revolutions (the model's orbit is the n-revolution map's fixed point).
  const int periods = dwells_[k].periods;
  const double w = d.omega(), period = periods * 2.0 * std::numbers::pi / w;
  const model sys(p, m.fx, w);

  // Where the orbit is read: the band's uniform grid, or the record's sample phases.
  const double shift = m.shift.empty() ? 0.0 : m.shift[k];
  if (!harmonics) sort_phases(k, shift, period);
  band* const b = harmonics ? &*bands_[k] : nullptr;
  const sample_grid grid = harmonics ? sample_grid(0.0, b->spacing, b->grid.size()) : sample_grid::at(c.phase);
  const std::vector<std::size_t>& order = harmonics ? b->identity : c.order;
  std::vector<rig_state>& states = harmonics ? b->states : c.states;

  // Newton from the anchor (the fit's start point's orbit), else from the data. The periodic
  // orbit is taken even where it is unstable: it stays a smooth function of the parameters, and
  // its distance from the data's (stable) orbit is what the fit must see to come back.
  c.last_ok = false;
  std::optional<settled_guess> from_data;  // the data's guess after its first settle, where a shot started there
  if (!transient) {
    const bool warm = c.started;
    shot result = shoot(k, m, sys, period, grid, order, states, from_data);
    if (result != shot::converged && warm) {  // from the data instead (the anchor stays)
      c.started = false;
      result = shoot(k, m, sys, period, grid, order, states, from_data);
      c.started = true;
    }
    if (result == shot::converged) return orbit_kind::periodic;
  }
  // No periodic orbit near the data (these parameters give a subharmonic, chaotic or far
  // orbit): compare the motion the model settles into from the data's state instead, so that the
  // fit still sees how far off it is and which way to go. It continues the first settle (the
  // shot's from the data, where one was made: the same flow either way, step for step).
  try {
    if (!from_data) from_data = first_settle(k, m, sys, period);
    const int rest = kFallbackSettleRevs - std::min(from_data->revolutions, kFallbackSettleRevs);
    const integration_options settle = fit_sampling(rest, orbits_), opt = fit_sampling(periods, orbits_);
    const rig_state settled = rest > 0 ? flow(sys, from_data->state, rest * 2.0 * std::numbers::pi / w, settle) : from_data->state;
    return sample_flow(sys, settled, period, opt, grid, order, states) ? orbit_kind::transient : orbit_kind::failed;
  } catch (const numerical_error&) {
    return orbit_kind::failed;
  }
}

orbit_predictor::shot orbit_predictor::shoot(std::size_t k, const model_point& m, const rotor_with_effects<identified>& sys, double period,
                                             const sample_grid& grid, const std::vector<std::size_t>& order, std::vector<rig_state>& states,
                                             std::optional<settled_guess>& from_data) {
  cache& c = caches_[k];
  const int periods = dwells_[k].periods;
  const integration_options opt = fit_sampling(periods, orbits_);
  try {
    rig_state guess = c.start;
    if (!c.started) {
      from_data = first_settle(k, m, sys, period);
      guess = from_data->state;
    }
    // The one shooting routine (ref/integrate/shooting.hpp): Newton with the exact monodromy of
    // the `periods`-revolution map.
    const auto orbit = shoot_fit_orbit(sys, guess, 0.0, periods, orbits_);
    if (!orbit.converged) return shot::failed;
    if (!sample_flow(sys, orbit.state, period, opt, grid, order, states)) return shot::failed;
    c.last = orbit.state;
    c.last_ok = true;
    return shot::converged;
  } catch (const numerical_error&) {
  }
  return shot::failed;
}

orbit_predictor::settled_guess orbit_predictor::first_settle(std::size_t k, const model_point& m, const rotor_with_effects<identified>& sys, double period) {
  // Whole multiples of the motion's period: a period-n orbit comes back to the guess's phase.
  const int periods = dwells_[k].periods;
  const int cycles = (kFirstSettleRevs + periods - 1) / periods;
  return {flow(sys, guess_from_data(data_state(k), m.fx), cycles * period, fit_sampling(periods * cycles, orbits_)), cycles * periods};
}

orbit_predictor::band& orbit_predictor::band_of(std::size_t k) {
  auto& slot = bands_[k];
  if (slot) return *slot;
  band b = harmonic_band(dwells_[k].data, dwells_[k].periods);
  b.identity.resize(b.grid.size());
  std::iota(b.identity.begin(), b.identity.end(), std::size_t{0});
  slot = std::move(b);
  return *slot;
}

void orbit_predictor::prepare_bands() {
  if (!harmonic_offsets_.empty() || dwells_.empty()) return;
  parallel_for(dwells_.size(), 0, [&](std::size_t k) { (void)band_of(k); });
  for (std::size_t k = 0; k < dwells_.size(); ++k) {
    harmonic_offsets_.push_back(harmonic_rows_);
    harmonic_rows_ += 2 * static_cast<std::size_t>(2 * bands_[k]->harmonics + 1);
  }
  for (const auto& d : dwells_)
    if (std::isfinite(d.timing_sigma)) ++harmonic_rows_;
}

std::size_t orbit_predictor::harmonic_rows() {
  prepare_bands();
  return harmonic_rows_;
}

double orbit_predictor::harmonic_offset() {
  prepare_bands();
  double sum = 0.0;
  for (const auto& b : bands_) sum += b->offset;
  return sum;
}

int orbit_predictor::band_harmonics(std::size_t k) { return band_of(k).harmonics; }

std::array<double, 2> orbit_predictor::band_reading(std::size_t k, double t, double shift) const {
  const band& b = bands_.at(k).value();
  const double w_motion = dwells_[k].data.omega() / dwells_[k].periods;
  const Eigen::VectorXd ax = turned(b.ax, w_motion * shift), ay = turned(b.ay, w_motion * shift);
  double x = ax[0], y = ay[0];
  for (int h = 1; h <= b.harmonics; ++h) {
    const double c = std::cos(h * w_motion * t), s = std::sin(h * w_motion * t);
    x += ax[2 * h - 1] * c + ax[2 * h] * s;
    y += ay[2 * h - 1] * c + ay[2 * h] * s;
  }
  return {x, y};
}

// One evaluation, on the samples or the band: every dwell's orbit (in parallel), `fill` writes
// dwell k's rows, then the shift priors close the vector of `rows`. A dwell that fails, or a
// non-finite entry, makes the evaluation fail: never a number inside a residual.
template <class Fill>
std::optional<Eigen::VectorXd> orbit_predictor::evaluate(const model_point& m, bool harmonics, std::size_t rows, Fill&& fill,
                                                        const std::vector<orbit_kind>* as) {
  ++evaluations_;
  if (!harmonics) harmonics_of_.reset();  // the orbits (and kinds) are no longer the band's
  Eigen::VectorXd r(static_cast<Eigen::Index>(rows));
  const std::vector<orbit_kind> held = as ? *as : std::vector<orbit_kind>{};  // (as may be kinds_ itself)
  kinds_.assign(dwells_.size(), orbit_kind::failed);
  parallel_for(dwells_.size(), 0, [&](std::size_t k) {
    kinds_[k] = predict(k, m, harmonics, k < held.size() && held[k] == orbit_kind::transient);
    if (kinds_[k] != orbit_kind::failed) fill(k, r);
  });
  if (std::find(kinds_.begin(), kinds_.end(), orbit_kind::failed) != kinds_.end()) return std::nullopt;
  auto row = static_cast<Eigen::Index>(rows - (rows_ - orbit_rows_));  // the priors are the last rows in both layouts
  for (std::size_t k = 0; k < dwells_.size(); ++k)
    if (std::isfinite(dwells_[k].timing_sigma)) r[row++] = noise_ * (m.shift.empty() ? 0.0 : m.shift[k]) / dwells_[k].timing_sigma;
  if (!r.allFinite()) return std::nullopt;
  return r;
}

std::optional<Eigen::VectorXd> orbit_predictor::harmonic_residuals(const model_point& m) { return harmonic_residuals(m, nullptr); }

std::optional<Eigen::VectorXd> orbit_predictor::harmonic_residuals_as(const model_point& m, const std::vector<orbit_kind>& as) {
  return harmonic_residuals(m, &as);
}

std::optional<Eigen::VectorXd> orbit_predictor::harmonic_residuals(const model_point& m, const std::vector<orbit_kind>* as) {
  prepare_bands();
  harmonics_of_.reset();
  auto out = evaluate(m, true, harmonic_rows_, [&](std::size_t k, Eigen::VectorXd& r) {
    band& b = *bands_[k];
    const dwell& d = dwells_[k].data;
    const double w = d.omega(), w_motion = w / dwells_[k].periods, shift = m.shift.empty() ? 0.0 : m.shift[k];
    // The readings on the grid: grid point j is the model at t + s = j T / M, the shaft at w (t + s).
    const probe_model probes(m.fx);
    const std::size_t M = b.grid.size();
    std::vector<double> rx(M), ry(M);
    for (std::size_t j = 0; j < M; ++j) {
      const auto& s = b.states[j];
      const auto reading = probes(s[idx::x], s[idx::y], w * b.grid[j]);
      rx[j] = reading[0];
      ry[j] = reading[1];
    }
    std::tie(b.ax, b.ay) = harmonics_on_grid(rx, ry, b.harmonics);
    const auto n = static_cast<Eigen::Index>(2 * b.harmonics + 1), at = static_cast<Eigen::Index>(harmonic_offsets_[k]);
    r.segment(at, n) = b.Lt.triangularView<Eigen::Upper>() * turned(b.ax, w_motion * shift) - b.target_x;
    r.segment(at + n, n) = b.Lt.triangularView<Eigen::Upper>() * turned(b.ay, w_motion * shift) - b.target_y;
  }, as);
  if (out) harmonics_of_ = m;
  return out;
}

Eigen::MatrixXd orbit_predictor::harmonic_shift_columns(const model_point& m) {
  prepare_bands();
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(harmonic_rows_), static_cast<Eigen::Index>(dwells_.size()));
  auto row = static_cast<Eigen::Index>(harmonic_rows_ - (rows_ - orbit_rows_));
  for (std::size_t k = 0; k < dwells_.size(); ++k) {
    const band& b = *bands_[k];
    const auto col = static_cast<Eigen::Index>(k);
    const auto n = static_cast<Eigen::Index>(2 * b.harmonics + 1), at = static_cast<Eigen::Index>(harmonic_offsets_[k]);
    if (b.ax.size() == n) {
      const double w_motion = dwells_[k].data.omega() / dwells_[k].periods, shift = m.shift.empty() ? 0.0 : m.shift[k];
      J.col(col).segment(at, n) = b.Lt.triangularView<Eigen::Upper>() * turned_rate(turned(b.ax, w_motion * shift), w_motion);
      J.col(col).segment(at + n, n) = b.Lt.triangularView<Eigen::Upper>() * turned_rate(turned(b.ay, w_motion * shift), w_motion);
    }
    if (std::isfinite(dwells_[k].timing_sigma)) J(row++, col) = noise_ / dwells_[k].timing_sigma;
  }
  return J;
}

namespace {
// Columns per flow: the flow carries s, Phi and this many parameter columns (6 + 6 x 14 states);
// a fit's coordinates take one or two flows per dwell.
constexpr int kColumnsPerFlow = kFitColumnsPerFlow;
using columns_system = fit_columns_system<identified>;

// Whether two points' rotors move alike: they differ at most in what only the probes see
// (runout, misorientation: ref/rig/probes.hpp), so a column between them has no orbit part.
bool same_dynamics(const model_point& a, const model_point& b) {
  const auto rotor_only = [](effect_parameters fx) {
    fx.runout_1x = fx.runout_1x_phase = fx.runout_2x = fx.runout_2x_phase = fx.misorientation = 0.0;
    return fx;
  };
  return a.p == b.p && rotor_only(a.fx) == rotor_only(b.fx);
}
}  // namespace

std::vector<std::optional<Eigen::VectorXd>> orbit_predictor::harmonic_columns(const model_point& m, const std::vector<model_point>& up,
                                                                               const std::vector<model_point>& down, const std::vector<double>& span) {
  const std::size_t P = up.size();
  std::vector<std::optional<Eigen::VectorXd>> out(P);
  if (P == 0 || !harmonics_are_of(m) || std::any_of(kinds_.begin(), kinds_.end(), [](orbit_kind k) { return k != orbit_kind::periodic; }))
    return out;
  Eigen::MatrixXd cols = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(harmonic_rows_), static_cast<Eigen::Index>(P));
  // Per dwell and column: whether it was had.
  std::vector<std::vector<char>> had(dwells_.size(), std::vector<char>(P, 0));
  const double tolerance = orbits_.orbit_error();
  parallel_for(dwells_.size(), 0, [&](std::size_t k) {
    const cache& c = caches_[k];
    if (!c.last_ok) return;
    const band& b = *bands_[k];
    const dwell& d = dwells_[k].data;
    const int periods = dwells_[k].periods;
    const double w = d.omega(), w_motion = w / periods;
    const double shift = m.shift.empty() ? 0.0 : m.shift[k];
    const auto model_at = [&](const model_point& at) {
      parameters p = at.p;
      p.clearance = d.clearance;
      return model(p, at.fx, w);
    };
    const model sys = model_at(m);
    const std::size_t M = b.grid.size();
    // The orbit's part: d(state)/d(coordinate) at each grid point, for the columns whose rotor moves.
    std::vector<std::vector<Eigen::Matrix<double, 6, 1>>> dstate(P);
    std::vector<std::size_t> dynamic;
    for (std::size_t j = 0; j < P; ++j) {
      if (!(span[j] > 0.0)) continue;
      if (same_dynamics(m, up[j]) && same_dynamics(m, down[j])) {
        dstate[j].assign(M, Eigen::Matrix<double, 6, 1>::Zero());
        had[k][j] = 1;
      } else if (model_at(up[j]).moving_states() == sys.moving_states() && model_at(down[j]).moving_states() == sys.moving_states()) {
        dynamic.push_back(j);
      }
    }
    const integration_options opt = fit_shooting(periods, orbits_).integration;
    for (std::size_t first = 0; first < dynamic.size(); first += kColumnsPerFlow) {
      const std::size_t count = std::min<std::size_t>(kColumnsPerFlow, dynamic.size() - first);
      std::vector<model> ups, downs;
      std::vector<double> spans;
      for (std::size_t i = 0; i < count; ++i) {
        ups.push_back(model_at(up[dynamic[first + i]]));
        downs.push_back(model_at(down[dynamic[first + i]]));
        spans.push_back(span[dynamic[first + i]]);
      }
      try {
        const columns_system aug(sys, std::move(ups), std::move(downs), std::move(spans));
        const auto oc = periodic_orbit_columns(aug, c.last, 0.0, periods, opt, sample_grid(0.0, b.spacing, M), tolerance);
        for (std::size_t i = 0; i < count; ++i) {
          const std::size_t j = dynamic[first + i];
          dstate[j].resize(M);
          for (std::size_t g = 0; g < M; ++g) dstate[j][g] = oc.at[g].col(static_cast<Eigen::Index>(i));
          had[k][j] = 1;
        }
      } catch (const numerical_error&) {
        // these columns are differenced by the caller
      }
    }
    // Readings: the probes turn the orbit's part (linear in x, y: the runout cancels in the
    // difference) and add their own (the moved probes' difference at the same states).
    const probe_model probes(m.fx);
    const auto n = static_cast<Eigen::Index>(2 * b.harmonics + 1), at = static_cast<Eigen::Index>(harmonic_offsets_[k]);
    std::vector<double> rx(M), ry(M);
    for (std::size_t j = 0; j < P; ++j) {
      if (!had[k][j]) continue;
      const probe_model probes_up(up[j].fx), probes_down(down[j].fx);
      for (std::size_t g = 0; g < M; ++g) {
        const auto& s = b.states[g];
        const double psi = w * b.grid[g];
        const auto zero = probes(0.0, 0.0, psi), turned_part = probes(dstate[j][g][idx::x], dstate[j][g][idx::y], psi);
        const auto own_up = probes_up(s[idx::x], s[idx::y], psi), own_down = probes_down(s[idx::x], s[idx::y], psi);
        rx[g] = turned_part[0] - zero[0] + (own_up[0] - own_down[0]) / span[j];
        ry[g] = turned_part[1] - zero[1] + (own_up[1] - own_down[1]) / span[j];
      }
      const auto [ax, ay] = harmonics_on_grid(rx, ry, b.harmonics);
      const auto col = static_cast<Eigen::Index>(j);
      cols.col(col).segment(at, n) = b.Lt.triangularView<Eigen::Upper>() * turned(ax, w_motion * shift);
      cols.col(col).segment(at + n, n) = b.Lt.triangularView<Eigen::Upper>() * turned(ay, w_motion * shift);
    }
  });
  for (std::size_t j = 0; j < P; ++j) {
    bool all = true;
    for (std::size_t k = 0; k < dwells_.size(); ++k) all = all && had[k][j];
    if (all && cols.col(static_cast<Eigen::Index>(j)).allFinite()) out[j] = cols.col(static_cast<Eigen::Index>(j));
  }
  if (std::any_of(out.begin(), out.end(), [](const auto& c) { return c.has_value(); })) ++sensitivity_evaluations_;
  return out;
}

const std::array<double, 4>& orbit_predictor::data_state(std::size_t k) {
  cache& c = caches_[k];
  if (!c.in_data) c.in_data = state_in_data(dwells_[k].data, dwells_[k].periods);
  return *c.in_data;
}

void orbit_predictor::reset() {
  for (auto& c : caches_) c.started = c.last_ok = false;  // the sorted phases stay: they depend on the timing alone
  harmonics_of_.reset();
}

void orbit_predictor::anchor(const model_point& m) {
  reset();
  // Only the orbits are kept, so the band's grid suffices. A dwell that fails keeps no anchor: it
  // starts from its data next time.
  (void)harmonic_residuals(m);
  for (auto& c : caches_) {
    c.started = c.last_ok;
    c.start = c.last;
  }
  harmonics_of_.reset();  // the next evaluation shoots from the new anchor
}

void orbit_predictor::anchor(const model_point& m, const orbit_anchors& from) {
  reset();
  for (std::size_t k = 0; k < caches_.size() && k < from.size(); ++k)
    if (from[k]) caches_[k].started = true, caches_[k].start = *from[k];
  (void)harmonic_residuals(m);
  for (auto& c : caches_) {
    c.started = c.last_ok;
    c.start = c.last;
  }
  harmonics_of_.reset();  // the next evaluation shoots from the new anchor
}

orbit_anchors orbit_predictor::last_orbits() const {
  orbit_anchors out(caches_.size());
  for (std::size_t k = 0; k < caches_.size(); ++k)
    if (caches_[k].last_ok) out[k] = caches_[k].last;
  return out;
}

std::optional<Eigen::VectorXd> orbit_predictor::residuals(const model_point& m) {
  return evaluate(m, false, rows_, [&](std::size_t k, Eigen::VectorXd& r) {
    const dwell& d = dwells_[k].data;
    const auto at = static_cast<Eigen::Index>(offsets_[k]);
    const double w = d.omega(), shift = m.shift.empty() ? 0.0 : m.shift[k];
    const probe_model probes(m.fx);
    for (std::size_t i = 0; i < d.size(); ++i) {
      const auto& s = caches_[k].states[i];
      const auto [xm, ym] = probes(s[idx::x], s[idx::y], w * (d.t[i] + shift));
      r[at + static_cast<Eigen::Index>(2 * i)] = xm - d.x[i];
      r[at + static_cast<Eigen::Index>(2 * i + 1)] = ym - d.y[i];
    }
  });
}

Eigen::MatrixXd orbit_predictor::shift_columns(const model_point& m) {
  // d(reading)/d(shift) = d(reading)/dt: the turned velocity plus the runout's rate. Uses the
  // states of the last residuals() call at m.
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(rows_), static_cast<Eigen::Index>(dwells_.size()));
  const double ca = std::cos(m.fx.misorientation), sa = std::sin(m.fx.misorientation);
  const auto runout_rate = [&](double a, double w) {
    return -w * (m.fx.runout_1x * std::sin(a + m.fx.runout_1x_phase) + 2.0 * m.fx.runout_2x * std::sin(2.0 * a + m.fx.runout_2x_phase));
  };
  Eigen::Index row = static_cast<Eigen::Index>(orbit_rows_);
  for (std::size_t k = 0; k < dwells_.size(); ++k) {
    const dwell& d = dwells_[k].data;
    const auto col = static_cast<Eigen::Index>(k);
    const double w = d.omega(), shift = m.shift.empty() ? 0.0 : m.shift[k];
    if (caches_[k].states.size() == d.size())
      for (std::size_t i = 0; i < d.size(); ++i) {
        const auto& s = caches_[k].states[i];
        const double psi = w * (d.t[i] + shift);
        const auto at = static_cast<Eigen::Index>(offsets_[k] + 2 * i);
        J(at, col) = ca * s[idx::vx] + sa * s[idx::vy] + runout_rate(psi, w);
        J(at + 1, col) = -sa * s[idx::vx] + ca * s[idx::vy] + runout_rate(psi - 0.5 * std::numbers::pi, w);
      }
    if (std::isfinite(dwells_[k].timing_sigma)) J(row++, col) = noise_ / dwells_[k].timing_sigma;
  }
  return J;
}

}  // namespace rubref
