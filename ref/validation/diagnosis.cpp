#include "ref/validation/diagnosis.hpp"

#include <algorithm>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/inference/least_squares.hpp"
#include "ref/orbits/fit_orbits.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr double kStandardGravity = 9.80665;  // m/s^2
constexpr double kMaxStaticLoad = 3.0;        // m g: the static loads searched (gravity, a bearing offset)


double period_of(const golden_case& g) { return 60.0 / g.request.rpm; }

double median_spacing(const std::vector<double>& t) {
  std::vector<double> d;
  for (std::size_t i = 1; i < t.size(); ++i) d.push_back(t[i] - t[i - 1]);
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

// ----------------------------------------------------------------------------------------------
// Re-simulation: a hypothesis is the case's model with one change; its periodic orbit, shot from
// a guess, is compared with what the candidate shows at the candidate's times.

// Positions a hypothesis must reproduce at times t of the case's run (the candidate, possibly
// transformed back).
struct view {
  std::vector<double> t, x, y;
};

// At most this many samples steer a fit (evenly spread); the confirmation uses them all.
constexpr std::size_t kFitSamples = 256;

view thinned(const view& v) {
  if (v.t.size() <= kFitSamples) return v;
  view out;
  for (std::size_t k = 0; k < kFitSamples; ++k) {
    const std::size_t i = k * (v.t.size() - 1) / (kFitSamples - 1);
    out.t.push_back(v.t[i]);
    out.x.push_back(v.x[i]);
    out.y.push_back(v.y[i]);
  }
  return out;
}

struct orbit_start {
  state_type s{};
  double t0 = 0.0;
  int periods = 1;
};

struct model_fit {
  bool converged = false;
  double rms = kInf, max = kInf;  // m, over the view
  orbit_start orbit;              // the shot orbit
  double max_multiplier = 0.0;
  std::vector<double> residual;   // m, (model - view) in x then y at each view point
};

enum class law_form { as_named, abs_damper };

struct hypothesis {
  std::string variant;
  law_form form = law_form::as_named;
  parameters params;
  double omega = 0.0;               // rad/s, signed (< 0: clockwise)
  double offset_x = 0.0, offset_y = 0.0;  // m, added to the model's positions
};

// A hypothesis's orbit is shot and sampled as every fit's (ref/orbits/fit_orbits.hpp): to the
// shooting's 1e-12 m, far below the smallest case tolerance (3.3e-8 m), so the comparison sees
// the orbit, not the shooting's residual; a hypothesis far from the candidate (a law pressing the
// rotor into the stator) fails fast instead of crawling.
template <class Law>
model_fit fit_orbit(const hypothesis& h, const view& v, const std::vector<orbit_start>& guesses) {
  model_fit out;
  const rotor_system<Law> model(h.params, h.omega);
  const double T = model.period();
  for (const orbit_start& guess : guesses) {
    if (!std::all_of(guess.s.begin(), guess.s.end(), [](double a) { return std::isfinite(a); })) continue;
    periodic_orbit<4> shot;
    try {
      shot = shoot_fit_orbit(model, guess.s, guess.t0, guess.periods);
    } catch (const std::exception&) {
      continue;
    }
    if (!shot.converged) continue;
    // The view's times within one period, at each revolution shift of a multi-revolution orbit.
    const double P = guess.periods * T;
    std::vector<std::pair<double, std::size_t>> at;  // (time, shift * n + i)
    const std::size_t n = v.t.size();
    for (int k = 0; k < guess.periods; ++k)
      for (std::size_t i = 0; i < n; ++i) {
        double tau = std::fmod(v.t[i] - guess.t0 + k * T, P);
        if (tau < 0.0) tau += P;
        at.emplace_back(guess.t0 + tau, static_cast<std::size_t>(k) * n + i);
      }
    std::sort(at.begin(), at.end());
    std::vector<double> times;
    for (const auto& [t, _] : at) times.push_back(t);
    struct keeper {
      std::vector<state_type> s;
      void on_sample(double, const state_type& x, const rotor_system<Law>&) { s.push_back(x); }
      void on_event(const contact_event&) {}
    } kept;
    try {
      integrate_hybrid(model, start_state(model, shot.state, guess.t0), guess.t0 + P, fit_sampling(guess.periods), sample_grid::at(times), kept);
    } catch (const std::exception&) {
      continue;
    }
    if (kept.s.size() != times.size()) continue;
    std::vector<double> sum(static_cast<std::size_t>(guess.periods), 0.0), worst(static_cast<std::size_t>(guess.periods), 0.0);
    for (std::size_t j = 0; j < at.size(); ++j) {
      const std::size_t k = at[j].second / n, i = at[j].second % n;
      const double e = std::hypot(kept.s[j][idx::x] + h.offset_x - v.x[i], kept.s[j][idx::y] + h.offset_y - v.y[i]);
      sum[k] += e * e;
      worst[k] = std::max(worst[k], e);
    }
    const auto best = static_cast<std::size_t>(std::min_element(sum.begin(), sum.end()) - sum.begin());
    out.residual.assign(2 * n, 0.0);
    for (std::size_t j = 0; j < at.size(); ++j)
      if (at[j].second / n == best) {
        const std::size_t i = at[j].second % n;
        out.residual[i] = kept.s[j][idx::x] + h.offset_x - v.x[i];
        out.residual[n + i] = kept.s[j][idx::y] + h.offset_y - v.y[i];
      }
    out.converged = true;
    out.rms = std::sqrt(sum[best] / static_cast<double>(n));
    out.max = worst[best];
    out.orbit = {shot.state, guess.t0, guess.periods};
    out.max_multiplier = shot.max_multiplier_modulus();
    if (!std::isfinite(out.rms)) out = model_fit{};
    return out;
  }
  return out;
}

model_fit evaluate(const hypothesis& h, const view& v, const std::vector<orbit_start>& guesses) {
  if (h.form == law_form::abs_damper) return fit_orbit<abs_damper_law>(h, v, guesses);
  return visit_variant(h.variant, [&]<class Law>() { return fit_orbit<Law>(h, v, guesses); });
}

hypothesis case_hypothesis(const golden_case& g) { return {g.request.variant, law_form::as_named, g.request.params, g.omega(), 0.0, 0.0}; }

// The view of the candidate as it is.
view candidate_view(const candidate_data& c) { return {c.t, c.x, c.y}; }

// The candidate's state at one of its samples, far from the stator (its lowest y, where no
// contact is near), for shooting from: its own velocities when it has them, else a central
// difference (4th order on a uniform stretch).
std::optional<orbit_start> candidate_state(const candidate_data& c, int periods) {
  const std::size_t n = c.t.size();
  if (n < 5) return std::nullopt;
  std::size_t i = 2;
  for (std::size_t k = 2; k + 2 < n; ++k)
    if (c.y[k] < c.y[i]) i = k;
  orbit_start s;
  s.t0 = c.t[i];
  s.periods = std::max(1, periods);
  s.s[idx::x] = c.x[i];
  s.s[idx::y] = c.y[i];
  if (c.vx.size() == n && c.vy.size() == n) {
    s.s[idx::vx] = c.vx[i];
    s.s[idx::vy] = c.vy[i];
    return s;
  }
  const double h = c.t[i + 1] - c.t[i];
  bool uniform = h > 0.0;
  for (std::size_t k = i - 2; k < i + 2; ++k) uniform = uniform && std::abs((c.t[k + 1] - c.t[k]) - h) <= 1e-6 * h;
  const auto derivative = [&](const std::vector<double>& f) {
    if (uniform) return (f[i - 2] - 8.0 * f[i - 1] + 8.0 * f[i + 1] - f[i + 2]) / (12.0 * h);
    const double a = c.t[i] - c.t[i - 1], b = c.t[i + 1] - c.t[i];
    return ((f[i + 1] - f[i]) * a * a + (f[i] - f[i - 1]) * b * b) / (a * b * (a + b));
  };
  s.s[idx::vx] = derivative(c.x);
  s.s[idx::vy] = derivative(c.y);
  return s;
}

orbit_start golden_start(const golden_case& g) {
  return {{g.x[0], g.y[0], g.vx[0], g.vy[0]}, g.t[0], std::max(1, g.period_revs)};
}

// ----------------------------------------------------------------------------------------------
// One-parameter refit: the value in [lo, hi] with which the hypothesis comes closest (RMS) to
// the view. A grid (orbits continued from point to point) brackets the minimum; the one
// least-squares solver (ref/inference/least_squares.hpp) refines it from the grid's best point
// within its neighbours. Near a grazing contact Newton may fail at some values: such a value is
// a rejected step of the solver, never read as a number.

struct refit {
  double value = 0.0;
  model_fit fit;  // on the thinned view
};

constexpr int kRefitGrid = 8;
// Hypotheses refined after the coarse grid: a wrong one comes no closer than ~1/2 of the
// difference there, the right one (its grid point within 1/16 of the range of the fault) several
// times closer, so the few closest hold it.
constexpr std::size_t kRefined = 4;

// The solver on one scalar x = centre + u step, u in [lo_u, hi_u], `residual` nothing where it
// cannot be evaluated; the solver's end.
double refine_scalar(const std::function<std::optional<Eigen::VectorXd>(double)>& residual, double centre, double step, double lo, double hi) {
  least_squares_problem lsq;
  lsq.residuals = [&](const Eigen::VectorXd& u) { return residual(centre + u[0] * step); };
  lsq.lower = Eigen::VectorXd::Constant(1, (lo - centre) / step);
  lsq.upper = Eigen::VectorXd::Constant(1, (hi - centre) / step);
  // The residuals (m) are the model's orbit against a candidate's: their unit of resolution is the
  // shooting's own accuracy (a candidate may match to it), so the solver converges to there.
  lsq.noise = kShootingTolerance;
  least_squares_options o;
  o.max_jacobians = default_count_of("diagnosis", "max_jacobians");
  o.difference_step = default_of("diagnosis", "difference_step");
  const least_squares_result f = solve_least_squares(lsq, Eigen::VectorXd::Zero(1), o);
  return centre + f.u[0] * step;
}

refit fit_one(const hypothesis& base, const std::function<void(hypothesis&, double)>& set, double lo, double hi, const view& v,
              const std::vector<orbit_start>& starts, bool refine, std::optional<double> extra = std::nullopt) {
  refit best;
  std::optional<orbit_start> warm;
  const auto evaluate_at = [&](double value) {
    hypothesis h = base;
    set(h, value);
    std::vector<orbit_start> guesses(starts.begin(), starts.begin() + (starts.empty() ? 0 : 1));
    if (warm) guesses.push_back(*warm);
    guesses.insert(guesses.end(), starts.begin() + (starts.empty() ? 0 : 1), starts.end());
    const model_fit f = evaluate(h, v, guesses);
    if (f.converged) warm = f.orbit;
    if (f.rms < best.fit.rms) best = {value, f};
    return f;
  };
  // The linearised step from the case's value (a small fault lies between grid points).
  if (extra && *extra >= lo && *extra <= hi) evaluate_at(*extra);
  const double step = (hi - lo) / kRefitGrid;
  for (int k = 0; k <= kRefitGrid; ++k) evaluate_at(lo + step * k);
  if (!best.fit.converged || !refine) return best;
  refine_scalar(
      [&](double value) -> std::optional<Eigen::VectorXd> {
        const model_fit f = evaluate_at(value);
        if (!f.converged) return std::nullopt;
        return Eigen::Map<const Eigen::VectorXd>(f.residual.data(), static_cast<Eigen::Index>(f.residual.size()));
      },
      best.value, step, std::max(lo, best.value - step), std::min(hi, best.value + step));
  return best;
}

// ----------------------------------------------------------------------------------------------
// Transforms of the golden orbit: candidate / scale = A golden(t + tau) + b.

// Cubic Hermite interpolation of the golden samples (positions and velocities) over one period:
// for the search only (its error, ~1e-8 of the orbit between contacts and larger across them,
// is far below any transform's effect); the verdict re-integrates the orbit exactly.
struct golden_curve {
  const golden_case& g;
  double t0, P, h;
  std::size_t per;  // samples per period
  explicit golden_curve(const golden_case& gc)
      : g(gc), t0(gc.t[0]), P(gc.period_revs * period_of(gc)), h(period_of(gc) / gc.request.samples_per_rev),
        per(static_cast<std::size_t>(gc.period_revs * gc.request.samples_per_rev)) {}
  std::array<double, 2> at(double t) const {
    double tau = std::fmod(t - t0, P);
    if (tau < 0.0) tau += P;
    const double u = tau / h;
    std::size_t i = static_cast<std::size_t>(u);
    const double s = u - static_cast<double>(i);
    i %= per;
    const std::size_t j = i + 1 < g.t.size() ? i + 1 : 0;
    const double h00 = (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s), h10 = s * (1.0 - s) * (1.0 - s), h01 = s * s * (3.0 - 2.0 * s),
                 h11 = s * s * (s - 1.0);
    return {h00 * g.x[i] + h10 * h * g.vx[i] + h01 * g.x[j] + h11 * h * g.vx[j],
            h00 * g.y[i] + h10 * h * g.vy[i] + h01 * g.y[j] + h11 * h * g.vy[j]};
  }
};

struct axis_map {
  int a11, a12, a21, a22;  // candidate = A golden (entries 0, +-1)
  std::string_view what;   // "" for the identity
};
constexpr std::array<axis_map, 8> kAxisMaps{{
    {1, 0, 0, 1, ""},
    {-1, 0, 0, 1, "x points the other way (x -> -x)"},
    {1, 0, 0, -1, "y points the other way (y -> -y: down where rubref's is up, the protrusion's side)"},
    {-1, 0, 0, -1, "both axes point the other way (x -> -x, y -> -y)"},
    {0, 1, 1, 0, "x and y are swapped"},
    {0, -1, 1, 0, "x and y are swapped and x points the other way"},
    {0, 1, -1, 0, "x and y are swapped and y points the other way"},
    {0, -1, -1, 0, "x and y are swapped and both point the other way"},
}};

struct unit_factor {
  double factor;  // candidate value = factor x metres
  std::string_view unit;
};
constexpr std::array<unit_factor, 5> kUnitFactors{{{1e3, "mm"}, {1e6, "um"}, {1.0 / 25.4e-6, "mils"}, {1.0 / 0.0254, "inches"}, {1e2, "cm"}}};
// A spread ratio within 2 % of a unit factor names it: the orbit's size changes by less under
// any single fault that leaves it near this case (a 6 % k1 change moves it ~0.1 %).
constexpr double kUnitMatch = 0.02;

struct transform_fit {
  std::size_t map = 0;
  double scale = 1.0;
  std::string_view unit;
  double tau = 0.0;  // s
  double bx = 0.0, by = 0.0;  // m
  double rms = kInf;
};

// RMS spread of a signal about its mean.
double spread(const std::vector<double>& a) {
  double m = 0.0;
  for (double v : a) m += v;
  m /= static_cast<double>(a.size());
  double s = 0.0;
  for (double v : a) s += (v - m) * (v - m);
  return std::sqrt(s / static_cast<double>(a.size()));
}

struct transform_search {
  const golden_curve& curve;
  const view& v;  // thinned candidate
  double scale;

  // Mean squared difference at shift tau (with the best constant offset when `offset`).
  double cost(const axis_map& A, double tau, bool offset, double* bx = nullptr, double* by = nullptr) const {
    const std::size_t n = v.t.size();
    double sx = 0.0, sy = 0.0, ss = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const auto p = curve.at(v.t[i] + tau);
      const double dx = v.x[i] / scale - (A.a11 * p[0] + A.a12 * p[1]);
      const double dy = v.y[i] / scale - (A.a21 * p[0] + A.a22 * p[1]);
      sx += dx;
      sy += dy;
      ss += dx * dx + dy * dy;
    }
    const double N = static_cast<double>(n);
    double mean_sq = ss / N;
    if (offset) {
      mean_sq -= (sx * sx + sy * sy) / (N * N);
      if (bx) *bx = sx / N;
      if (by) *by = sy / N;
    }
    return std::max(0.0, mean_sq);
  }

  // The differences at shift tau, x then y per sample (less their mean when `offset`): cost's
  // terms, for the solver.
  Eigen::VectorXd differences(const axis_map& A, double tau, bool offset) const {
    const std::size_t n = v.t.size();
    Eigen::VectorXd r(static_cast<Eigen::Index>(2 * n));
    for (std::size_t i = 0; i < n; ++i) {
      const auto p = curve.at(v.t[i] + tau);
      r[static_cast<Eigen::Index>(2 * i)] = v.x[i] / scale - (A.a11 * p[0] + A.a12 * p[1]);
      r[static_cast<Eigen::Index>(2 * i + 1)] = v.y[i] / scale - (A.a21 * p[0] + A.a22 * p[1]);
    }
    if (offset) {
      const double mx = r(Eigen::seq(0, Eigen::last, 2)).mean(), my = r(Eigen::seq(1, Eigen::last, 2)).mean();
      for (std::size_t i = 0; i < n; ++i) r[static_cast<Eigen::Index>(2 * i)] -= mx, r[static_cast<Eigen::Index>(2 * i + 1)] -= my;
    }
    return r;
  }

  // The best shift of map A: a grid of 4 points per golden sample over the period, then the
  // solver between the best point's neighbours.
  std::pair<double, double> best_shift(const axis_map& A, bool offset) const {
    const std::size_t M = 4 * curve.per;
    double best_tau = 0.0, best = kInf;
    for (std::size_t k = 0; k < M; ++k) {
      const double tau = curve.P * static_cast<double>(k) / static_cast<double>(M);
      const double c = cost(A, tau, offset);
      if (c < best) {
        best = c;
        best_tau = tau;
      }
    }
    const double d = curve.P / static_cast<double>(M);
    const double tau = refine_scalar([&](double t) -> std::optional<Eigen::VectorXd> { return differences(A, t, offset); }, best_tau, d, best_tau - d, best_tau + d);
    const double c = cost(A, tau, offset);
    return c < best ? std::pair{tau, c} : std::pair{best_tau, best};
  }
};

