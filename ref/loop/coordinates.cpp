#include "ref/loop/coordinates.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "ref/base/errors.hpp"

namespace rubref {

namespace {

using member = double effect_parameters::*;

const effect_parameter_info& parameter(const effect_info& e, std::string_view key) {
  for (const auto& q : e.parameters)
    if (q.key == key) return q;
  throw input_error("effect '" + std::string(e.name) + "' has no parameter '" + std::string(key) + "'");
}

// The parameter after `key` in the effect's table: an amplitude's phase.
const effect_parameter_info& phase_of(const effect_info& e, std::string_view key) {
  for (std::size_t i = 0; i + 1 < e.parameters.size(); ++i)
    if (e.parameters[i].key == key && e.parameters[i + 1].key.starts_with("phi")) return e.parameters[i + 1];
  throw input_error("effect '" + std::string(e.name) + "': '" + std::string(key) + "' has no phase after it");
}

// An amplitude a >= 0 at angle phi as (a cos phi, a sin phi): smooth through a = 0. Going
// through (a, phi) leaves ~1e-17 of a component set to zero; below 1e-12 of the scale it is 0.
std::vector<fit_coordinate> polar_pair(const std::string& name, member amp, member phase, double scale) {
  const auto flush = [scale](double a) { return a < 1e-12 * scale ? 0.0 : a; };
  return {{name + "_cos", scale, [=](const model_point& q) { return q.fx.*amp * std::cos(q.fx.*phase); },
           [=](model_point& q, double v) {
             const double s = q.fx.*amp * std::sin(q.fx.*phase);
             q.fx.*amp = flush(std::hypot(v, s));
             q.fx.*phase = std::atan2(s, v);
           }},
          {name + "_sin", scale, [=](const model_point& q) { return q.fx.*amp * std::sin(q.fx.*phase); },
           [=](model_point& q, double v) {
             const double c = q.fx.*amp * std::cos(q.fx.*phase);
             q.fx.*amp = flush(std::hypot(c, v));
             q.fx.*phase = std::atan2(v, c);
           }}};
}

// A stiffness as its compliance 1/k (0: rigid, and the fit is smooth there), with the dip search
// its ringing needs. At a rigid stator its derivative is a series spring that k1 absorbs, and the
// stator rings between impacts (m_s = 1 kg on 4e6 N/m: 318 Hz, damping ratio 0.025, ~15 % of it
// left when the rotor returns), so the residual along 1/k_s is a comb of dips a few % apart and
// ~2 % wide (docs/loop.md). Envelope: k_s from 1e6 to 3.3e7 N/m in factors of sqrt 2, the law
// (k1, c2, mu) refitted at each; k3 is left out (it goes to 0 in every fit of these orbits). Hops:
// a factor 1.45 either way covers the envelope's spacing with room, in steps of 0.5 % that land
// in every dip; they move the compliance with k1 keeping the law and stator's series stiffness,
// which the contacts pin.
fit_coordinate compliance(const std::string& name, member k, double scale) {
  fit_coordinate c{name, scale, [k](const model_point& q) { return q.fx.*k > 0.0 ? 1.0 / (q.fx.*k) : 0.0; },
                   [k](model_point& q, double v) { q.fx.*k = v > 0.0 ? 1.0 / v : 0.0; }};
  std::vector<double> envelope;
  for (double v = 3e-8; v < 1.01e-6; v *= std::numbers::sqrt2) envelope.push_back(v);
  c.search = fit_coordinate::dip_search{envelope,
                                         {"k1", "c2", "mu"},
                                         [k](model_point& q, double v) {
                                           const double old = q.fx.*k > 0.0 ? 1.0 / (q.fx.*k) : 0.0;
                                           const double law = 1.0 / q.p.k1 + old - v;  // 1 / k1 at the same series stiffness
                                           if (!(v > 0.0 && law > 0.0)) return false;
                                           q.fx.*k = 1.0 / v;
                                           q.p.k1 = 1.0 / law;
                                           return true;
                                         },
                                         1.45, 0.005};
  return c;
}

}  // namespace

std::vector<fit_coordinate> paper_coordinates() {
  // Quantities positive by nature are searched as log(value): a trial step can never make a
  // stiffness, damping or the unbalance negative. The scale is 1: u = log(value).
  const auto positive = [](std::string name, double parameters::*m) {
    return fit_coordinate{std::move(name), 1.0, [m](const model_point& q) { return std::log(std::max(q.p.*m, 1e-300)); },
                          [m](model_point& q, double u) { q.p.*m = std::exp(u); }};
  };
  // The contact's coefficients may vanish in a fit that lacks an effect, and a logarithm has no
  // way back from there: its gradient shrinks with the value (a preload record's fit left c2 at
  // 1e-97 kg/m with k3 at 1e15 N/m^3 in its place, a cross-coupling record's k1 at 1e-269 N/m).
  // They are searched as themselves, in units of Table 2's order, and bounded by 0 (a negative k3
  // lets the rotor run through the stator, where the law's forces explode).
  const auto vanishing = [](std::string name, double parameters::*m, double scale) {
    fit_coordinate c{std::move(name), scale, [m](const model_point& q) { return q.p.*m; }, [m](model_point& q, double v) { q.p.*m = std::max(v, 0.0); }};
    c.lower = 0.0;
    return c;
  };
  return {positive("c_x", &parameters::c_x),
          positive("c_y", &parameters::c_y),
          positive("k_x", &parameters::k_x),
          positive("k_y", &parameters::k_y),
          positive("e", &parameters::e),
          {"unbalance_phase", 1.0, [](const model_point& q) { return q.p.unbalance_phase; },
           [](model_point& q, double v) { q.p.unbalance_phase = v; }},
          vanishing("k1", &parameters::k1, 1e6),
          vanishing("k3", &parameters::k3, 1e11),
          vanishing("c2", &parameters::c2, 1e4),
          vanishing("mu", &parameters::mu, 0.1)};
}

std::vector<fit_coordinate> effect_coordinates(const effect_info& e) {
  std::vector<fit_coordinate> out;
  for (const auto& f : e.fit) {
    const effect_parameter_info& q = parameter(e, f.key);
    const member m = q.member;
    const std::string name = std::string(e.name) + "." + std::string(f.key);
    switch (f.form) {
      case fit_form::value: {
        fit_coordinate c{name, f.scale, [m](const model_point& p) { return p.fx.*m; }, [m](model_point& p, double v) { p.fx.*m = v; }};
        if (q.lo >= 0.0) c.lower = 0.0;  // a force term or stiffness that cannot be negative (k_h, lambda)
        if (!f.trials.empty()) c.trials = fit_coordinate::trial_grid{f.trials, c.set};
        out.push_back(std::move(c));
        break;
      }
      case fit_form::polar: {
        auto pair = polar_pair(name, m, phase_of(e, f.key).member, f.scale);
        out.insert(out.end(), pair.begin(), pair.end());
        break;
      }
      case fit_form::compliance:
        out.push_back(compliance(std::string(e.name) + ".1/" + std::string(f.key), m, f.scale));
        out.back().lower = 0.0;
        break;
      case fit_form::excess_over_mu:  // mu_s <= mu is off
        out.push_back({name + "-mu", f.scale, [m](const model_point& p) { return p.fx.*m > p.p.mu ? p.fx.*m - p.p.mu : 0.0; },
                       [m](model_point& p, double v) { p.fx.*m = v > 0.0 ? p.p.mu + v : 0.0; }});
        out.back().lower = 0.0;
        break;
    }
  }
  if (out.empty()) throw input_error("the loop has no coordinates for effect '" + std::string(e.name) + "'");
  return out;
}

std::vector<fit_coordinate>::const_iterator dip_searched(const std::vector<fit_coordinate>& ec) {
  return std::find_if(ec.begin(), ec.end(), [](const fit_coordinate& q) { return q.search.has_value(); });
}

}  // namespace rubref
