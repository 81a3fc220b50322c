#pragma once
// Known answers. The contact-free rotor (Eq. 1 with f_x = f_y = 0) is linear with harmonic
// forcing, so its steady state is closed form: per axis, X = m e w^2 e^{j phi} / (k - m w^2 + j c w),
// x(t) = Re(X e^{jwt}) and y(t) = Re(-j Y e^{jwt}) because sin(a) = Re(-j e^{ja}).

#include <cmath>
#include <complex>
#include <numbers>

#include "ref/model/parameters.hpp"
#include "ref/model/state.hpp"

namespace rubref {

struct unbalance_response {
  std::complex<double> x_phasor;  // m, x(t) = Re(x_phasor e^{jwt})
  std::complex<double> y_phasor;  // m, y(t) = Re(y_phasor e^{jwt})
  double omega;                   // rad/s

  unbalance_response(const parameters& p, double w) : omega(w) {
    using namespace std::complex_literals;
    const std::complex<double> force = p.m * p.e * w * w * std::exp(1i * p.unbalance_phase);
    x_phasor = force / std::complex<double>(p.k_x - p.m * w * w, p.c_x * w);
    y_phasor = -1i * force / std::complex<double>(p.k_y - p.m * w * w, p.c_y * w);
  }

  // The steady-state orbit at time t (an exact solution of Eq. 1 without contact).
  state_type at(double t) const {
    using namespace std::complex_literals;
    const std::complex<double> rot = std::exp(1i * (omega * t));
    const std::complex<double> x = x_phasor * rot, y = y_phasor * rot;
    const std::complex<double> vx = 1i * omega * x, vy = 1i * omega * y;
    return {x.real(), y.real(), vx.real(), vy.real()};
  }

  // Eq. 7's whirl components: x + jy = forward e^{jwt} + backward e^{-jwt}.
  std::complex<double> forward() const {
    using namespace std::complex_literals;
    return 0.5 * (x_phasor + 1i * y_phasor);
  }
  std::complex<double> backward() const {
    using namespace std::complex_literals;
    return 0.5 * (std::conj(x_phasor) + 1i * std::conj(y_phasor));
  }
};

// The contact-free orbit as an ellipse. With r_f = |forward|, r_b = |backward| (Eq. 7) the
// semi-axes are r_f + r_b and |r_f - r_b|, the major axis lies at (arg F + arg B) / 2 from +x,
// and the orbit turns with the shaft (counter-clockwise, forward) when r_f > r_b.
struct whirl_ellipse {
  double semi_major = 0.0;  // m
  double semi_minor = 0.0;  // m
  double tilt = 0.0;        // rad, the major axis' angle from +x, in [0, pi)
  bool forward = true;
};

inline whirl_ellipse ellipse_of(const unbalance_response& r) {
  const std::complex<double> f = r.forward(), b = r.backward();
  whirl_ellipse e;
  e.semi_major = std::abs(f) + std::abs(b);
  e.semi_minor = std::abs(std::abs(f) - std::abs(b));
  e.tilt = std::fmod(0.5 * (std::arg(f) + std::arg(b)) + 2.0 * std::numbers::pi, std::numbers::pi);
  e.forward = std::abs(f) >= std::abs(b);
  return e;
}

}  // namespace rubref
