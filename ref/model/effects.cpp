#include "ref/model/effects.hpp"

#include <charconv>
#include <cmath>

#include "ref/base/errors.hpp"
#include "ref/format/record.hpp"

namespace rubref {

namespace {
using P = effect_parameters;
constexpr double kPi = 3.14159265358979323846;
}  // namespace

const std::vector<effect_info>& effect_library() {
  // Moderate levels, against the paper's rotor at 1450-1750 rpm (contact forces ~100 N at
  // z ~ 1e-5 m, 0.05-0.1 m/s; unbalance force m e w^2 ~ 3 N; orbits ~0.5 mm): each changes the
  // orbit by microns to tens of microns, well above 1 um probe noise, well below the orbit.
  // Documented levels span what a lab kit meets, from barely visible to strong, within what the
  // rig can integrate: a stator stiffer than ~7e6 N/m runs away under the identified law, and a
  // skew cross-coupling above ~c w_n = 2400 N/m destabilises the free rotor (docs/loop.md).
  static const std::vector<effect_info> library{
      {"hertz_contact", "f_N += k_h z^1.5 (z > 0)", "K. L. Johnson, Contact Mechanics, 1985, Sec. 4.2 (Hertz)", false,
       {{&P::hertz_k, "k_h", "N/m^1.5", true, 0.0, 3e8, 0.0, 1e10, 3e8, 1e10}},
       {{"k_h", fit_form::value, 1e8}}},
      {"hunt_crossley_damping", "f_N += lambda z^p z_dot (z > 0)",
       "K. H. Hunt, F. R. E. Crossley, Coefficient of restitution interpreted as damping in vibroimpact, J. Appl. Mech. 42 (1975)",
       false,
       // lambda's levels hold at the default p = 1.5 and, for another p, at the reference penetration
       // (power_reference_penetration: lambda z_ref^(p - 1.5)); its range spans every p in [1, 2].
       {{&P::hc_lambda, "lambda", "N s/m^(p+1)", true, 0.0, 5e9, 0.0, 1e14, 1e9, 2e10},
        {&P::hc_exponent, "p", "-", false, 1.5, 1.5, 1.0, 2.0, 1.0, 2.0}},
       {{"lambda", fit_form::power_coefficient, 1e9}, {"p", fit_form::power_exponent, 0.1, {}, 1.0, 2.0}}},
      {"contact_angle", "contact normal (sin theta, cos theta), friction along (cos theta, -sin theta)",
       "geometry: the protrusion not at the top (Fig. 1 has it at theta = 0)", false,
       {{&P::contact_angle, "theta", "rad", true, 0.0, 0.3, -0.8, 0.8, 0.05, 0.5, true}},
       {{"theta", fit_form::value, 0.1, {-0.75, -0.5, -0.25, 0.25, 0.5, 0.75}}}},
      {"preload", "constant force (F_x, F_y) on the rotor",
       "A. Muszynska, Rotordynamics, 2005, Ch. 3 (radial preload: gravity, misaligned bearings)", false,
       {{&P::preload_x, "F_x", "N", true, 0.0, 2.0, -20.0, 20.0, 0.5, 10.0, true}, {&P::preload_y, "F_y", "N", true, 0.0, -3.0, -20.0, 20.0, 0.5, 10.0, true}},
       {{"F_x", fit_form::value, 1.0}, {"F_y", fit_form::value, 1.0}}},
      {"misalignment_2x", "force F2 (cos(2wt + phi2), sin(2wt + phi2))",
       "A. Muszynska, Rotordynamics, 2005, Ch. 6 (misalignment: 2X)", false,
       {{&P::misalignment_force, "F2", "N", true, 0.0, 0.5, 0.0, 50.0, 0.1, 2.0},
        {&P::misalignment_phase, "phi2", "rad", false, 0.0, 0.7, -kPi, kPi}},
       {{"F2", fit_form::polar, 1.0}}},
      {"shaft_bow", "force (k_x b cos(wt + phi_b), k_y b sin(wt + phi_b))",
       "J. C. Nicholas, E. J. Gunter, P. E. Allaire, Effect of residual shaft bow on unbalance response, J. Eng. Ind. 98 (1976)",
       false,
       {{&P::bow, "b", "m", true, 0.0, 5e-5, 0.0, 5e-4, 5e-6, 1e-4}, {&P::bow_phase, "phi_b", "rad", false, 0.0, 1.0, -kPi, kPi}},
       {{"b", fit_form::polar, 1e-5}}},
      {"probe_runout", "probes add a1 cos(psi + phi1) + a2 cos(2 psi + phi2), psi = wt - probe angle (x 0, y 90 deg)",
       "API 670, Machinery Protection Systems (mechanical and electrical runout)", true,
       {{&P::runout_1x, "a1", "m", true, 0.0, 5e-6, 0.0, 1e-4, 1e-6, 2e-5},
        {&P::runout_1x_phase, "phi1", "rad", false, 0.0, 0.5, -kPi, kPi},
        {&P::runout_2x, "a2", "m", true, 0.0, 3e-6, 0.0, 1e-4, 1e-6, 1e-5},
        {&P::runout_2x_phase, "phi2", "rad", false, 0.0, 1.2, -kPi, kPi}},
       {{"a1", fit_form::polar, 1e-6}, {"a2", fit_form::polar, 1e-6}}},
      {"probe_misorientation", "probe axes turned by alpha from the model's x, y",
       "installation error of XY proximity probes (API 670)", true,
       {{&P::misorientation, "alpha", "rad", true, 0.0, 0.1, -0.5, 0.5, 0.02, 0.3, true}},
       {{"alpha", fit_form::value, 0.01, {-0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3}}}},
      {"stator_compliance", "protrusion of mass m_s on spring k_s and damper c_s along the normal",
       "H. F. Black, Interaction of a whirling rotor with a vibrating stator across a clearance annulus, J. Mech. Eng. Sci. 10 (1968)",
       false,
       {{&P::stator_k, "k_s", "N/m", true, 0.0, 4e6, 1e5, 1e9, 1.5e6, 7e6},
        {&P::stator_c, "c_s", "N s/m", false, 100.0, 100.0, 1.0, 1e4, 10.0, 1e3},
        {&P::stator_m, "m_s", "kg", false, 1.0, 1.0, 0.02, 50.0, 0.1, 5.0}},
       // Ring frequency sqrt(k_s/m_s) and damping ratio over what the documented k_s, c_s and m_s give:
       // 550-8400 rad/s, 0.001-1.3.
       {{"k_s", fit_form::compliance, 1e-7}, {"m_s", fit_form::ring_frequency, 1.0, {}, 500.0, 1e4},
        {"c_s", fit_form::damping_ratio, 1.0, {}, 1e-3, 1.5}}},
      {"velocity_dependent_friction", "mu(v) = mu + (mu_s - mu) exp(-v / v_c), v = R|w| - tangential rotor speed",
       "Stribeck-type falling friction; B. Armstrong-Helouvry et al., Automatica 30 (1994)", false,
       {{&P::mu_static, "mu_s", "-", true, 0.0, 0.6, 0.0, 2.0, 0.3, 1.0},
        {&P::slip_decay_speed, "v_c", "m/s", false, 0.5, 0.5, 0.01, 10.0, 0.05, 2.0},
        {&P::shaft_radius, "R", "m", false, 5e-3, 5e-3, 5e-4, 0.1, 2e-3, 2e-2}},
       {{"mu_s", fit_form::excess_over_mu, 0.1}, {"v_c", fit_form::logarithm, 1.0, {}, 0.05, 2.0},
        {"R", fit_form::logarithm, 1.0, {}, 2e-3, 2e-2}}},
      {"cross_coupling", "stiffness k_xy (x: -k_xy y), k_yx (y: -k_yx x)",
       "J. M. Vance, Rotordynamics of Turbomachinery, 1988, Ch. 6 (cross-coupled stiffness)", false,
       {{&P::k_xy, "k_xy", "N/m", true, 0.0, 1.5e3, -2e4, 2e4, 300.0, 2000.0, true}, {&P::k_yx, "k_yx", "N/m", true, 0.0, -1.5e3, -2e4, 2e4, 300.0, 2000.0, true}},
       {{"k_xy", fit_form::value, 1e3}, {"k_yx", fit_form::value, 1e3}}},
  };
  return library;
}

std::string_view to_string(fit_form f) {
  switch (f) {
    case fit_form::value: return "itself";
    case fit_form::polar: return "(a cos phi, a sin phi)";
    case fit_form::compliance: return "compliance 1/k";
    case fit_form::excess_over_mu: return "excess over mu";
    case fit_form::power_coefficient: return "lambda z_ref^(p - p0)";
    case fit_form::logarithm: return "log";
    case fit_form::power_exponent: return "itself, lambda z_ref^p kept";
    case fit_form::ring_frequency: return "log ring frequency sqrt(k/m) [rad/s]";
    case fit_form::damping_ratio: return "log damping ratio c/(2 sqrt(k m))";
  }
  return "?";
}

const effect_info& find_effect(std::string_view name) {
  std::string known;
  std::vector<std::string> names;
  for (const auto& e : effect_library()) {
    if (e.name == name) return e;
    known += (known.empty() ? "" : ", ") + std::string(e.name);
    names.emplace_back(e.name);
  }
  throw input_error("unknown effect '" + std::string(name) + "'" + did_you_mean(name, names) + " (known: " + known + ")");
}

bool has_effect(const effect_parameters& p, const effect_info& e) {
  for (const auto& q : e.parameters)
    if (q.is_switch && p.*q.member != q.off) return true;
  return false;
}

std::vector<double> effect_values(const effect_parameters& p, const effect_info& e) {
  std::vector<double> v;
  for (const auto& q : e.parameters) v.push_back(p.*q.member);
  return v;
}

void apply_effect(effect_parameters& p, std::string_view text) {
  const auto colon = text.find(':');
  const effect_info& e = find_effect(text.substr(0, colon));
  for (const auto& q : e.parameters) p.*q.member = q.moderate;
  if (colon == std::string_view::npos) return;
  std::string_view rest = text.substr(colon + 1);
  while (!rest.empty()) {
    const auto comma = std::min(rest.find(','), rest.size());
    const std::string_view item = rest.substr(0, comma);
    rest = comma < rest.size() ? rest.substr(comma + 1) : std::string_view{};
    const auto eq = item.find('=');
    if (eq == std::string_view::npos) throw input_error("effect '" + std::string(e.name) + "': expected key=value, got '" + std::string(item) + "'");
    const std::string_view key = item.substr(0, eq), value = item.substr(eq + 1);
    const effect_parameter_info* q = nullptr;
    for (const auto& candidate : e.parameters)
      if (candidate.key == key) q = &candidate;
    if (!q) {
      std::string keys;
      for (const auto& candidate : e.parameters) keys += (keys.empty() ? "" : ", ") + std::string(candidate.key);
      throw input_error("effect '" + std::string(e.name) + "' has no parameter '" + std::string(key) + "' (it has " + keys + ")");
    }
    double v = 0.0;
    const auto [ptr, ec] = std::from_chars(value.data(), value.data() + value.size(), v);
    if (ec != std::errc() || ptr != value.data() + value.size() || !std::isfinite(v))
      throw input_error("effect '" + std::string(e.name) + "': " + std::string(key) + " is not a finite number: '" + std::string(value) + "'");
    if (!(q->is_switch && v == q->off) && (v < q->lo || v > q->hi))
      throw input_error("effect '" + std::string(e.name) + "': " + std::string(key) + " = " + std::string(value) + " " + std::string(q->unit) +
                        " is outside [" + format_number(q->lo) + ", " + format_number(q->hi) + "]");
    p.*q->member = v;
  }
}

}  // namespace rubref