// tau folded to (-T/2, T/2].
double fold(double tau, double T) {
  double f = std::fmod(tau, T);
  if (f > T / 2) f -= T;
  if (f <= -T / 2) f += T;
  return f;
}

// ----------------------------------------------------------------------------------------------

// A hypothesis a refit tries: the cause it names, the parameter (its key), the model it changes,
// how the value enters it, the range searched and the case's own value (infinite: the hypothesis
// is not the case's model there).
struct candidate_refit {
  cause_code code;
  std::string name;
  hypothesis base;
  std::function<void(hypothesis&, double)> set;
  double lo, hi, value0;
};

struct diagnosis {
  const golden_case& g;
  const candidate_data& c;
  const record& header;
  const comparison_points* pts;
  // Causes with the strength of their evidence: 0 confirmed; 1 a re-simulation came tenfold
  // closer, or the candidate is in a state the case's model forbids (inside a rigid stator);
  // 2 a sign only (a period that differs, episodes that are missing).
  struct noted {
    cause c;
    int evidence;
  };
  std::vector<noted> found;
  double baseline_rms = kInf;  // m, the candidate against the golden orbit (or the nearer other attractor)
  double tolerance = 0.0;      // m
  int period = -1;             // the candidate's own (candidate_period)

  bool confirmed() const {
    return std::any_of(found.begin(), found.end(), [](const noted& k) { return k.c.confidence == cause_confidence::confirmed; });
  }
  void add(cause_code code, bool confirmed_, std::string detail, nlohmann::ordered_json fitted = nlohmann::ordered_json::object(),
           int evidence = 1) {
    found.push_back({{code, confirmed_ ? cause_confidence::confirmed : cause_confidence::likely, std::move(detail), std::move(fitted)},
                     confirmed_ ? 0 : evidence});
  }
  std::string reproduces(const model_fit& f) const {
    return f.max <= tolerance ? "reproduces the candidate to " + format_digits(f.max, 2) + " m (tolerance " + format_digits(tolerance, 3) + " m)"
                              : "comes closest, " + format_digits(f.rms, 2) + " m RMS (" + format_digits(baseline_rms / f.rms, 2) + " times closer than the case)";
  }

