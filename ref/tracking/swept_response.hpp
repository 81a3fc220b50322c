#pragma once
// The 1X a table reads off a rotor swept through its speeds (docs/real-data.md, "Run-ups as they
// are run"). The linear rotor of the table fit (response_fit.hpp: modes, anisotropy,
// cross-coupling, unbalance, bow; per unit mass) under a constant angular acceleration alpha,
// Omega(t) = Omega_s + alpha t, theta(t) = Omega_s t + alpha t^2 / 2, is forced by
//
//   unbalance  U (Omega^2 - j alpha) e^{j theta} (1, -j)   (= -U d^2/dt^2 e^{j theta}: the
//              eccentric mass's acceleration, the tangential term included)
//   bow        B e^{j theta} (w_x^2, -j w_y^2)
//
// and a probe at angle beta reads Re(.) of its response plus its runout. In the modes of the
// state matrix (lambda_k, eta_k' = lambda_k eta_k + p_k g(t)) each response is closed form in
// the Faddeeva function (Lewis's passage through resonance): with c = sqrt(-j alpha / 2) and
// x_k(t) = c t - (j Omega_s - lambda_k) / (2 c),
//
//   integral_0^t e^{lambda (t - s)} e^{j theta(s)} ds
//     = sqrt(pi) / (2 c) [e^{lambda t} w(j x(0)) - e^{j theta(t)} w(j x(t))],
//
// so eta_k(t) = e^{j theta} S_k(t) + R_k(t): S_k the sweep's own (adiabatic) response, slowly
// varying, and R_k = a free mode e^{lambda_k t}, the ringing, which starts where the sweep passes
// the mode (Re x_k = 0, where the bounded branch of w changes: w(jx) = 2 e^{x^2} - w(-jx)). Every
// response starts adiabatic at t = 0 (no ringing yet: the sweep is taken to have run before the
// first row as it runs after it; to first order in alpha that is the steady response there).
//
// The table's instrument reads each row's 1X over a block of N revolutions centred on the row
// (computed order tracking in the shaft-angle domain), from a keyphasor pulse: v = 1/(pi N)
// integral r(theta) e^{-j theta} d theta with theta = 0 at the block's start, and the row's speed
// is the block's mean speed. r is linear in (Re U, Im U) and
// (Re B, Im B) but not complex-linear in U once the sweep rings (the backward parts of the
// modes read as a conjugate), so each real coordinate has its own column.
//
// Numerics: S_k is interpolated by Chebyshev series on spans it is smooth over (its coefficients'
// tail below 1e-13 of their size, spans halved until it is; spans end where a mode's branch
// changes), so w is evaluated some 16 times per span and mode, not per sample; the block
// integrals are Gauss-Legendre with enough nodes for their fastest phase (2 Omega, Omega + w_k).

#include <array>
#include <complex>
#include <vector>

#include <Eigen/Dense>

namespace rubref {

// The linear rotor per unit mass: support axes x and y (rad/s), damping ratios, cross-coupling
// k_xy/m, k_yx/m (1/s^2).
struct linear_rotor {
  double wx = 0.0, wy = 0.0, zx = 0.0, zy = 0.0, kxy = 0.0, kyx = 0.0;
};

// The two forcings a table's rotor has: the unbalance's and the bow's, per unit complex amplitude.
enum class swept_forcing { unbalance, bow };

// A constant-acceleration sweep of `rotor`: time 0 at speed omega_start (rad/s), alpha (rad/s^2;
// > 0 a run-up, < 0 a coast-down). numerical_error where the state matrix has no well-conditioned
// modes (a mode exactly critically damped) or a mode grows (an unstable rotor).
class swept_response {
 public:
  swept_response(const linear_rotor& rotor, double omega_start, double alpha);

  double speed(double t) const { return omega_start_ + alpha_ * t; }
  double angle(double t) const { return (omega_start_ + 0.5 * alpha_ * t) * t; }
  double alpha() const { return alpha_; }

  // The complex state (x, y, x', y') at time t >= 0 answering the complex forcing (its real part
  // answers the real forcing Re(.)), straight from the closed form.
  Eigen::Vector4cd state(double t, swept_forcing f) const;

  // One probe's 1X read over [ta, tb] (N revolutions of the shaft from a keyphasor pulse: the
  // angle is taken as 0 at ta, as an order tracker takes it), per unit Re and Im of the
  // forcing's amplitude (steady, the second is j times the first), straight from the closed form
  // at every node (the reference for the interpolated read of swept_1x).
  std::array<std::complex<double>, 2> read(double ta, double tb, double revolutions, double beta, swept_forcing f) const;

  struct mode {
    std::complex<double> lambda;
    std::complex<double> p_unbalance, p_bow;  // (V^-1 d)_k
    std::complex<double> x0;                   // x_k(0)
    double crossing = 0.0;                     // t where Re x_k = 0 (<= 0: never, in t > 0)
    // R_k(t) = ring e^{j theta(t*)} e^{lambda (t - t*)} for t > t* = crossing (ring relative to the
    // shaft's angle there); the speed and angle at t*.
    std::complex<double> ring_unbalance, ring_bow;
    double crossing_speed = 0.0, crossing_angle = 0.0;
    Eigen::Vector2cd displacement;                   // V's (x, y) rows of the mode's vector
  };
  const std::vector<mode>& modes() const { return modes_; }
  // Mode k's S_k(t) for forcing f (on its bounded branch at t); for both forcings at once (one
  // Faddeeva evaluation): {unbalance, bow}.
  std::complex<double> adiabatic(std::size_t k, double t, swept_forcing f) const;
  std::array<std::complex<double>, 2> adiabatic_both(std::size_t k, double t) const;
  // Mode k's ringing R_k(t) for forcing f (0 before its crossing).
  std::complex<double> ringing(std::size_t k, double t, swept_forcing f) const;

 private:
  double omega_start_, alpha_;
  std::complex<double> c_;  // sqrt(-j alpha / 2)
  std::vector<mode> modes_;
};

// The 1X of a table's rows under a sweep: per probe (angles in rad) and row (speeds in rad/s, any
// order), the columns {Re U, Im U, Re B, Im B}. The rows' times follow from their speeds,
// t = (Omega - Omega_s) / alpha (rising speed for a run-up, falling for a coast-down), time 0 at the
// first row's block start; each row's block is N revolutions at its mean speed. input_error where
// a block would reach zero speed (alpha too fast for the table's lowest speed and N).
struct swept_table_columns {
  std::vector<std::vector<std::array<std::complex<double>, 4>>> columns;  // [probe][row]
};
swept_table_columns swept_1x(const linear_rotor& rotor, const std::vector<double>& speeds, double alpha, double revolutions,
                             const std::vector<double>& probe_angles, bool with_bow);

// The same rows' times and blocks (for tests and figures): time 0 at the first block's start.
struct swept_rows {
  double omega_start = 0.0;
  std::vector<double> time, block_start, block_end;  // per row, in the rows' order
};
swept_rows swept_row_times(const std::vector<double>& speeds, double alpha, double revolutions);

}  // namespace rubref
