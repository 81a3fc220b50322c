#include "ref/loop/coordinates.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string_view>

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

// A compliant part (the stator) in the chart where its orbit depends on it most simply: the
// compliance 1/k (0: rigid, and the fit is smooth there; at a rigid stator its derivative is a
// series spring that k1 absorbs), the ring frequency w = sqrt(k/m) and the damping ratio
// zeta = c / (2 sqrt(k m)). Setting one keeps the other two, so that a Jacobian column moves one
// alone, unless that takes m or c out of the library's range (they are held at its end: records
// that cannot tell an overdamped stator's damper from a heavier one drove c_s to 1e4). Where the part is rigid (k = 0) the shapes are read with the library's moderate
// stiffness, so the chart is continuous as the part turns on.
struct compliant_part {
  member k, m, c;
  double k_ref;
  double m_lo, m_hi, c_lo, c_hi;  // the library's fit ranges: a chart move is projected onto them
  double stiffness(const model_point& q) const { return q.fx.*k > 0.0 ? q.fx.*k : k_ref; }
  double ring(const model_point& q) const { return std::sqrt(stiffness(q) / q.fx.*m); }
  double ratio(const model_point& q) const { return q.fx.*c / (2.0 * std::sqrt(stiffness(q) * q.fx.*m)); }
  void place(model_point& q, double k_new, double w, double zeta) const {
    q.fx.*k = k_new;
    const double ks = stiffness(q);
    q.fx.*m = std::clamp(ks / (w * w), m_lo, m_hi);
    q.fx.*c = std::clamp(2.0 * zeta * std::sqrt(ks * q.fx.*m), c_lo, c_hi);
  }
};

compliant_part part_of(const effect_info& e) {
  const effect_parameter_info* k = nullptr;
  const effect_parameter_info *m = nullptr, *c = nullptr;
  for (const auto& f : e.fit) {
    if (f.form == fit_form::compliance) k = &parameter(e, f.key);
    if (f.form == fit_form::ring_frequency) m = &parameter(e, f.key);
    if (f.form == fit_form::damping_ratio) c = &parameter(e, f.key);
  }
  if (!k || !m || !c)
    throw input_error("effect '" + std::string(e.name) + "': a compliance, its ring frequency and its damping ratio come together");
  return {k->member, m->member, c->member, k->moderate, m->lo, m->hi, c->lo, c->hi};
}

// Ring frequency steps of the dip search: the stator's dips are ~1 % wide in w (docs/loop.md), so
// steps of 0.25 % land in each; hops scan a factor 1.2 either way, which covers the envelope's
// spacing (a factor sqrt 2) with room.
constexpr double kRingStep = 0.0025;
constexpr double kRingHopFactor = 1.2;

// A power law's coefficient lambda of z^p at the penetrations contacts reach: lambda and p are
// fitted as lambda_ref = lambda z_ref^(p - p0) and p, so that moving p keeps the force at z_ref.
// z_ref is the chart's pivot, not a model setting: any value gives the same optimum, one near the
// penetrations reached gives a well-conditioned fit.
struct power_law {
  member lambda, p;
  double p0;
  double reference(const model_point& q) const { return q.fx.*lambda * std::pow(power_reference_penetration, q.fx.*p - p0); }
};