  // Where a hypothesis's orbit is shot from: the candidate's own state (with its own period when
  // it has one: if the hypothesis is right, the candidate is on that orbit), then the golden's.
  std::vector<orbit_start> starts() const {
    std::vector<orbit_start> out;
    if (const auto s = candidate_state(c, period > 0 ? period : g.period_revs)) out.push_back(*s);
    if (g.period_revs > 0) out.push_back(golden_start(g));
    return out;
  }

  void header_stage();
  int periodicity_stage();
  std::optional<transform_fit> transform_stage();
  void refit_stage(const std::optional<transform_fit>& transform);
  std::vector<candidate_refit> refit_hypotheses(const std::optional<transform_fit>& transform) const;
  std::vector<std::optional<double>> linearised_steps(const std::vector<candidate_refit>& list, const view& v, const std::vector<orbit_start>& from) const;
  void report_refit(const candidate_refit& item, double value, const model_fit& full, bool ok);
  void event_stage();
};

void diagnosis::header_stage() {
  std::vector<std::string> differ;
  nlohmann::ordered_json fitted = nlohmann::ordered_json::object();
  hypothesis h = case_hypothesis(g);
  bool usable = true;
  if (const std::string* v = header.find("variant"); v && *v != g.request.variant) {
    differ.push_back("variant " + *v + " (the case's is " + g.request.variant + ")");
    fitted["variant"] = *v;
    h.variant = *v;
    try {
      visit_variant(*v, []<class V>() {});
    } catch (const input_error&) {
      usable = false;
    }
  }
  const auto numeric = [&](std::string_view key, double want, const std::function<void(double)>& apply) {
    if (!header.find(key)) return;
    double got = 0.0;
    try {
      got = header.number(key);
    } catch (const input_error&) {
      differ.push_back(std::string(key) + " '" + *header.find(key) + "' (not a number)");
      usable = false;
      return;
    }
    if (std::abs(got - want) <= 1e-9 * std::abs(want)) return;
    differ.push_back(std::string(key) + " " + format_digits(got, 8) + " (the case's is " + format_digits(want, 8) + ")");
    fitted[std::string(key)] = got;
    apply(got);
  };
  numeric("speed_rpm", g.request.rpm, [&](double v) { h.omega = rpm_to_rad_s(v); });
  for (const auto& info : parameter_table) numeric(info.key, g.request.params.*info.member, [&, m = info.member](double v) { h.params.*m = v; });
  if (differ.empty()) return;
  std::string list;
  for (const auto& d : differ) list += (list.empty() ? "" : "; ") + d;
  bool confirmed_ = false;
  std::string how = "";
  if (usable && g.period_revs > 0 && h.omega > 0.0) {
    const model_fit f = evaluate(h, candidate_view(c), starts());
    confirmed_ = f.converged && f.max <= tolerance;
    if (f.converged) how = "; rubref with the header's values " + reproduces(f);
  }
  add(cause_code::header_mismatch, confirmed_,
      "the candidate's own header differs from the case: " + list + how + "; run the case's values (rubref params, or the golden file's header)",
      fitted);
}

