// The swept run-up's closed form (ref/tracking/swept_response.hpp) against the equations it solves:
//  - its state against the linear rotor's ODE integrated by odeint (run-up and coast-down, both
//    forcings, an anisotropic rotor with cross-coupling);
//  - a block's 1X read against the ODE with the read integrated alongside;
//  - the table's interpolated read against the closed form at every node;
//  - a slow sweep reads the steady response (the table fit's closed form, written here apart);
//  - above the critical speed the ringing beats against the 1X, its maxima at speeds where
//    (Omega - w)^2 advances by 4 pi alpha: set by the sweep rate alone (Lewis 1932).

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include <boost/numeric/odeint.hpp>

#include "ref/tracking/swept_response.hpp"

namespace rubref {
namespace {

using cplx = std::complex<double>;
constexpr cplx kJ(0.0, 1.0);
constexpr double kPi = std::numbers::pi;

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
        // A block through the first mode's ringing (t = 1.6 s: 164 rad/s up, 196 rad/s down).
        const double ta = 1.6, tb = [&] {  // N revolutions on from ta
          const double w0 = s.speed(ta), a = 0.5 * alpha, c = -2.0 * kPi * revolutions;
          return ta + (-w0 + std::sqrt(w0 * w0 - 4.0 * a * c)) / (2.0 * a);
        }();
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
              << "alpha " << alpha << ", N " << revolutions << ", column " << c;
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

}  // namespace
}  // namespace rubref
