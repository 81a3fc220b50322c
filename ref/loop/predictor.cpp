#include "ref/loop/predictor.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/orbits/fit_orbits.hpp"

namespace rubref {

namespace {

using rig_state = std::array<double, 6>;
using model = rotor_with_effects<identified>;

// Orbits are shot and sampled as every fit's (ref/orbits/fit_orbits.hpp): to the shooting's
// 1e-12 m, far below probe resolution and far below the orbit changes the fit's finite
// differences make (>= 1e-9 m).
// Revolutions integrated from a first guess taken from the data before shooting starts: damps
// what the guess gets wrong of fast motions (contact ringing) so that Newton starts close.
constexpr int kFirstSettleRevs = 10;
// Revolutions the model runs from the data's state when Newton finds no periodic orbit there.
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

}  // namespace

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
    : dwells_(dwells), noise_(noise), orbits_(orbits), caches_(dwells.size()), kinds_(dwells.size(), orbit_kind::failed) {
  orbits_.validate();
  for (const auto& d : dwells_) {
    offsets_.push_back(orbit_rows_);
    orbit_rows_ += 2 * d.data.size();
  }
  rows_ = orbit_rows_;
  for (const auto& d : dwells_)
    if (std::isfinite(d.timing_sigma)) ++rows_;
}

orbit_kind orbit_predictor::predict(std::size_t k, const model_point& m) {
  const dwell& d = dwells_[k].data;
  cache& c = caches_[k];
  parameters p = m.p;
  p.clearance = d.clearance;
  // The motion's period: `periods` revolutions (the model's orbit is the n-revolution map's fixed point).
  const int periods = dwells_[k].periods;
  const double w = d.omega(), period = periods * 2.0 * std::numbers::pi / w;
  const model sys(p, m.fx, w);

  // Sample phases in [0, T) for this shift, sorted for one pass over the revolution (kept while
  // the shift is the same: most evaluations of a fit change the model, not the timing).
  const double shift = m.shift.empty() ? 0.0 : m.shift[k];
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
  const sample_grid grid = sample_grid::at(c.phase);

  // Newton from the anchor (the fit's start point's orbit), else from the data. The periodic
  // orbit is taken even where it is unstable: it stays a smooth function of the parameters, and
  // its distance from the data's (stable) orbit is what the fit must see to come back.
  c.last_ok = false;
  const bool warm = c.started;
  shot result = shoot(k, m, sys, period, grid);
  if (result != shot::converged && warm) {  // from the data instead (the anchor stays)
    c.started = false;
    result = shoot(k, m, sys, period, grid);
    c.started = true;
  }
  if (result == shot::converged) return orbit_kind::periodic;
  // No periodic orbit near the data (these parameters give a subharmonic, chaotic or far
  // orbit): compare the motion the model settles into from the data's state instead, so that the
  // fit still sees how far off it is and which way to go.
  try {
    const integration_options settle = fit_sampling(kFallbackSettleRevs, orbits_), opt = fit_sampling(periods, orbits_);
    const rig_state settled =
        flow(sys, guess_from_data(data_state(k), m.fx), kFallbackSettleRevs * 2.0 * std::numbers::pi / w, settle);
    return sample_flow(sys, settled, period, opt, grid, c.order, c.states) ? orbit_kind::transient : orbit_kind::failed;
  } catch (const numerical_error&) {
    return orbit_kind::failed;
  }
}

orbit_predictor::shot orbit_predictor::shoot(std::size_t k, const model_point& m, const rotor_with_effects<identified>& sys, double period,
                                             const sample_grid& grid) {
  cache& c = caches_[k];
  const int periods = dwells_[k].periods;
  const integration_options opt = fit_sampling(periods, orbits_);
  try {
    rig_state guess = c.started ? c.start : guess_from_data(data_state(k), m.fx);
    if (!c.started) {
      // Whole multiples of the motion's period: a period-n orbit comes back to the guess's phase.
      const int cycles = (kFirstSettleRevs + periods - 1) / periods;
      const integration_options settle = fit_sampling(periods * cycles, orbits_);
      guess = flow(sys, guess, cycles * period, settle);
    }
    // The one shooting routine (ref/integrate/shooting.hpp): Newton with the exact monodromy of
    // the `periods`-revolution map.
    const auto orbit = shoot_fit_orbit(sys, guess, 0.0, periods, orbits_);
    if (!orbit.converged) return shot::failed;
    if (!sample_flow(sys, orbit.state, period, opt, grid, c.order, c.states)) return shot::failed;
    c.last = orbit.state;
    c.last_ok = true;
    return shot::converged;
  } catch (const numerical_error&) {
  }
  return shot::failed;
}

const std::array<double, 4>& orbit_predictor::data_state(std::size_t k) {
  cache& c = caches_[k];
  if (!c.in_data) c.in_data = state_in_data(dwells_[k].data, dwells_[k].periods);
  return *c.in_data;
}

void orbit_predictor::reset() {
  for (auto& c : caches_) c.started = c.last_ok = false;  // the sorted phases stay: they depend on the timing alone
}

void orbit_predictor::anchor(const model_point& m) {
  reset();
  (void)residuals(m);  // a dwell that fails keeps no anchor: it starts from its data next time
  for (auto& c : caches_) {
    c.started = c.last_ok;
    c.start = c.last;
  }
}

void orbit_predictor::anchor(const model_point& m, const orbit_anchors& from) {
  reset();
  for (std::size_t k = 0; k < caches_.size() && k < from.size(); ++k)
    if (from[k]) caches_[k].started = true, caches_[k].start = *from[k];
  (void)residuals(m);
  for (auto& c : caches_) {
    c.started = c.last_ok;
    c.start = c.last;
  }
}

orbit_anchors orbit_predictor::last_orbits() const {
  orbit_anchors out(caches_.size());
  for (std::size_t k = 0; k < caches_.size(); ++k)
    if (caches_[k].last_ok) out[k] = caches_[k].last;
  return out;
}

std::optional<Eigen::VectorXd> orbit_predictor::residuals(const model_point& m) {
  ++evaluations_;
  Eigen::VectorXd r(static_cast<Eigen::Index>(rows_));
  kinds_.assign(dwells_.size(), orbit_kind::failed);
  parallel_for(dwells_.size(), 0, [&](std::size_t k) {
    kinds_[k] = predict(k, m);
    if (kinds_[k] == orbit_kind::failed) return;
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
  if (std::find(kinds_.begin(), kinds_.end(), orbit_kind::failed) != kinds_.end()) return std::nullopt;
  Eigen::Index row = static_cast<Eigen::Index>(orbit_rows_);
  for (std::size_t k = 0; k < dwells_.size(); ++k)
    if (std::isfinite(dwells_[k].timing_sigma)) r[row++] = noise_ * (m.shift.empty() ? 0.0 : m.shift[k]) / dwells_[k].timing_sigma;
  if (!r.allFinite()) return std::nullopt;
  return r;
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