// Revolution-to-revolution repetition against the case's period. Returns the candidate's period
// (0: none within its span, -1: too short to tell).
int diagnosis::periodicity_stage() {
  const int pc = period;
  const std::string advice = "start from rest (x = y = 0, x' = y' = 0) at t = 0 with the file's unbalance phase and settle " +
                             std::to_string(g.request.settle_revs) + " revolutions, as the case does";
  if (pc < 0) return pc;
  if (g.comparison == comparison_kind::statistics || g.period_revs == 0) {
    if (pc > 0 && g.comparison == comparison_kind::statistics)
      add(cause_code::other_attractor, false,
          "the candidate repeats every " + std::to_string(pc) + " revolution(s) where the case's steady state is chaotic: it settled on a periodic orbit; " + advice,
          {{"candidate_period_revs", pc}}, 2);
    return pc;
  }
  if (pc == 0) {
    add(cause_code::non_periodic, false,
        "the candidate does not repeat itself within its " + format_digits(spanned_revolutions(g, c), 3) + " revolutions where the case's orbit repeats every " +
            std::to_string(g.period_revs) + ": it has not settled, or it is chaotic; " + advice,
        {{"candidate_period_revs", 0}}, 2);
    return pc;
  }
  // Another orbit: a recorded coexisting attractor, or one shot from the candidate's own state.
  const view all = candidate_view(c);
  for (std::size_t k = 0; k < g.attractors.size(); ++k) {
    const auto& a = g.attractors[k];
    const model_fit f = evaluate(case_hypothesis(g), all, {{a.state, g.t[0], a.period_revs}});
    if (f.converged && f.max <= tolerance) {
      add(cause_code::other_attractor, true,
          "the candidate is on the case's coexisting period-" + std::to_string(a.period_revs) + " orbit (reached from " + a.start +
              "), not on the orbit from rest; " + advice,
          {{"candidate_period_revs", pc}, {"attractor", static_cast<int>(k + 1)}, {"start", a.start}, {"max_error_m", f.max}});
      return pc;
    }
  }
  // The case's own model shot from the candidate's state with the candidate's period: a stable
  // orbit there that reproduces the candidate confirms it; one that comes tenfold closer than
  // the golden is likely, and the later stages must then explain what is left of the difference.
  if (const auto s = candidate_state(c, pc)) {
    const model_fit f = evaluate(case_hypothesis(g), all, {*s});
    if (f.converged && f.max_multiplier < 1.0 && (f.max <= tolerance || f.rms * kLikelyReduction <= baseline_rms)) {
      const bool ok = f.max <= tolerance;
      add(cause_code::other_attractor, ok,
          "the case's own model has a stable period-" + std::to_string(pc) + " orbit (largest multiplier " + format_digits(f.max_multiplier, 3) + ") that " +
              (ok ? "reproduces the candidate to " + format_digits(f.max, 2) + " m" : "comes within " + format_digits(f.rms, 2) + " m RMS of the candidate") +
              ": the candidate settled there, not on the orbit from rest (period " + std::to_string(g.period_revs) + ")" +
              (ok ? "" : ", and differs from it a little more") + "; " + advice,
          {{"candidate_period_revs", pc}, {"max_multiplier", f.max_multiplier}, {"max_error_m", f.max}});
      if (!ok) baseline_rms = f.rms;
      return pc;
    }
  }
  if (pc % g.period_revs != 0 && g.period_revs % pc != 0)
    add(cause_code::other_attractor, false,
        "the candidate repeats every " + std::to_string(pc) + " revolution(s), the case every " + std::to_string(g.period_revs) +
            ": another orbit (another start, or another model); " + advice,
        {{"candidate_period_revs", pc}}, 2);
  else if (pc != g.period_revs)
    add(cause_code::other_attractor, false,
        "the candidate repeats every " + std::to_string(pc) + " revolution(s), the case every " + std::to_string(g.period_revs) +
            ": another orbit (another start, or another model); " + advice,
        {{"candidate_period_revs", pc}}, 2);
  return pc;
}

