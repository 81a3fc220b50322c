#pragma once
// RapidCheck generators for rubref's parameter structs: physically bounded (a lab rotor kit of
// the RK-4's kind, within a factor of a few of the paper's §3 values), uniform over their ranges
// at every size. No tests here. A failing case prints its seed; RC_PARAMS="seed=..." (or the
// "reproduce" string RapidCheck prints) replays it.

#include <rapidcheck.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <ostream>

#include "ref/model/parameters.hpp"
#include "ref/model/state.hpp"

namespace rubref::props {

// A double uniform on [lo, hi]. gen::inRange scales its range with the generation size (small
// cases first); the size is pinned here so every case spans the whole physical range, and
// shrinking still moves towards lo.
inline rc::Gen<double> uniform(double lo, double hi) {
  constexpr std::int64_t kSteps = std::int64_t{1} << 40;
  return rc::gen::map(rc::gen::resize(100, rc::gen::inRange<std::int64_t>(0, kSteps + 1)),
                      [lo, hi](std::int64_t k) { return lo + (hi - lo) * (static_cast<double>(k) / static_cast<double>(kSteps)); });
}

// log-uniform on [lo, hi], lo > 0: stiffnesses span decades.
inline rc::Gen<double> log_uniform(double lo, double hi) {
  return rc::gen::map(uniform(std::log(lo), std::log(hi)), [](double v) { return std::exp(v); });
}

// A contact-free rotor: the clearance is far beyond any orbit these parameters produce.
inline constexpr double kNoContactClearance = 1.0;  // m

// Where a thrown rotor starts: below the stator, moving up hard enough to reach it.
struct throw_case {
  parameters p;
  double rpm;        // rev/min: the unbalance (if any) and the default step caps
  state_type start;  // at t = 0

  // Vertical amplitude of the free undamped motion from `start`, in units of the clearance.
  double reach() const {
    const double wy = std::sqrt(p.k_y / p.m);
    return std::hypot(start[idx::y], start[idx::vy] / wy) / p.clearance;
  }
};

// A start that rises into the stator within half a vertical period: y0 in [-delta, 0.9 delta],
// free vertical amplitude `reach` clearances (> 1), x0 within a clearance, any horizontal speed
// up to `vx_max` m/s with the sign asked for (`vx_sign` 0: either).
inline rc::Gen<state_type> rising_start(const parameters& p, double reach_lo, double reach_hi, double vx_max, int vx_sign = 0) {
  const double wy = std::sqrt(p.k_y / p.m), clearance = p.clearance;
  const double vx_lo = vx_sign > 0 ? 0.0 : -vx_max, vx_hi = vx_sign < 0 ? 0.0 : vx_max;
  return rc::gen::apply(
      [=](double y_frac, double reach, double x_frac, double vx) {
        const double y0 = y_frac * clearance, amplitude = reach * clearance;
        return state_type{x_frac * clearance, y0, vx, wy * std::sqrt(amplitude * amplitude - y0 * y0)};
      },
      uniform(-1.0, 0.9), uniform(reach_lo, reach_hi), uniform(-1.0, 1.0), uniform(vx_lo, vx_hi));
}

}  // namespace rubref::props

namespace rc {

// Every model parameter over the range a lab rotor kit can have (paper §3, Table 2 in the middle).
template <>
struct Arbitrary<rubref::parameters> {
  static Gen<rubref::parameters> arbitrary() {
    using rubref::props::log_uniform;
    using rubref::props::uniform;
    return gen::apply(
        [](double m, double e, double phase, double c_x, double c_y, double k_x, double k_y, double clearance, double mu,
           double r, double k1, double k3, double c2) {
          rubref::parameters p;
          p.m = m;
          p.e = e;
          p.unbalance_phase = phase;
          p.c_x = c_x;
          p.c_y = c_y;
          p.k_x = k_x;
          p.k_y = k_y;
          p.clearance = clearance;
          p.mu = mu;
          p.r = r;
          p.k1 = k1;
          p.k3 = k3;
          p.c2 = c2;
          return p;
        },
        uniform(0.5, 5.0),                                // m, kg
        uniform(0.0, 0.2e-3),                             // e, m
        uniform(-std::numbers::pi, std::numbers::pi),     // unbalance angle, rad
        uniform(0.0, 50.0), uniform(0.0, 50.0),           // c_x, c_y, kg/s: damping ratios up to ~0.1
        log_uniform(1e4, 1e5), log_uniform(1e4, 1e5),    // k_x, k_y, N/m
        uniform(0.1e-3, 0.6e-3),                          // clearance, m
        uniform(0.0, 0.5),                                // mu
        uniform(0.0, 1.0),                                // r
        log_uniform(1e5, 1e8),                            // k1, N/m: 3 to 3000 times the shaft
        uniform(0.0, 1e13),                               // k3, N/m^3: k3 z^3 ~ k1 z at z ~ 0.1 mm
        uniform(0.0, 1e5));                               // c2, kg/m
  }
};

template <>
struct Arbitrary<rubref::props::throw_case> {
  static Gen<rubref::props::throw_case> arbitrary() {
    return gen::mapcat(gen::pair(gen::arbitrary<rubref::parameters>(), rubref::props::uniform(600.0, 3000.0)),
                       [](const std::pair<rubref::parameters, double>& pr) {
                         return gen::map(rubref::props::rising_start(pr.first, 1.05, 3.0, 0.1), [pr](const rubref::state_type& s) {
                           return rubref::props::throw_case{pr.first, pr.second, s};
                         });
                       });
  }
};

}  // namespace rc

namespace rubref {

// How RapidCheck prints a counterexample: every value at full precision.
inline void showValue(const parameters& p, std::ostream& os) {
  const auto precision = os.precision(17);
  os << "{";
  for (const auto& info : parameter_table) os << " " << info.key << ": " << p.*info.member;
  os << " }";
  os.precision(precision);
}

namespace props {
inline void showValue(const throw_case& c, std::ostream& os) {
  const auto precision = os.precision(17);
  os << "{ rpm: " << c.rpm << ", start (x, y, vx, vy): (" << c.start[0] << ", " << c.start[1] << ", " << c.start[2] << ", "
     << c.start[3] << "), parameters: ";
  rubref::showValue(c.p, os);
  os << " }";
  os.precision(precision);
}
}  // namespace props

}  // namespace rubref
