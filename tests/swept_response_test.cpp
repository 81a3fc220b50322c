// The swept run-up's closed form (ref/tracking/swept_response.hpp) against the equations it solves:
//  - its state against the linear rotor's ODE integrated by odeint (run-up and coast-down, both
//    forcings, an anisotropic rotor with cross-coupling);
//  - a block's 1X read against the ODE with the read integrated alongside;
//  - the table's interpolated read against the closed form at every node;
//  - a slow sweep reads the steady response (the table fit's closed form, written here apart);
//  - above the critical speed the ringing beats against the 1X, its maxima at speeds where
//    (Omega - w)^2 advances by 4 pi alpha: set by the sweep rate alone (Lewis 1932).

#include <gtest/gtest.h>

#include "tests/estimate_checks.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstring>
#include <numbers>
#include <vector>

#include <boost/numeric/odeint.hpp>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/format/order_table.hpp"
#include "ref/tracking/response_fit.hpp"
#include "ref/tracking/swept_response.hpp"
#include "ref/tracking/tracking_loop.hpp"
#include "ref/tracking/tracking_report.hpp"

#include <optional>
#include <random>

namespace rubref {
namespace {

using cplx = std::complex<double>;
constexpr cplx kJ(0.0, 1.0);
constexpr double kPi = std::numbers::pi;

// The tests' tables of known truth, made apart from the closed form: the rotor's real equations
// integrated by odeint through a sweep, each row's 1X demodulated over its block of N revolutions
// (blocks end to end, as an order tracker reports them), with runout and seeded noise.
struct swept_truth {
  linear_rotor rotor;
  double alpha = 0.0;        // rad/s^2 (< 0: a coast-down)
  double revolutions = 1.0;  // per row
  std::size_t every = 1;     // a row every `every` blocks (a monitoring system's logging interval)
  cplx unbalance{0.0}, runout{0.0};
  double beta = 0.0;         // the probe's angle
  double from = 0.0, to = 0.0;  // the rows' speeds (rad/s), in time order
  double noise = 0.0;
};
// with_time: the table has a time_s column (each block's middle).
order_table swept_table(const swept_truth& t, unsigned seed = 11, bool with_time = false);

// An anisotropic rotor with cross-coupling (per unit mass): modes near 150 and 180 rad/s.
linear_rotor anisotropic() { return {150.0, 180.0, 0.02, 0.03, 400.0, -900.0}; }

// The complex state (x, y, x', y') and the block integrals A = int rho e^{-j theta} Omega dt and
// B = int conj(rho) e^{-j theta} Omega dt for one probe, as one real ODE for odeint.
using ode_state = std::array<double, 12>;
struct swept_ode {
  linear_rotor r;
  double omega_start, alpha, beta;
  swept_forcing f;
  void operator()(const ode_state& s, ode_state& ds, double t) const {
    const cplx x(s[0], s[1]), y(s[2], s[3]), vx(s[4], s[5]), vy(s[6], s[7]);
    const double w = omega_start + alpha * t, theta = (omega_start + 0.5 * alpha * t) * t;
    const cplx turn = std::polar(1.0, theta);
    const cplx g = f == swept_forcing::unbalance ? (w * w - kJ * alpha) * turn : turn;
    const cplx fx = f == swept_forcing::unbalance ? g : r.wx * r.wx * g, fy = f == swept_forcing::unbalance ? -kJ * g : -kJ * r.wy * r.wy * g;
    const cplx ax = fx - r.wx * r.wx * x - r.kxy * y - 2.0 * r.zx * r.wx * vx;
    const cplx ay = fy - r.kyx * x - r.wy * r.wy * y - 2.0 * r.zy * r.wy * vy;
    const cplx rho = std::cos(beta) * x + std::sin(beta) * y, back = std::conj(turn);
    const cplx da = rho * back * w, db = std::conj(rho) * back * w;
    const cplx d[6] = {vx, vy, ax, ay, da, db};
    for (int i = 0; i < 6; ++i) ds[2 * i] = d[i].real(), ds[2 * i + 1] = d[i].imag();
  }
};

ode_state start_of(const Eigen::Vector4cd& z) {
  ode_state s{};
  for (int i = 0; i < 4; ++i) s[2 * i] = z(i).real(), s[2 * i + 1] = z(i).imag();
  return s;
}

// Integrates from t0 to t1 at tolerances far below the comparisons' (1e-13 absolute and relative
// on states of order 1e-2 to 1).
void integrate(const swept_ode& ode, ode_state& s, double t0, double t1) {
  using namespace boost::numeric::odeint;
  integrate_adaptive(make_controlled<runge_kutta_dopri5<ode_state>>(1e-13, 1e-13), ode, s, t0, t1, 1e-4);
}

double largest(const Eigen::Vector4cd& z) { return z.cwiseAbs().maxCoeff(); }

TEST(SweptResponse, ItsStateSolvesTheRotorsEquations) {
  // Run-up through both modes (100 -> 260 rad/s at 40 rad/s^2: eta = alpha / w^2 about 1.5e-3,
  // eta / zeta^2 about 4: well ringing) and a coast-down the other way.
  for (const double alpha : {40.0, -40.0})
    for (const swept_forcing f : {swept_forcing::unbalance, swept_forcing::bow}) {
      const double omega_start = alpha > 0.0 ? 100.0 : 260.0;
      const swept_response s(anisotropic(), omega_start, alpha);
      swept_ode ode{anisotropic(), omega_start, alpha, 0.0, f};
      ode_state y = start_of(s.state(0.0, f));
      double t = 0.0;
      for (const double to : {1.0, 2.0, 3.0, 4.0}) {
        integrate(ode, y, t, to);
        t = to;
        const Eigen::Vector4cd z = s.state(t, f);
        // The closed form's Faddeeva evaluations are good to about 1e-13 relative; the
        // integration's error grows with its 4 s (~100 revolutions) to about 1e-10.
        for (int i = 0; i < 4; ++i)
          EXPECT_NEAR(std::abs(z(i) - cplx(y[2 * i], y[2 * i + 1])) / largest(z), 0.0, 1e-8) << "alpha " << alpha << ", t " << t << ", component " << i;
      }
    }
}

TEST(SweptResponse, ABlocksReadIsTheIntegratedDemodulation) {
  for (const double alpha : {40.0, -40.0}) {
    const double omega_start = alpha > 0.0 ? 100.0 : 260.0, beta = 0.7;
    const swept_response s(anisotropic(), omega_start, alpha);
    for (const swept_forcing f : {swept_forcing::unbalance, swept_forcing::bow})
      for (const double revolutions : {1.0, 3.0}) {
        // A block through the first mode's ringing (t = 1.6 s: 164 rad/s up, 196 rad/s down), and
        // one that holds a mode's crossing (where its ringing starts, mid-block).
        // Each starts at a keyphasor pulse (theta a whole number of revolutions), as a read's block does.
        const auto time_at_angle = [&](double theta) { return (-omega_start + std::sqrt(omega_start * omega_start + 2.0 * alpha * theta)) / alpha; };
        const auto pulse_after = [&](double t) { return time_at_angle(2.0 * kPi * std::ceil(s.angle(t) / (2.0 * kPi))); };
        for (const double ta : {pulse_after(1.6), pulse_after(s.modes()[0].crossing > 0.0 ? s.modes()[0].crossing - 0.05 : s.modes()[1].crossing - 0.05)}) {
        const double tb = time_at_angle(s.angle(ta) + 2.0 * kPi * revolutions);
        swept_ode ode{anisotropic(), omega_start, alpha, beta, f};
        ode_state y = start_of(s.state(0.0, f));
        integrate(ode, y, 0.0, ta);
        for (int i = 8; i < 12; ++i) y[static_cast<std::size_t>(i)] = 0.0;
        integrate(ode, y, ta, tb);
        const cplx a(y[8], y[9]), b(y[10], y[11]);
        const double scale = 1.0 / (2.0 * kPi * revolutions);
        const std::array<cplx, 2> want{scale * (a + b), scale * kJ * (a - b)};
        const std::array<cplx, 2> got = s.read(ta, tb, revolutions, beta, f);
        for (int c = 0; c < 2; ++c)
          EXPECT_NEAR(std::abs(got[static_cast<std::size_t>(c)] - want[static_cast<std::size_t>(c)]) / std::abs(want[0]), 0.0, 1e-8)
              << "alpha " << alpha << ", N " << revolutions << ", column " << c << ", block from " << ta << " s";
        }
      }
  }
}

TEST(SweptResponse, TheTablesInterpolatedReadIsTheClosedForm) {
  // Rows 2 % apart from 100 to 260 rad/s (the time axis from the speeds), two probes.
  std::vector<double> speeds;
  for (double w = 100.0; w < 260.0; w *= 1.02) speeds.push_back(w);
  const std::vector<double> probes{0.3, 1.9};
  for (const double alpha : {40.0, -40.0})
    for (const double revolutions : {1.0, 4.0}) {
      const swept_table_columns cols = swept_1x(anisotropic(), speeds, alpha, revolutions, probes, true);
      const swept_rows rows = swept_row_times(speeds, alpha, revolutions);
      const swept_response s(anisotropic(), rows.omega_start, alpha);
      for (std::size_t p = 0; p < probes.size(); ++p)
        for (std::size_t i = 0; i < speeds.size(); ++i) {
          // Each row's block spans N revolutions at its speed (the instrument's block).
          EXPECT_NEAR(s.angle(rows.block_end[i]) - s.angle(rows.block_start[i]), 2.0 * kPi * revolutions, 1e-9);
          EXPECT_NEAR(s.speed(rows.time[i]), speeds[i], 1e-9 * speeds[i]);
          for (const swept_forcing f : {swept_forcing::unbalance, swept_forcing::bow}) {
            const auto exact = s.read(rows.block_start[i], rows.block_end[i], revolutions, probes[p], f);
            const std::size_t c0 = f == swept_forcing::bow ? 2 : 0;
            // The interpolants' tails are below 1e-13 of their size.
            for (std::size_t c = 0; c < 2; ++c)
              EXPECT_NEAR(std::abs(cols.columns[p][i][c0 + c] - exact[c]) / std::abs(exact[0]), 0.0, 1e-10);
          }
        }
    }
}

TEST(SweptResponse, TheTablesReadIsTheSameBitForBitOnOneAndTwoThreads) {
  // The rows' reads run on the machine's threads from spans made beforehand, each writing its own.
  std::vector<double> speeds;
  for (double w = 100.0; w < 260.0; w *= 1.002) speeds.push_back(w);
  const auto on = [&](unsigned threads) {
    set_default_threads(threads);
    const swept_table_columns c = swept_1x(anisotropic(), speeds, 40.0, 2.0, {0.3, 1.9}, true);
    set_default_threads(0);
    return c;
  };
  const swept_table_columns one = on(1), two = on(2);
  for (std::size_t p = 0; p < 2; ++p)
    for (std::size_t i = 0; i < speeds.size(); ++i) EXPECT_EQ(std::memcmp(one.columns[p][i].data(), two.columns[p][i].data(), sizeof(cplx) * 4), 0) << "row " << i;
}

// The steady 1X per unit unbalance (w^2 (1, -j) forcing) and per unit bow, solved here apart.
std::array<cplx, 2> steady(const linear_rotor& r, double w, double beta) {
  const cplx dxx(r.wx * r.wx - w * w, 2.0 * r.zx * r.wx * w), dyy(r.wy * r.wy - w * w, 2.0 * r.zy * r.wy * w);
  const auto solve = [&](cplx fx, cplx fy) {
    const cplx det = dxx * dyy - r.kxy * r.kyx;
    return std::cos(beta) * (dyy * fx - r.kxy * fy) / det + std::sin(beta) * (dxx * fy - r.kyx * fx) / det;
  };
  return {w * w * solve(1.0, -kJ), solve(r.wx * r.wx, -kJ * r.wy * r.wy)};
}

TEST(SweptResponse, ASlowSweepReadsTheSteadyResponse) {
  // eta = alpha / w^2 = 4e-6, eta / zeta^2 = 0.01 for the lighter damped mode: the sweep's lag
  // moves the response by about that share near the peak, and by far less away from it.
  std::vector<double> speeds;
  for (double w = 100.0; w < 260.0; w *= 1.01) speeds.push_back(w);
  const double alpha = 4e-6 * 150.0 * 150.0, beta = 0.3;
  const swept_table_columns cols = swept_1x(anisotropic(), speeds, alpha, 1.0, {beta}, true);
  double worst = 0.0;
  for (std::size_t i = 0; i < speeds.size(); ++i) {
    const auto st = steady(anisotropic(), speeds[i], beta);
    worst = std::max(worst, std::abs(cols.columns[0][i][0] - st[0]) / std::abs(st[0]));
    worst = std::max(worst, std::abs(cols.columns[0][i][1] - kJ * st[0]) / std::abs(st[0]));
    worst = std::max(worst, std::abs(cols.columns[0][i][2] - st[1]) / std::abs(st[1]));
  }
  EXPECT_LT(worst, 0.02);
  EXPECT_GT(worst, 1e-6);  // and a sweep is not the steady response
}

TEST(SweptResponse, TheRingingBeatsAtSpeedsSetByTheSweepRateAlone) {
  // An isotropic, lightly damped rotor (w = 150 rad/s, zeta = 0.005) run up at 30 rad/s^2: above
  // the critical its 1X vector x e^{-j theta} (the complex response, an ideal tracker) is largest
  // where the ringing at the damped natural frequency w_d comes into phase with the 1X again:
  // (Omega - w_d)^2 / (2 alpha) advancing by 2 pi. (A table's block read adds the ringing's
  // leakage at w_d + Omega, which a block of whole revolutions does not cancel.)
  const linear_rotor r{150.0, 150.0, 0.005, 0.005, 0.0, 0.0};
  const double alpha = 30.0, wd = 150.0 * std::sqrt(1.0 - 0.005 * 0.005);
  const swept_response s(r, 120.0, alpha);
  std::vector<double> speed, size;
  for (double t = 0.0; t < 4.5; t += 1e-3) {
    speed.push_back(s.speed(t));
    size.push_back(std::abs(s.state(t, swept_forcing::unbalance)(0)));
  }
  std::vector<double> peaks;
  for (std::size_t i = 1; i + 1 < speed.size(); ++i)
    if (speed[i] > 170.0 && size[i] > size[i - 1] && size[i] >= size[i + 1]) peaks.push_back(speed[i]);
  ASSERT_GE(peaks.size(), 4u);
  for (std::size_t k = 1; k < 4; ++k) {
    const double step = (std::pow(peaks[k] - wd, 2) - std::pow(peaks[k - 1] - wd, 2)) / (4.0 * kPi * alpha);
    // One beat per 2 pi of the relative phase, within 5 % (the steady phase's drift over a beat
    // and the 0.03 rad/s sampling).
    EXPECT_NEAR(step, 1.0, 0.05) << "between the beats at " << peaks[k - 1] << " and " << peaks[k] << " rad/s";
  }
}


// The real rotor (x, y, x', y') under the real unbalance force e (Omega^2 cos, Omega^2 sin)(theta +
// phi) + e alpha (sin, -cos)(theta + phi), and the probe's 1X accumulated over the block.
struct real_swept_ode {
  const swept_truth& t;
  double omega_start;
  void operator()(const std::array<double, 6>& s, std::array<double, 6>& ds, double time) const {
    const double w = omega_start + t.alpha * time, theta = (omega_start + 0.5 * t.alpha * time) * time;
    const double psi = theta + std::arg(t.unbalance), e = std::abs(t.unbalance);
    const linear_rotor& r = t.rotor;
    const double fx = e * (w * w * std::cos(psi) + t.alpha * std::sin(psi)), fy = e * (w * w * std::sin(psi) - t.alpha * std::cos(psi));
    ds[0] = s[2], ds[1] = s[3];
    ds[2] = fx - r.wx * r.wx * s[0] - r.kxy * s[1] - 2.0 * r.zx * r.wx * s[2];
    ds[3] = fy - r.kyx * s[0] - r.wy * r.wy * s[1] - 2.0 * r.zy * r.wy * s[3];
    const double reading = std::cos(t.beta) * s[0] + std::sin(t.beta) * s[1];
    ds[4] = reading * std::cos(theta) * w, ds[5] = -reading * std::sin(theta) * w;
  }
};

order_table swept_table(const swept_truth& t, unsigned seed, bool with_time) {
  using namespace boost::numeric::odeint;
  // A lead-in from 0.7 of the first row's speed, started steady there: what a steady start leaves
  // beside the sweep's own response decays over the lead-in (e^{-zeta w t}, far below the noise).
  const double omega_start = t.alpha > 0.0 ? 0.7 * t.from : 1.2 * t.from;
  const real_swept_ode ode{t, omega_start};
  // The steady state there: the unbalance's w^2 (1, -j) forcing through the 2x2 dynamic stiffness.
  const linear_rotor& r = t.rotor;
  const cplx dxx(r.wx * r.wx - omega_start * omega_start, 2.0 * r.zx * r.wx * omega_start), dyy(r.wy * r.wy - omega_start * omega_start, 2.0 * r.zy * r.wy * omega_start);
  const cplx fx = t.unbalance * omega_start * omega_start, fy = -kJ * fx, det = dxx * dyy - r.kxy * r.kyx;
  const cplx x = (dyy * fx - r.kxy * fy) / det, y = (dxx * fy - r.kyx * fx) / det;
  std::array<double, 6> s{x.real(), y.real(), -omega_start * x.imag(), -omega_start * y.imag(), 0.0, 0.0};
  const auto time_at_angle = [&](double theta) {  // theta(t) = w0 t + alpha t^2 / 2
    return (-omega_start + std::sqrt(omega_start * omega_start + 2.0 * t.alpha * theta)) / t.alpha;
  };
  order_table table;
  table.source = "swept";
  table.orders = {{"", 1, t.beta, {}, "amp_1x", "phase_1x"}};
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> n(0.0, t.noise);  // this toolchain's; the tolerances hold for any draw
  std::vector<std::pair<double, cplx>> rows;  // in time order
  std::vector<double> times;                  // each row's block's middle
  double time = 0.0;
  for (std::size_t block = 0;; ++block) {
    const double ta = time_at_angle(2.0 * kPi * t.revolutions * static_cast<double>(block));
    const double tb = time_at_angle(2.0 * kPi * t.revolutions * static_cast<double>(block + 1));
    if (!std::isfinite(tb)) break;
    integrate_adaptive(make_controlled<runge_kutta_dopri5<std::array<double, 6>>>(1e-12, 1e-10), ode, s, time, ta, 1e-4);
    s[4] = s[5] = 0.0;
    integrate_adaptive(make_controlled<runge_kutta_dopri5<std::array<double, 6>>>(1e-12, 1e-10), ode, s, ta, tb, 1e-4);
    time = tb;
    const double speed = 2.0 * kPi * t.revolutions / (tb - ta);
    const bool started = t.alpha > 0.0 ? speed >= t.from : speed <= t.from;
    if (started && block % t.every == 0) rows.emplace_back(speed, cplx(s[4], s[5]) / (kPi * t.revolutions) + t.runout + cplx(n(gen), n(gen))), times.push_back(0.5 * (ta + tb));
    if (t.alpha > 0.0 ? speed > t.to : speed < t.to) break;
  }
  // As the reader leaves a file: rows in rising speed, each with its line (its place in time).
  std::vector<std::size_t> order(rows.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return rows[a].first < rows[b].first; });
  for (const std::size_t i : order) {
    table.rpm.push_back(rows[i].first * 60.0 / (2.0 * kPi));
    table.line.push_back(i + 2);
    table.orders[0].vector.push_back(rows[i].second);
    if (with_time) table.time_s.push_back(times[i]);
  }
  return table;
}

// A lightly damped isotropic rotor (1432 rpm, zeta 0.01) swept at eta / zeta^2 = 2 (alpha = 4.5
// rad/s^2, 43 rpm/s): a table that rings for a few beats above the critical speed; read every 2
// revolutions, one probe at a declared angle, runout, 0.05 µm of noise against ~50 µm at the peak.
swept_truth ringing_run_up() {
  swept_truth t;
  t.rotor = {150.0, 150.0, 0.01, 0.01, 0.0, 0.0};
  t.alpha = 2.0 * 0.01 * 0.01 * 150.0 * 150.0;
  t.revolutions = 2.0;
  t.unbalance = std::polar(10e-6, 0.8);
  t.runout = std::polar(1e-6, -0.4);
  t.beta = 0.3;
  t.from = 75.0, t.to = 300.0;
  t.noise = 0.05e-6;
  return t;
}

using testing::expect_within;

void expect_recovered(const swept_truth& t, const response_fit& swept, const response_fit& steady_fit) {
  const double rpm = 60.0 / (2.0 * kPi);
  // Within the 95 % intervals, widened by 1 % of the truth: the intervals are linearised and the
  // table's integration is good to about 1e-9 relative, far inside.
  expect_within(swept.sweep_rpm_per_s, std::abs(t.alpha) * rpm, 0.01, "sweep rate");
  EXPECT_TRUE(swept.sweep_rpm_per_s.determined);
  EXPECT_EQ(swept.sweep_direction, t.alpha > 0.0 ? 1 : -1);
  EXPECT_EQ(swept.sweep_revolutions, t.revolutions);
  expect_within(swept.modes.front().critical_speed_rpm, t.rotor.wx * rpm, 0.01, "critical speed");
  expect_within(swept.modes.front().damping_ratio, t.rotor.zx, 0.01, "damping ratio");
  expect_within(swept.unbalance_m, std::abs(t.unbalance), 0.01, "unbalance");
  EXPECT_TRUE(swept.consistent_with_noise) << "chi2/dof " << swept.chi2 / static_cast<double>(swept.dof);
  // The steady fit of the same table is biased: its critical speed's interval misses the truth
  // (the sweep drags the peak along: higher on a run-up, lower on a coast-down).
  const auto& m = steady_fit.modes.front().critical_speed_rpm;
  EXPECT_TRUE(t.rotor.wx * rpm < m.lo || t.rotor.wx * rpm > m.hi) << m.value << " [" << m.lo << ", " << m.hi << "]";
  EXPECT_EQ(m.value > t.rotor.wx * rpm, t.alpha > 0.0);
  EXPECT_FALSE(steady_fit.consistent_with_noise);
}

// The table's swept fit started from its steady fit, as the loop starts it, with options `o`.
response_fit swept_fit(const order_table& table, const response_fit& steady_fit, response_fit_options o = {}) {
  response_parts parts;
  parts.sweep = true;
  o.start = &steady_fit;
  return fit_response(table, parts, o);
}

TEST(SweptFit, ARingingRunUpIsRecoveredWithinItsIntervals) {
  const swept_truth t = ringing_run_up();
  const order_table table = swept_table(t);
  const response_fit steady_fit = fit_response(table, {});
  expect_recovered(t, swept_fit(table, steady_fit), steady_fit);
}

TEST(SweptFit, ACoastDownRingsBelowTheCriticalSpeedAndIsRecovered) {
  swept_truth t = ringing_run_up();
  t.alpha = -t.alpha, t.from = 300.0, t.to = 75.0;
  const order_table table = swept_table(t);
  EXPECT_EQ(sweep_direction_of(table), -1);
  const response_fit steady_fit = fit_response(table, {});
  expect_recovered(t, swept_fit(table, steady_fit), steady_fit);
}

TEST(SweptFit, ATimeColumnGivesTheRateWhichTheFitHolds) {
  // A coast-down with a time_s column, its rows shuffled in the file: the time says the direction
  // and the rate (the line through the blocks' middles: exact for a constant acceleration, to the
  // table's integration, 1e-9), and the fit holds the rate and recovers the rotor.
  swept_truth t = ringing_run_up();
  t.alpha = -t.alpha, t.from = 300.0, t.to = 75.0;
  order_table table = swept_table(t, 11, true);
  std::mt19937_64 gen(3);
  std::shuffle(table.line.begin(), table.line.end(), gen);
  EXPECT_EQ(sweep_direction_of(table), -1);
  const std::optional<timed_sweep> timed = sweep_of_times(table);
  ASSERT_TRUE(timed.has_value());
  EXPECT_NEAR(timed->alpha, t.alpha, 1e-6 * std::abs(t.alpha));
  EXPECT_LT(timed->departure_rpm, 1e-6 * timed->range_rpm);
  const response_fit steady_fit = fit_response(table, {});
  response_fit_options o;
  o.sweep_rate = std::abs(timed->alpha);
  const response_fit swept = swept_fit(table, steady_fit, o);
  EXPECT_TRUE(swept.sweep_rate_held);
  EXPECT_EQ(swept.sweep_rpm_per_s.value, std::abs(timed->alpha) * 60.0 / (2.0 * kPi));
  expect_recovered(t, swept, steady_fit);
  // One coordinate fewer than the fit that finds the rate itself.
  EXPECT_EQ(swept_fit(table, steady_fit).parameters, swept.parameters + 1);
}

TEST(SweptFit, BlocksThatFitAsWellWidenTheIntervalsToCoverTheirs) {
  // A slower sweep (eta / zeta^2 = 0.1) read in blocks of 3: the block changes the read little,
  // so several blocks may fit as well. Whatever the fit chose, the truth is inside the intervals,
  // and they cover those of the fit held at any block named as fitting as well.
  swept_truth t = ringing_run_up();
  t.alpha = 0.1 * 0.01 * 0.01 * 150.0 * 150.0, t.revolutions = 3.0;
  const order_table table = swept_table(t, 13);
  const response_fit steady_fit = fit_response(table, {});
  const response_fit f = swept_fit(table, steady_fit);
  // (This table's blocks 1, 2 and 3 fit alike: the test reaches the widening.)
  ASSERT_GT(f.sweep_alternatives.size(), 1u);
  EXPECT_EQ(f.sweep_alternatives.front(), f.sweep_revolutions);
  const double rpm = 60.0 / (2.0 * kPi);
  // (1 % of slack, as expect_recovered's: linearised intervals.)
  expect_within(f.sweep_rpm_per_s, t.alpha * rpm, 0.01, "sweep rate");
  expect_within(f.modes.front().critical_speed_rpm, t.rotor.wx * rpm, 0.01, "critical speed");
  expect_within(f.modes.front().damping_ratio, t.rotor.zx, 0.01, "damping ratio");
  // A held block's fit starts elsewhere and ends within the solver's tolerance of the same point:
  // its interval's ends agree to far better than 1e-6 of the speed.
  for (std::size_t i = 1; i < f.sweep_alternatives.size(); ++i) {
    response_fit_options held;
    held.revolutions_per_row = f.sweep_alternatives[i];
    const response_fit at_block = swept_fit(table, steady_fit, held);
    const auto& g = at_block.modes.front().critical_speed_rpm;
    const auto& c = f.modes.front().critical_speed_rpm;
    EXPECT_LE(c.lo, g.lo + 1e-6 * g.value) << f.sweep_alternatives[i];
    EXPECT_GE(c.hi, g.hi - 1e-6 * g.value) << f.sweep_alternatives[i];
  }
}

TEST(SweptFit, AHeldRateTooFastForEveryBlockIsRefused) {
  // 1e6 rad/s^2 at 75 rad/s: a block of one revolution (2 pi / 75 s) would pass zero speed.
  const order_table table = swept_table(ringing_run_up());
  response_parts parts;
  parts.sweep = true;
  response_fit_options o;
  o.sweep_rate = 1e6;
  EXPECT_THROW(fit_response(table, parts, o), input_error);
}

// A fast sweep of a lightly damped rotor (zeta 0.005, eta / zeta^2 = 8) logged every 10th block
// of 5 revolutions, as campaign seed 2718's #490: the ringing shows in a few rows above the
// critical speed, and from one row to the next its phase against the 1X turns several times over,
// so chi^2 is aliased in rate and critical speed together and the rate's starts (ranked at the
// steady fit's mode) miss the truth's basin; the scan of chi^2 itself over both finds it.
swept_truth sparsely_logged_fast_run_up() {
  swept_truth t = ringing_run_up();
  t.rotor = {153.7, 153.7, 0.005, 0.005, 0.0, 0.0};
  t.alpha = 8.25 * 0.005 * 0.005 * 153.7 * 153.7;
  t.revolutions = 5.0;
  t.every = 10;
  t.from = 93.0, t.to = 514.0;
  t.unbalance = std::polar(7.66e-6, -0.07);
  t.runout = std::polar(1.85e-6, 2.86);
  t.noise = 0.23e-6;
  return t;
}

TEST(SweptFit, AFastSweepLoggedSparselyIsFoundByTheScanOfItsChi2) {
  const swept_truth t = sparsely_logged_fast_run_up();
  const order_table table = swept_table(t);
  const response_fit steady_fit = fit_response(table, {});
  expect_recovered(t, swept_fit(table, steady_fit), steady_fit);
}

TEST(SweptLoop, NamesTheSweepOfARingingRunUp) {
  // Logged every third block (249 rows, not 747: the loop fits every combination swept, each
  // evaluation a response at every row).
  swept_truth t = ringing_run_up();
  t.every = 3;
  const tracking_result r = run_tracking_loop(swept_table(t));
  std::string trace;
  for (const auto& m : r.models) trace += m.estimates + ": " + m.summary + "\n";
  EXPECT_EQ(r.decision.named, std::vector<std::string>{"sweep_transient"}) << trace;
  EXPECT_EQ(r.decision.claim, "full") << trace;
  EXPECT_TRUE(r.after.parts.sweep);
  // The steady fit of the same effects beside it: in the report (its bias) and in the figure.
  ASSERT_TRUE(r.steady.has_value());
  EXPECT_FALSE(r.steady->parts.sweep);
  EXPECT_NE(to_markdown(r).find("the steady fit of the same effects put mode both at"), std::string::npos);
  EXPECT_TRUE(plot_data(r)["probes"][0].contains("steady_re"));
}

// A fast run-up read every revolution (zeta 0.02, eta / zeta^2 = 30, 26 rows): the ringing
// turns the 1X by a large angle from row to row, so the rows' scatter, and the steady fits'
// residual, count it as noise (some 400 times the truth's), and the base fit alone looks at the
// noise.
swept_truth fast_ringing_run_up() {
  swept_truth t = ringing_run_up();
  t.rotor = {150.0, 150.0, 0.02, 0.02, 0.0, 0.0};
  t.alpha = 30.0 * 0.02 * 0.02 * 150.0 * 150.0;
  t.revolutions = 1.0;
  return t;
}

TEST(SweptLoop, TriesTheSweepWhereTheRingingPassesForNoise) {
  const order_table table = swept_table(fast_ringing_run_up());
  // The premise: at the noise the rows' scatter and the steady fit's residual give (the smaller,
  // as the loop takes it), the base fit fits to it.
  response_fit_options at_scatter;
  at_scatter.noise_m = residual_noise(fit_response(table, {}));
  at_scatter.noise_m.front() = std::min(at_scatter.noise_m.front(), row_scatter_noise(table).front());
  ASSERT_TRUE(fit_response(table, {}, at_scatter).consistent_with_noise);
  const tracking_result r = run_tracking_loop(table);
  std::string trace;
  for (const auto& m : r.models) trace += m.estimates + ": " + m.summary + "\n";
  EXPECT_EQ(r.decision.named, std::vector<std::string>{"sweep_transient"}) << trace;
  EXPECT_EQ(r.decision.claim, "full") << trace;
  // The noise came down to the swept fit's residual scatter, near the truth's.
  EXPECT_LT(r.after.noise_m.front(), 2.0 * fast_ringing_run_up().noise) << trace;
}

// The fast run-up read every 2 revolutions: 14 rows, halves of 7, too few to refit on. The loop
// deals them into three folds (every refit on 9 or 10 rows) and tests the sweep out of sample there;
// with halves alone the sweep is "significant, not tested out of sample", never named.
TEST(SweptLoop, TestsAShortTableOutOfSampleOnMoreFolds) {
  swept_truth t = fast_ringing_run_up();
  t.revolutions = 2.0;
  const order_table table = swept_table(t);
  ASSERT_EQ(table.rows(), 14u);  // the premise: each half is 7 rows, under the 8 a refit needs
  const tracking_result r = run_tracking_loop(table);
  std::string trace;
  for (const auto& m : r.models) trace += m.estimates + ": " + m.summary + "\n";
  EXPECT_EQ(r.decision.named, std::vector<std::string>{"sweep_transient"}) << trace;
  const auto named = std::find_if(r.models.begin(), r.models.end(), [](const tracked_model& m) { return m.effects == std::vector<std::string>{"sweep_transient"}; });
  ASSERT_NE(named, r.models.end());
  ASSERT_EQ(named->needs.size(), 1u);
  EXPECT_EQ(named->needs[0].held_out_with.size(), 3u) << named->needs[0].reason;  // 14 rows: 3 folds leave 9-10 to refit on
}

// A slow run-up (eta / zeta^2 = 0.1 for the lighter mode) of an anisotropic rotor (modes 150 and
// 165 rad/s, zeta 0.04), one probe at an undeclared angle, read every 8 revolutions (101 rows),
// 0.45 µm of noise: the isotropic base cannot fit it, so the swept base fit finds no rate, and the
// anisotropic steady fit passes for noise at the noise the table gives (at the truth's its
// chi^2/dof is 1.6); the sweep shows only beside the anisotropy (campaign seed 3319, #152).
TEST(SweptLoop, FindsASlowSweepBesideTheEffectThatHidesItFromTheBase) {
  swept_truth t = ringing_run_up();
  t.rotor = {150.0, 165.0, 0.04, 0.04, 0.0, 0.0};
  t.alpha = 0.1 * 0.04 * 0.04 * 150.0 * 150.0;
  t.revolutions = 8.0;
  t.from = 110.0, t.to = 220.0;
  t.noise = 0.45e-6;
  order_table table = swept_table(t);
  table.orders[0].probe_angle.reset();
  const tracking_result r = run_tracking_loop(table);
  std::string trace;
  for (const auto& m : r.models) trace += m.estimates + ": " + m.summary + "\n";
  const auto model = [&](std::vector<std::string> effects) {
    return std::find_if(r.models.begin(), r.models.end(), [&](const tracked_model& m) { return m.effects == effects; });
  };
  // The premise: the swept base fit alone finds no rate, and the anisotropic steady fit passes for
  // noise at the noise a table read without sweeps gives (the smaller of the rows' scatter and its
  // own residual's), so nothing looks left for a sweep to explain.
  ASSERT_NE(model({"sweep_transient"}), r.models.end());
  EXPECT_FALSE(model({"sweep_transient"})->undetermined.empty()) << trace;
  response_parts anisotropic;
  anisotropic.anisotropy = true;
  response_fit_options steady_noise;
  steady_noise.noise_m = residual_noise(fit_response(table, anisotropic));
  steady_noise.noise_m.front() = std::min(steady_noise.noise_m.front(), row_scatter_noise(table).front());
  EXPECT_TRUE(fit_response(table, anisotropic, steady_noise).consistent_with_noise) << trace;
  EXPECT_EQ(r.decision.named, (std::vector<std::string>{"anisotropy", "sweep_transient"})) << trace;
}

// The same rotor's steady response (the sweep infinitely slow), rows every 0.5 % from 75 to 300
// rad/s, with noise; `runout_step`: the runout steps up by that share above 220 rad/s (a probe
// recalibrated mid-run), which no model here has.
order_table steady_table(double runout_step) {
  const swept_truth t = ringing_run_up();
  order_table table;
  table.source = "steady";
  table.orders = {{"", 1, t.beta, {}, "amp_1x", "phase_1x"}};
  std::mt19937_64 gen(5);
  std::normal_distribution<double> n(0.0, t.noise);  // this toolchain's; the assertions hold for any draw
  for (double w = t.from; w <= t.to; w *= 1.005) {
    table.rpm.push_back(w * 60.0 / (2.0 * kPi));
    table.line.push_back(table.rpm.size() + 1);
    const double step = w > 220.0 ? runout_step : 0.0;
    table.orders[0].vector.push_back(t.unbalance * steady(t.rotor, w, t.beta)[0] + t.runout * (1.0 + step) + cplx(n(gen), n(gen)));
  }
  return table;
}

TEST(SweptFit, ASteadyTableIsQuasiSteady) {
  // Fitted swept, its rate is not determined: the table cannot tell it from steady (its interval
  // reaches far slower rates, or the fit sits at the slow end of its range).
  const order_table table = steady_table(0.0);
  const response_fit steady_fit = fit_response(table, {});
  EXPECT_TRUE(steady_fit.consistent_with_noise);
  const response_fit swept = swept_fit(table, steady_fit);
  EXPECT_FALSE(swept.sweep_rpm_per_s.determined) << swept.sweep_rpm_per_s.value << " [" << swept.sweep_rpm_per_s.lo << ", " << swept.sweep_rpm_per_s.hi << "]";
}

TEST(SweptLoop, GivesNoSweepToASteadyTableWithAnEffectOutsideTheModel) {
  // The runout doubling above 220 rad/s (1 µm more, 20 times the noise): the residual is not
  // noise, so the loop tries the sweep, which must not take the misfit's place.
  // (The probe's angle undeclared, so the rub is not tried: its orbits are not what this tests.)
  order_table table = steady_table(1.0);
  table.orders[0].probe_angle.reset();
  const tracking_result r = run_tracking_loop(table);
  EXPECT_FALSE(r.before.consistent_with_noise);
  std::string trace;
  bool tried = false;
  for (const auto& m : r.models) {
    trace += m.estimates + ": " + m.summary + "\n";
    tried = tried || std::find(m.effects.begin(), m.effects.end(), "sweep_transient") != m.effects.end();
  }
  EXPECT_TRUE(tried) << trace;
  for (const auto& e : r.decision.chosen()) EXPECT_NE(e, "sweep_transient") << trace;
  // The swept base fit cannot tell its rate: the report says the table is quasi-steady.
  const auto swept_base = std::find_if(r.models.begin(), r.models.end(), [](const tracked_model& m) { return m.effects == std::vector<std::string>{"sweep_transient"}; });
  ASSERT_NE(swept_base, r.models.end());
  EXPECT_FALSE(swept_base->undetermined.empty()) << trace;
  EXPECT_NE(to_markdown(r).find("the table is quasi-steady at its noise"), std::string::npos);
}

}  // namespace
}  // namespace rubref