std::optional<transform_fit> diagnosis::transform_stage() {
  if (g.period_revs == 0 || g.comparison != comparison_kind::orbit) return std::nullopt;
  const golden_curve curve(g);
  const view v = thinned(candidate_view(c));
  const double T = period_of(g);
  // The unit factor, from the ratio of the two orbits' spreads.
  std::vector<double> gx, gy;
  for (double t : v.t) {
    const auto p = curve.at(t);
    gx.push_back(p[0]);
    gy.push_back(p[1]);
  }
  const double ratio = std::hypot(spread(v.x), spread(v.y)) / std::hypot(spread(gx), spread(gy));
  transform_fit best;
  for (const auto& u : kUnitFactors)
    if (std::abs(ratio / u.factor - 1.0) <= kUnitMatch) {
      best.scale = u.factor;
      best.unit = u.unit;
    }
  const transform_search search{curve, v, best.scale};
  const double identity_rms = std::sqrt(search.cost(kAxisMaps[0], 0.0, false)) * best.scale;
  // The best map and shift, without an offset, then with one if that cuts the error tenfold. A
  // map replaces the identity (or an earlier one) only when it is tenfold better in RMS: a
  // contact-free orbit is an ellipse, for which flipping both axes is exactly half a revolution
  // of shift, and a tie must not name a mirror.
  const auto better = [](double cost, double than) { return cost * kLikelyReduction * kLikelyReduction < than; };
  double best_cost = kInf;
  for (std::size_t k = 0; k < kAxisMaps.size(); ++k) {
    const auto [tau, cost] = search.best_shift(kAxisMaps[k], false);
    if (k == 0 || better(cost, best_cost)) {
      best_cost = cost;
      best.map = k;
      best.tau = tau;
    }
  }
  const double plain = best_cost;
  double with_offset_cost = kInf;
  std::size_t offset_map = 0;
  double offset_tau = 0.0;
  for (std::size_t k = 0; k < kAxisMaps.size(); ++k) {
    const auto [tau, cost] = search.best_shift(kAxisMaps[k], true);
    if (k == 0 || better(cost, with_offset_cost)) {
      with_offset_cost = cost;
      offset_map = k;
      offset_tau = tau;
    }
  }
  bool offset = false;
  // A part of a transform counts only when leaving it out costs tenfold in RMS and leaves the
  // candidate outside half the tolerance (else a shift of 1e-9 s found by the solver on an exact
  // match would be "significant").
  const double negligible = std::pow(0.5 * tolerance / best.scale, 2);
  if (with_offset_cost * kLikelyReduction * kLikelyReduction <= plain && plain > negligible) {
    offset = true;
    best.map = offset_map;
    best.tau = offset_tau;
    search.cost(kAxisMaps[best.map], best.tau, true, &best.bx, &best.by);
    best.bx *= best.scale;
    best.by *= best.scale;
    best_cost = with_offset_cost;
  }
  best.rms = std::sqrt(best_cost) * best.scale;
  // A shift by whole revolutions is the same orbit (the comparison already picks the best).
  const axis_map& A = kAxisMaps[best.map];
  const double whole = std::round(best.tau / T) * T;
  const double unshifted = search.cost(A, whole, offset);
  const bool shifted = unshifted > kLikelyReduction * kLikelyReduction * best_cost && unshifted > negligible;
  if (!shifted) best.tau = whole;
  const bool any = best.scale != 1.0 || best.map != 0 || shifted || offset;
  // Significant: the transform explains the difference at least tenfold better than the raw
  // comparison (the Hermite curve's own error, ~1e-8 of the orbit, sets the floor).
  if (!any || !(best.rms * kLikelyReduction <= std::max(baseline_rms, identity_rms))) return std::nullopt;

  // The verdict: the candidate mapped back, against the golden orbit integrated again exactly.
  view back = candidate_view(c);
  const double det = A.a11 * A.a22 - A.a12 * A.a21;
  for (std::size_t i = 0; i < back.t.size(); ++i) {
    const double u = back.x[i] / best.scale - best.bx / best.scale, w = back.y[i] / best.scale - best.by / best.scale;
    back.x[i] = (A.a22 * u - A.a12 * w) / det;
    back.y[i] = (-A.a21 * u + A.a11 * w) / det;
    back.t[i] += best.tau;
  }
  const model_fit f = evaluate(case_hypothesis(g), back, {golden_start(g)});
  const bool ok = f.converged && f.max <= tolerance;
  const std::string verdict = f.converged ? (ok ? ": with it the golden orbit reproduces the candidate to " + format_digits(f.max, 2) + " m"
                                                : ": with it the golden orbit comes within " + format_digits(f.rms, 2) + " m RMS of the candidate")
                                          : "";
  const double tau_fold = fold(best.tau, T);
  if (best.scale != 1.0)
    add(cause_code::units, ok,
        "the candidate's displacements are " + format_digits(best.scale, 6) + " times the golden's: written in " + std::string(best.unit) +
            ", not m" + verdict + "; the record's columns are SI (x_m, y_m)",
        {{"factor", best.scale}, {"unit", best.unit}});
  const bool half_turn = best.map == 1 && shifted && std::abs(std::abs(tau_fold) - T / 2) <= 1e-3 * T;
  if (half_turn) {
    add(cause_code::rotation_sense, ok,
        "the candidate is the mirror image x -> -x of the golden orbit, half a revolution on: its shaft (unbalance and friction) turns "
        "clockwise" + verdict + "; rubref's turns counter-clockwise, from +x to +y: the force is m e w^2 (cos wt, sin wt)",
        {{"mirror", "x"}, {"time_shift_s", best.tau}});
  } else {
    if (best.map != 0)
      add(cause_code::mirrored_axis, ok, "the candidate is the golden orbit with " + std::string(A.what) + verdict +
                                              "; rubref's x is horizontal, y points up to the protrusion",
          {{"map", {{"x", {A.a11, A.a12}}, {"y", {A.a21, A.a22}}}}});
    if (shifted) {
      const double phase_deg = fold(best.tau * g.omega(), kTwoPi) * 180.0 / std::numbers::pi;
      add(cause_code::time_origin_or_unbalance_phase, ok,
          "the candidate is the golden orbit " + format_digits(tau_fold, 6) + " s (" + format_digits(phase_deg, 4) +
              " deg of shaft rotation) " + (tau_fold > 0 ? "later" : "earlier") + " in phase" + verdict +
              ": its times count from another origin, or its unbalance starts at phase " + format_digits(phase_deg, 4) +
              " deg; rubref's t is absolute from rest and the force is m e w^2 (cos wt, sin wt)",
          {{"time_shift_s", tau_fold}, {"unbalance_phase_deg", phase_deg}});
    }
  }
  if (offset)
    add(cause_code::static_offset, ok,
        "the candidate is the golden orbit moved by (" + format_digits(best.bx, 4) + ", " + format_digits(best.by, 4) + ") m" + verdict +
            (ok ? ": a constant offset of its output (another origin)" : ": a static load (gravity?) or an offset of its origin"),
        {{"offset_x_m", best.bx}, {"offset_y_m", best.by}});
  return best;
}

// The hypotheses the refits try: every parameter of the case's law, the unbalance and its phase,
// the rotation sense, and a static load.
std::vector<candidate_refit> diagnosis::refit_hypotheses(const std::optional<transform_fit>& transform) const {
  const parameters& p = g.request.params;
  const bool rigid = visit_variant(g.request.variant, []<class V>() { return impact_law<V>; });
  const std::string& variant = g.request.variant;
  std::vector<candidate_refit> list;
  const hypothesis h0 = case_hypothesis(g);
  const auto member = [](double parameters::*m) { return [m](hypothesis& h, double v) { h.params.*m = v; }; };
  list.push_back({cause_code::clearance, "clearance_m", h0, member(&parameters::clearance), 0.5 * p.clearance, 1.5 * p.clearance, p.clearance});
  if (!rigid) {
    const double mu = std::max(p.mu, 0.1);
    list.push_back({cause_code::friction_coefficient, "mu", h0, member(&parameters::mu), -2.0 * mu, 2.0 * mu, p.mu});
    list.push_back({cause_code::contact_law_coefficient, "k1_N_m", h0, member(&parameters::k1), 0.5 * p.k1, 2.0 * p.k1, p.k1});
    if (variant == "piecewise-nonlinear" || variant == "identified")
      list.push_back({cause_code::contact_law_coefficient, "k3_N_m3", h0, member(&parameters::k3), 0.0, 3.0 * p.k3, p.k3});
    if (variant == "identified") {
      list.push_back({cause_code::contact_law_coefficient, "c2_kg_m", h0, member(&parameters::c2), 0.0, 3.0 * p.c2, p.c2});
      hypothesis damper = h0;
      damper.form = law_form::abs_damper;
      list.push_back({cause_code::contact_law_form, "c2_kg_m", damper, member(&parameters::c2), 0.0, 3.0 * p.c2, kInf});
    }
  } else {
    list.push_back({cause_code::contact_law_coefficient, "r", h0, member(&parameters::r), 0.0, 1.0, p.r});
  }
  list.push_back({cause_code::unbalance, "e_m", h0, member(&parameters::e), 0.5 * p.e, 2.0 * p.e, p.e});
  // Another unbalance phase at t = 0 (or time origin): on the same orbit the transforms find it
  // as a shift; this finds it when that start settled on another orbit.
  list.push_back({cause_code::time_origin_or_unbalance_phase, "unbalance_phase_rad", h0, member(&parameters::unbalance_phase), 0.0,
                  kTwoPi, kInf});
  // The unbalance turning clockwise while friction keeps rubref's direction (sin and cos swapped
  // in the force): omega < 0 with mu < 0 (rubref turns friction with omega), the phase fitted.
  {
    hypothesis reversed = h0;
    reversed.omega = -h0.omega;
    reversed.params.mu = -p.mu;
    list.push_back({cause_code::rotation_sense, "unbalance_phase_rad", reversed, member(&parameters::unbalance_phase), 0.0, kTwoPi, kInf});
  }
  // A static load F_y is an offset F_y / k_y and a clearance delta - F_y / k_y (Eq. 1 is linear
  // off contact): searched when the transforms saw an offset.
  // Searched over +-kMaxStaticLoad m g, or twice the offset the transforms saw.
  if (!rigid) {
    // Upwards no more than presses the rotor statically on the stator (delta k_y).
    const double f0 = transform ? std::abs(transform->by) * p.k_y : 0.0, range = std::max(kMaxStaticLoad * p.m * kStandardGravity, 2.0 * f0);
    list.push_back({cause_code::static_offset, "preload_y_N", h0,
                    [p](hypothesis& h, double F) {
                      h.params.clearance = p.clearance - F / p.k_y;
                      h.offset_y = F / p.k_y;
                    },
                    -range, std::min(range, p.clearance * p.k_y), 0.0});
  }

  return list;
}