power_law power_of(const effect_info& e) {
  const effect_parameter_info *l = nullptr, *p = nullptr;
  for (const auto& f : e.fit) {
    if (f.form == fit_form::power_coefficient) l = &parameter(e, f.key);
    if (f.form == fit_form::power_exponent) p = &parameter(e, f.key);
  }
  if (!l || !p) throw input_error("effect '" + std::string(e.name) + "': a power coefficient and its exponent come together");
  return {l->member, p->member, p->off};
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
  bool shapes_started = false;
  for (const auto& f : e.fit) {
    const effect_parameter_info& q = parameter(e, f.key);
    const member m = q.member;
    const std::string name = std::string(e.name) + "." + std::string(f.key);
    const std::size_t first = out.size();
    switch (f.form) {
      case fit_form::value: {
        fit_coordinate c{name, f.scale, [m](const model_point& p) { return p.fx.*m; }, [m](model_point& p, double v) { p.fx.*m = v; }};
        if (q.lo >= 0.0) c.lower = 0.0;  // a force term or stiffness that cannot be negative (k_h)
        if (!f.trials.empty()) c.trials = fit_coordinate::trial_grid{f.trials, c.set};
        out.push_back(std::move(c));
        break;
      }
      case fit_form::polar: {
        auto pair = polar_pair(name, m, phase_of(e, f.key).member, f.scale);
        out.insert(out.end(), pair.begin(), pair.end());
        break;
      }
      case fit_form::compliance: {
        const compliant_part part = part_of(e);
        out.push_back({std::string(e.name) + ".1/" + std::string(f.key), f.scale,
                       [part](const model_point& p) { return p.fx.*part.k > 0.0 ? 1.0 / (p.fx.*part.k) : 0.0; },
                       [part](model_point& p, double v) { part.place(p, v > 0.0 ? 1.0 / v : 0.0, part.ring(p), part.ratio(p)); }});
        out.back().lower = 0.0;
        break;
      }
      case fit_form::excess_over_mu:  // mu_s <= mu is off
        out.push_back({name + "-mu", f.scale, [m](const model_point& p) { return p.fx.*m > p.p.mu ? p.fx.*m - p.p.mu : 0.0; },
                       [m](model_point& p, double v) { p.fx.*m = v > 0.0 ? p.p.mu + v : 0.0; }});
        out.back().lower = 0.0;
        break;
      case fit_form::power_coefficient: {
        const power_law law = power_of(e);
        out.push_back({name + "@z_ref", f.scale, [law](const model_point& p) { return law.reference(p); },
                       [law](model_point& p, double v) { p.fx.*law.lambda = v * std::pow(power_reference_penetration, law.p0 - p.fx.*law.p); }});
        out.back().lower = 0.0;
        break;
      }
      case fit_form::logarithm:
        out.push_back({"log " + name, f.scale, [m](const model_point& p) { return std::log(p.fx.*m); },
                       [m](model_point& p, double u) { p.fx.*m = std::exp(u); }});
        out.back().lower = std::log(q.lo), out.back().upper = std::log(q.hi);
        out.back().logarithmic = true;
        break;
      case fit_form::power_exponent: {
        const power_law law = power_of(e);
        out.push_back({name, f.scale, [m](const model_point& p) { return p.fx.*m; },
                       [law](model_point& p, double v) {
                         const double at_reference = law.reference(p);
                         p.fx.*law.p = v;
                         p.fx.*law.lambda = at_reference * std::pow(power_reference_penetration, law.p0 - v);
                       }});
        out.back().lower = q.lo, out.back().upper = q.hi;
        break;
      }
      case fit_form::ring_frequency: {
        const compliant_part part = part_of(e);
        fit_coordinate c{"log " + std::string(e.name) + ".ring_frequency", f.scale, [part](const model_point& p) { return std::log(part.ring(p)); },
                         [part](model_point& p, double u) { part.place(p, p.fx.*part.k, std::exp(u), part.ratio(p)); }};
        c.logarithmic = true;
        // Bounds: the mass's fit range at the stiffest and the softest stator the fit allows.
        const effect_parameter_info& k = parameter(e, e.fit.front().key);
        c.lower = 0.5 * std::log(k.lo / q.hi), c.upper = 0.5 * std::log(k.hi / q.lo);
        std::vector<double> envelope;
        for (double w = f.range_lo; w < f.range_hi * 1.01; w *= std::numbers::sqrt2) envelope.push_back(std::log(w));
        const std::string compliance_name = std::string(e.name) + ".1/" + std::string(k.key);
        std::string ratio_name;
        for (const auto& g : e.fit)
          if (g.form == fit_form::damping_ratio) ratio_name = "log " + std::string(e.name) + ".damping_ratio";
        c.search = fit_coordinate::dip_search{envelope,
                                               ratio_name,
                                               {std::log(0.02), std::log(0.3)},
                                               {compliance_name, ratio_name, "k1", "c2", "mu"},
                                               // On at the moderate stiffness, with k1 moved to keep the law and
                                               // stator's series stiffness, which the contacts pin (a stator
                                               // stiffer than the law where the law is the stiffer one).
                                               [part](model_point& p) {
                                                 if (p.fx.*part.k > 0.0) return;
                                                 const double law = 1.0 / p.p.k1 - 1.0 / part.k_ref;
                                                 const double ks = law > 0.0 ? part.k_ref : 2.0 * p.p.k1;
                                                 p.p.k1 = law > 0.0 ? 1.0 / law : 2.0 * p.p.k1;
                                                 part.place(p, ks, part.ring(p), part.ratio(p));
                                               },
                                               kRingHopFactor, kRingStep};
        out.push_back(std::move(c));
        break;
      }
      case fit_form::damping_ratio: {
        const compliant_part part = part_of(e);
        out.push_back({"log " + std::string(e.name) + ".damping_ratio", f.scale, [part](const model_point& p) { return std::log(part.ratio(p)); },
                       [part](model_point& p, double u) { part.place(p, p.fx.*part.k, part.ring(p), std::exp(u)); }});
        out.back().logarithmic = true;
        out.back().lower = std::log(1e-4), out.back().upper = std::log(10.0);  // from nearly undamped to far past critical
        break;
      }
    }
    if (f.is_shape()) {
      shapes_started = true;
      for (std::size_t i = first; i < out.size(); ++i) {
        out[i].shape = true;
        out[i].range_lo = f.range_lo, out[i].range_hi = f.range_hi;
        out[i].quantity = std::string(f.key), out[i].unit = std::string(q.unit);
        if (f.form == fit_form::ring_frequency) {
          out[i].quantity = "sqrt(" + std::string(e.fit.front().key) + "/" + std::string(f.key) + ")", out[i].unit = "rad/s";
        } else if (f.form == fit_form::damping_ratio) {
          out[i].quantity = "damping ratio " + std::string(f.key) + "/(2 sqrt(k m))", out[i].unit = "-";
        }
      }
    } else if (shapes_started) {
      throw input_error("effect '" + std::string(e.name) + "': its switches come before its shapes in the fit list");
    }
  }
  if (out.empty()) throw input_error("the loop has no coordinates for effect '" + std::string(e.name) + "'");
  for (auto& c : out) c.effect = std::string(e.name);
  return out;
}

std::size_t switch_count(const std::vector<fit_coordinate>& ec) {
  return static_cast<std::size_t>(std::find_if(ec.begin(), ec.end(), [](const fit_coordinate& q) { return q.shape; }) - ec.begin());
}

std::vector<fit_coordinate>::const_iterator dip_searched(const std::vector<fit_coordinate>& ec) {
  return std::find_if(ec.begin(), ec.end(), [](const fit_coordinate& q) { return q.search.has_value(); });
}

}  // namespace rubref
