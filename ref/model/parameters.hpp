#pragma once
// Physical parameters of the rub rotor, SI units, with the paper's values as defaults
// (§3 for the rotor, Eq. 6 text for r, §4 and Table 2 for the contact law).

#include <array>
#include <string>
#include <string_view>

namespace rubref {

struct parameters {
  double m = 1.52;          // kg, rotor mass (§3)
  double e = 0.0706e-3;     // m, mass eccentricity (§3)
  double unbalance_phase = 0.0;  // rad, angle of the unbalance from +x at t = 0 (Eq. 1 has 0)
  double c_x = 15.100;      // kg/s, damping in x (§3)
  double c_y = 14.727;      // kg/s, damping in y (§3)
  double k_x = 38.521e3;    // N/m, stiffness in x (§3)
  double k_y = 41.017e3;    // N/m, stiffness in y (§3)
  double delta = 0.3e-3;    // m, radial clearance to the protrusion at the top (§3)
  double mu = 0.24;         // -, Coulomb friction coefficient, f_T = mu f_N (Eq. 2, Fig. 5)
  double r = 0.86;          // -, coefficient of restitution (Eq. 6)
  double k1 = 3.946e6;      // N/m, linear contact stiffness (Table 2)
  double k3 = 1.408e11;     // N/m^3, cubic contact stiffness (Table 2)
  double c2 = 3.720e4;      // kg/m, quadratic contact damping (Table 2)

  friend bool operator==(const parameters&, const parameters&) = default;
};

// What a parameter must satisfy to be physically meaningful and numerically safe.
enum class constraint { positive, non_negative, unit_interval, finite };

// One row per parameter: the single source for the CLI options, the parameter-file and record
// metadata keys, --help, and validation. `key` carries the unit so a file is self-describing.
struct parameter_info {
  double parameters::*member;
  std::string_view flag;         // CLI option without dashes, e.g. "k1" -> --k1
  std::string_view key;          // file / metadata key, e.g. "k1_N_m"
  std::string_view unit;
  std::string_view description;
  constraint rule;
};

inline constexpr std::array<parameter_info, 13> parameter_table{{
    {&parameters::m, "m", "m_kg", "kg", "rotor mass", constraint::positive},
    {&parameters::e, "e", "e_m", "m", "mass eccentricity (unbalance me omega^2)", constraint::non_negative},
    {&parameters::unbalance_phase, "unbalance-phase", "unbalance_phase_rad", "rad",
     "angle of the unbalance from +x at t = 0: forcing m e omega^2 (cos(omega t + phase), sin(omega t + phase))", constraint::finite},
    {&parameters::c_x, "c-x", "c_x_kg_s", "kg/s", "damping, horizontal", constraint::non_negative},
    {&parameters::c_y, "c-y", "c_y_kg_s", "kg/s", "damping, vertical", constraint::non_negative},
    {&parameters::k_x, "k-x", "k_x_N_m", "N/m", "stiffness, horizontal", constraint::positive},
    {&parameters::k_y, "k-y", "k_y_N_m", "N/m", "stiffness, vertical", constraint::positive},
    {&parameters::delta, "clearance", "clearance_m", "m", "radial clearance delta to the protrusion at the top", constraint::positive},
    {&parameters::mu, "mu", "mu", "-", "Coulomb friction coefficient f_T = mu f_N", constraint::non_negative},
    {&parameters::r, "r", "r", "-", "coefficient of restitution (restitution variant)", constraint::unit_interval},
    {&parameters::k1, "k1", "k1_N_m", "N/m", "linear contact stiffness", constraint::positive},
    {&parameters::k3, "k3", "k3_N_m3", "N/m^3", "cubic contact stiffness", constraint::non_negative},
    {&parameters::c2, "c2", "c2_kg_m", "kg/m", "quadratic contact damping (c2 zdot^2)", constraint::non_negative},
}};

// Why `v` is not a valid value of the parameter ("parameter mu must be finite and >= 0 (got -1)"),
// or empty if it is.
std::string violation(const parameter_info& info, double v);

// Throws input_error naming the first parameter that is non-finite or violates its constraint.
void validate(const parameters& p);

// The rule as words, for --help and error messages ("> 0", ">= 0", "in [0, 1]", "any real").
std::string_view describe(constraint rule);

}  // namespace rubref