// A small fault lies between the coarse grid's points: each hypothesis also tries the
// Gauss-Newton step from the case's value, p0 - (J . r0) / (J . J), with r0 the residual of the
// case's own orbit and J its derivative by a forward difference of 1e-4 of the range.
std::vector<std::optional<double>> diagnosis::linearised_steps(const std::vector<candidate_refit>& list, const view& v,
                                                              const std::vector<orbit_start>& from) const {
  const parameters& p = g.request.params;
  const hypothesis h0 = case_hypothesis(g);
  std::vector<std::optional<double>> linearised(list.size());
  const model_fit at_case = evaluate(h0, v, from);
  if (at_case.converged) {
    parallel_for(list.size(), thread_count(0, list.size()), [&](std::size_t k) {
      const auto& item = list[k];
      const bool case_model = item.base.form == h0.form && item.base.omega == h0.omega;
      const double p0 = item.code == cause_code::time_origin_or_unbalance_phase ? p.unbalance_phase : item.value0;
      if (!case_model || !std::isfinite(p0)) return;
      const double dp = 1e-4 * (item.hi - item.lo);
      hypothesis h = item.base;
      item.set(h, p0 + dp);
      const model_fit f = evaluate(h, v, {at_case.orbit});
      if (!f.converged || f.residual.size() != at_case.residual.size()) return;
      double jr = 0.0, jj = 0.0;
      for (std::size_t i = 0; i < f.residual.size(); ++i) {
        const double J = (f.residual[i] - at_case.residual[i]) / dp;
        jr += J * at_case.residual[i];
        jj += J * J;
      }
      if (jj > 0.0) linearised[k] = p0 - jr / jj;
    });
  }
  return linearised;
}

// Every hypothesis on the coarse grid; the kRefined closest to the candidate refined (the others
// get no verdict: not converged).
std::vector<refit> refit_all(const std::vector<candidate_refit>& list, const view& v, const std::vector<orbit_start>& from,
                             const std::vector<std::optional<double>>& linearised) {
  std::vector<refit> fits(list.size());
  parallel_for(list.size(), thread_count(0, list.size()), [&](std::size_t k) {
    fits[k] = fit_one(list[k].base, list[k].set, list[k].lo, list[k].hi, v, from, false, linearised[k]);
  });
  std::vector<std::size_t> order(list.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return fits[a].fit.rms < fits[b].fit.rms; });
  order.resize(std::min(order.size(), kRefined));
  std::erase_if(order, [&](std::size_t k) { return !fits[k].fit.converged; });
  parallel_for(order.size(), thread_count(0, order.size()), [&](std::size_t i) {
    const std::size_t k = order[i];
    fits[k] = fit_one(list[k].base, list[k].set, list[k].lo, list[k].hi, v, from, true, linearised[k]);
  });
  for (std::size_t k = 0; k < list.size(); ++k)
    if (std::find(order.begin(), order.end(), k) == order.end()) fits[k].fit.converged = false;  // not refined: no verdict

  return fits;
}

// What a refit that came closer says: the cause, in words, with its fitted value.
void diagnosis::report_refit(const candidate_refit& item, double value, const model_fit& full, bool ok) {
  const parameters& p = g.request.params;
  const std::string fit_text = reproduces(full);
  nlohmann::ordered_json fitted{{item.name, value}};
  if (std::isfinite(item.value0) && item.value0 != 0.0) fitted["relative_change"] = value / item.value0 - 1.0;
  switch (item.code) {
    case cause_code::friction_coefficient:
      if (value < 0.0) {
        add(cause_code::friction_sign, ok,
            "rubref with f_x = -mu f_N (mu = " + format_digits(-value) + ") " + fit_text +
                "; for a shaft spinning counter-clockwise (x towards y) the stator pushes the rotor's top towards +x, f_x = +mu f_N (docs/model.md)",
            fitted);
      } else {
        add(cause_code::friction_coefficient, ok, "rubref with mu = " + format_digits(value) + " instead of " + format_digits(p.mu) + " " + fit_text, fitted);
      }
      break;
    case cause_code::contact_law_form:
      add(cause_code::contact_law_form, ok,
          "rubref with c2 |z_dot| z_dot (a damper, c2 = " + format_digits(value) + " kg/m) in place of Eq. 5's c2 z_dot^2 " + fit_text +
              "; Eq. 5's term has the same sign in and out of contact (docs/model.md)",
          fitted);
      break;
    case cause_code::rotation_sense:
      add(cause_code::rotation_sense, ok,
          "rubref with the unbalance turning clockwise, m e w^2 (cos(-wt + phi), sin(-wt + phi)) with phi = " +
              format_digits(value * 180.0 / std::numbers::pi, 4) + " deg (friction as rubref's) " + fit_text +
              (std::abs(value - std::numbers::pi / 2) < 0.05 ? ": sin and cos swapped in the force?" : "") +
              "; rubref's force is m e w^2 (cos wt, sin wt)",
          {{"unbalance_phase_rad", value}, {"clockwise", true}});
      break;
    case cause_code::time_origin_or_unbalance_phase: {
      const double deg = fold(value, kTwoPi) * 180.0 / std::numbers::pi;
      add(cause_code::time_origin_or_unbalance_phase, ok,
          "rubref with the unbalance at " + format_digits(deg, 4) + " deg at t = 0 (the file's is " + format_digits(p.unbalance_phase * 180.0 / std::numbers::pi, 4) +
              " deg) " + fit_text + "; its time origin or unbalance phase differs from the case's",
          {{"unbalance_phase_rad", value}, {"unbalance_phase_deg", deg}});
      // No shift of the golden orbit matched (the transforms came first): from that start the
      // rotor settled on another orbit.
      if (ok)
        add(cause_code::other_attractor, true,
            "from that start the rotor settles on another orbit than the case's (no time shift of the golden orbit matches it); "
            "start from rest at t = 0 with the file's unbalance phase",
            {{"unbalance_phase_rad", value}});
      break;
    }
    case cause_code::static_offset:
      add(cause_code::static_offset, ok,
          "rubref with a static vertical load of " + format_digits(value, 4) + " N (" + format_digits(value / (p.m * kStandardGravity), 3) + " m g) " + fit_text +
              ": the candidate has gravity or a preload that the paper's Eq. 1 does not",
          {{"preload_y_N", value}});
      break;
    default: {
      std::string what = item.name, extra;
      if (item.code == cause_code::contact_law_coefficient && item.name == "r") {
        if (std::abs(value - std::sqrt(p.r)) <= 2e-3) extra = " (sqrt(" + format_digits(p.r) + ") = " + format_digits(std::sqrt(p.r)) + ": r applied to the kinetic energy instead of the velocity?)";
        if (std::abs(value - p.r * p.r) <= 2e-3) extra = " (" + format_digits(p.r) + "^2 = " + format_digits(p.r * p.r) + ": r applied twice?)";
      }
      add(item.code, ok,
          "rubref with " + what + " = " + format_digits(value, 6) + " instead of " + format_digits(item.value0, 6) + " (" + format_digits(100.0 * (value / item.value0 - 1.0), 3) +
              " %) " + fit_text + extra,
          fitted);
    }
  }
}

void diagnosis::refit_stage(const std::optional<transform_fit>& transform) {
  if (g.period_revs == 0 || g.comparison != comparison_kind::orbit) return;
  const view v = thinned(candidate_view(c));
  const std::vector<orbit_start> from = starts();
  const std::vector<candidate_refit> list = refit_hypotheses(transform);
  const std::vector<refit> fits = refit_all(list, v, from, linearised_steps(list, v, from));
  struct ranked {
    std::size_t k;
    model_fit full;
  };
  std::vector<ranked> hits;
  const view all = candidate_view(c);
  for (std::size_t k = 0; k < list.size(); ++k) {
    const refit& f = fits[k];
    if (!f.fit.converged || !(f.fit.rms * kLikelyReduction <= baseline_rms)) continue;
    // A value equal to the case's is no change.
    if (std::isfinite(list[k].value0) && std::abs(f.value - list[k].value0) <= 1e-6 * std::max(std::abs(list[k].value0), 1e-12)) continue;
    hypothesis h = list[k].base;
    list[k].set(h, f.value);
    std::vector<orbit_start> guesses{f.fit.orbit};
    guesses.insert(guesses.end(), from.begin(), from.end());
    hits.push_back({k, evaluate(h, all, guesses)});
  }
  // Reproduced ones first, then the closest.
  std::stable_sort(hits.begin(), hits.end(), [tol = tolerance](const ranked& a, const ranked& b) {
    const bool ca = a.full.max <= tol, cb = b.full.max <= tol;
    return ca == cb ? a.full.rms < b.full.rms : ca;
  });
  std::size_t likely = 0;
  for (const auto& [k, full] : hits) {
    const auto& item = list[k];
    const double value = fits[k].value;
    const bool ok = full.converged && full.max <= tolerance;
    if (!ok && ++likely > 3) continue;
    report_refit(item, value, full, ok);
  }
}

// Upward crossings of the clearance: contact episodes seen on the samples.
int episodes(const std::vector<double>& y, double clearance) {
  int count = 0;
  for (std::size_t i = 1; i < y.size(); ++i)
    if (y[i - 1] <= clearance && y[i] > clearance) ++count;
  return count;
}

// A naive code's run (compliant laws): odeint's fixed-step RK4 from rest at t = 0 on Eq. 1-2 as
// written (the force switched on by z > 0 inside the steps, no event located), its positions at
// the candidate's times, which must lie on its step grid. Empty when they do not.
template <class Law>
std::vector<std::array<double, 2>> naive_run(const golden_case& g, const candidate_data& c, double dt) {
  std::vector<long> steps;
  for (double t : c.t) {
    const double k = t / dt;
    if (std::abs(k - std::round(k)) > 1e-6) return {};
    steps.push_back(std::lround(k));
  }
  const rotor_system<Law> model(g.request.params, g.omega(), contact_phase::by_penetration);
  boost::numeric::odeint::runge_kutta4<state_type> rk4;
  state_type s{};
  std::vector<std::array<double, 2>> out;
  long k = 0;
  for (const long want : steps) {
    if (want < k) return {};
    for (; k < want; ++k) rk4.do_step(model, s, static_cast<double>(k) * dt, dt);
    if (!std::isfinite(s[idx::x]) || !std::isfinite(s[idx::y])) return {};
    out.push_back({s[idx::x], s[idx::y]});
  }
  return out;
}

// rubref's own run of the case from rest at t = 0, its positions at the candidate's times (the
// reference a naive scheme must beat): empty when they are not ascending from t >= 0.
std::vector<std::array<double, 2>> exact_run(const golden_case& g, const candidate_data& c) {
  if (c.t.empty() || c.t.front() < 0.0 || !std::is_sorted(c.t.begin(), c.t.end())) return {};
  return visit_variant(g.request.variant, [&]<class Law>() {
    const rotor_system<Law> model(g.request.params, g.omega());
    struct keeper {
      std::vector<std::array<double, 2>> s;
      void on_sample(double, const state_type& x, const rotor_system<Law>&) { s.push_back({x[idx::x], x[idx::y]}); }
      void on_event(const contact_event&) {}
    } kept;
    try {
      integrate_hybrid(model, start_state(model, state_type{}, 0.0), c.t.back(), g.request.integration, sample_grid::at(c.t), kept);
    } catch (const std::exception&) {
      return std::vector<std::array<double, 2>>{};
    }
    return kept.s;
  });
}

double rms_of(const std::vector<std::array<double, 2>>& run, const candidate_data& c, double* worst = nullptr) {
  double sum = 0.0, w = 0.0;
  for (std::size_t i = 0; i < run.size(); ++i) {
    const double e = std::hypot(run[i][0] - c.x[i], run[i][1] - c.y[i]);
    w = std::max(w, e);
    sum += e * e;
  }
  if (worst) *worst = w;
  return std::sqrt(sum / static_cast<double>(run.size()));
}

void diagnosis::event_stage() {
  const parameters& p = g.request.params;
  const double clearance = p.clearance, scale = kGoldenOrbitRelTol * g.statistics.max_radius;
  const bool rigid = visit_variant(g.request.variant, []<class V>() { return impact_law<V>; });

  std::size_t deepest = 0;
  for (std::size_t i = 1; i < c.y.size(); ++i)
    if (c.y[i] > c.y[deepest]) deepest = i;
  const double depth = c.y[deepest] - clearance;
  double golden_depth = 0.0;
  for (const double y : g.y) golden_depth = std::max(golden_depth, y - clearance);
  if (rigid && depth > scale)
    add(cause_code::missed_events, false,
        "the candidate goes " + format_digits(depth) + " m into the stator at t = " + format_digits(c.t[deepest], 10) +
            " s, which the restitution law (Eq. 6) never allows; impacts are detected late (only at step ends?) or missed between steps",
        {{"max_penetration_m", depth}, {"t_s", c.t[deepest]}});
  if (!rigid && golden_depth > 0.0 && depth > 1.5 * golden_depth + scale)
    add(cause_code::missed_events, false,
        "the candidate penetrates " + format_digits(depth) + " m where the golden's deepest sample is " + format_digits(golden_depth) +
            " m: contact onsets are detected late or missed between steps",
        {{"max_penetration_m", depth}, {"golden_max_penetration_m", golden_depth}}, 2);
  if (pts) {
    const int want = episodes(pts->gy, clearance), got = episodes(pts->y, clearance);
    if (got < want)
      add(cause_code::missed_events, false,
          std::to_string(got) + " contact episodes on the compared samples where the golden has " + std::to_string(want) +
              ": short or grazing contacts are missed between steps",
          {{"episodes", got}, {"golden_episodes", want}}, 2);
  }
  // A naive fixed step that reproduces the candidate (its sampling divided by 1, 2, 4 or 8).
  // It is likely when it comes tenfold closer than rubref's own run from rest at the same times.
  const auto exact = rigid || !pts ? std::vector<std::array<double, 2>>{} : exact_run(g, c);
  if (!exact.empty()) {
    const double exact_rms = rms_of(exact, c);
    const double h = median_spacing(c.t);
    for (int div : {1, 2, 4, 8}) {
      const auto run = visit_variant(g.request.variant, [&]<class Law>() -> std::vector<std::array<double, 2>> {
        if constexpr (compliant_law<Law>) return naive_run<Law>(g, c, h / div);
        return {};
      });
      if (run.empty()) break;
      double worst = 0.0;
      const double rms = rms_of(run, c, &worst);
      if (worst <= tolerance || rms * kLikelyReduction <= exact_rms) {
        add(cause_code::coarse_step, worst <= tolerance,
            "a fixed RK4 step of " + format_digits(h / div, 4) + " s (" + format_digits(period_of(g) * div / h, 4) +
                " a revolution) with the contact force switched inside the steps reproduces the candidate to " + format_digits(worst, 2) +
                " m: its step is too coarse for a contact of ~" + format_digits(1.0 / std::sqrt(p.k1 / p.m), 2) +
                " s time scale; locate the contact events or step finer (docs/robustness.md)",
            {{"dt_s", h / div}, {"max_error_m", worst}});
        break;
      }
    }
  }
}

}  // namespace

double required_revolutions(const golden_case& g) { return std::max(1, g.period_revs); }

double spanned_revolutions(const golden_case& g, const candidate_data& c) {
  if (c.t.size() < 2) return 0.0;
  return (c.t.back() - c.t.front() + median_spacing(c.t)) / period_of(g);
}

int candidate_period(const golden_case& g, const candidate_data& c) {
  const std::size_t n = c.t.size();
  if (n < 8) return -1;
  const double T = period_of(g), span = c.t.back() - c.t.front();
  double size = 0.0, curvature = 0.0;
  for (std::size_t i = 0; i < n; ++i) size = std::max(size, std::hypot(c.x[i], c.y[i]));
  for (std::size_t i = 1; i + 1 < n; ++i)
    curvature = std::max(curvature, std::hypot(c.x[i + 1] - 2.0 * c.x[i] + c.x[i - 1], c.y[i + 1] - 2.0 * c.y[i] + c.y[i - 1]));
  if (!(size > 0.0)) return -1;
  int tested = 0;
  for (int p = 1; p <= kMaxCandidatePeriod; ++p) {
    // At least a revolution of pairs p revolutions apart.
    if (span < (p + 1) * T * (1.0 - 1e-9)) break;
    tested = p;
    double err = 0.0;
    bool exact = true;
    for (std::size_t i = 0; i < n; ++i) {
      const double tp = c.t[i] + p * T;
      if (tp > c.t.back() + 1e-9 * T) break;
      auto j = static_cast<std::size_t>(std::lower_bound(c.t.begin(), c.t.end(), tp - 1e-9 * T) - c.t.begin());
      if (j >= n) j = n - 1;
      double px = c.x[j], py = c.y[j];
      if (std::abs(c.t[j] - tp) > 1e-9 * T) {
        exact = false;
        const std::size_t a = j == 0 ? 0 : j - 1;
        const double w = (tp - c.t[a]) / (c.t[j] - c.t[a]);
        px = c.x[a] + w * (c.x[j] - c.x[a]);
        py = c.y[a] + w * (c.y[j] - c.y[a]);
      }
      err = std::max(err, std::hypot(px - c.x[i], py - c.y[i]));
    }
    // Linear interpolation errs by at most h^2 |c''| / 8, the largest second difference / 8.
    if (err <= kRepeatRelTol * size + (exact ? 0.0 : curvature / 4.0)) return p;
  }
  // "Does not repeat" only when it could have repeated with the case's own period.
  return tested >= std::max(1, g.period_revs) ? 0 : -1;
}

std::vector<cause> diagnose(const golden_case& g, const candidate_data& c, const record& header, const comparison_points* pts) {
  diagnosis d{g, c, header, pts, {}, kInf, g.orbit_tolerance, candidate_period(g, c)};
  if (pts) {
    double sum = 0.0;
    for (std::size_t i = 0; i < pts->t.size(); ++i) sum += std::pow(pts->x[i] - pts->gx[i], 2) + std::pow(pts->y[i] - pts->gy[i], 2);
    d.baseline_rms = std::sqrt(sum / static_cast<double>(pts->t.size()));
  }
  const double spanned = spanned_revolutions(g, c), required = required_revolutions(g);
  if (spanned < required * (1.0 - 1e-6)) {
    d.add(cause_code::coverage, true,
          "the candidate spans " + format_digits(spanned, 3) + " revolution(s); the case needs at least " + format_digits(required, 3) +
              " (one period of its orbit) to be compared: record whole periods (best: the file's " + std::to_string(g.request.record_revs) +
              " revolutions at its own t_s)",
          {{"spanned_revs", spanned}, {"required_revs", required}});
    return {d.found.front().c};
  }
  const auto finish = [&] {
    if (d.found.empty())
      d.add(cause_code::none_found, false,
            "no single cause found: no transform of the golden orbit and no single change of the model reproduces the candidate; "
            "check Eq. 1-2 term by term against docs/model.md");
    // A likely cause that a later stage confirmed is said once, confirmed.
    std::erase_if(d.found, [&](const diagnosis::noted& k) {
      return k.evidence > 0 && std::any_of(d.found.begin(), d.found.end(), [&](const diagnosis::noted& o) { return o.c.code == k.c.code && o.evidence == 0; });
    });
    std::stable_sort(d.found.begin(), d.found.end(), [](const diagnosis::noted& a, const diagnosis::noted& b) { return a.evidence < b.evidence; });
    std::vector<cause> out;
    for (auto& k : d.found) out.push_back(std::move(k.c));
    return out;
  };
  d.header_stage();
  if (d.confirmed()) return finish();
  const int period = d.periodicity_stage();
  d.period = period;
  if (d.confirmed()) return finish();
  // Stages that compare with the golden orbit need the candidate on an orbit of the case's period.
  const bool settled = period < 0 || (g.period_revs > 0 && period > 0 && period % g.period_revs == 0);
  std::optional<transform_fit> transform;
  if (pts && settled) {
    transform = d.transform_stage();
    if (d.confirmed()) return finish();
  }
  if (pts && (settled || period > 0)) {
    d.refit_stage(transform);
    if (d.confirmed()) return finish();
  }
  d.event_stage();
  return finish();
}

}  // namespace rubref
