#pragma once
// Physical parameters of the rub rotor, SI units, with the paper's values as defaults
// (§3 for the rotor, Eq. 6 text for r, §4 and Table 2 for the contact law), from the settings
// registry.

#include <array>
#include <string>
#include <string_view>

#include "ref/model/settings.hpp"

namespace rubref {

// The defaults are the registry's (ref/model/settings.hpp): the paper's values.
struct parameters {
  double m = default_of("model", "m");                  // kg, rotor mass (§3)
  double e = default_of("model", "e");                  // m, mass eccentricity (§3)
  double unbalance_phase = default_of("model", "unbalance_phase");  // rad, from +x at t = 0 (Eq. 1 has 0)
  double c_x = default_of("model", "c_x");              // kg/s, damping in x (§3)
  double c_y = default_of("model", "c_y");              // kg/s, damping in y (§3)
  double k_x = default_of("model", "k_x");              // N/m, stiffness in x (§3)
  double k_y = default_of("model", "k_y");              // N/m, stiffness in y (§3)
  double clearance = default_of("model", "clearance");  // m, radial clearance delta to the protrusion at the top (§3)
  double mu = default_of("model", "mu");                // -, Coulomb friction coefficient, f_T = mu f_N (Eq. 2, Fig. 5)
  double r = default_of("model", "r");                  // -, coefficient of restitution (Eq. 6)
  double k1 = default_of("model", "k1");                // N/m, linear contact stiffness (Table 2)
  double k3 = default_of("model", "k3");                // N/m^3, cubic contact stiffness (Table 2)
  double c2 = default_of("model", "c2");                // kg/m, quadratic contact damping (Table 2)

  friend bool operator==(const parameters&, const parameters&) = default;
};

// Each member with its row of the registry: the CLI options, the parameter-file and record
// metadata keys, --help and validation all iterate over this. `key` carries the unit so a file
// is self-describing.
struct parameter_info {
  double parameters::*member;
  const setting_info* row;
  std::string_view flag;         // CLI option without dashes, e.g. "k1" -> --k1
  std::string_view key;          // file / metadata key, e.g. "k1_N_m"
  std::string_view unit;
  std::string_view description;
};

namespace detail {
consteval parameter_info parameter_row(double parameters::*member, std::string_view name) {
  const setting_info& s = setting_named("model", name);
  return {member, &s, s.flag, s.key, s.unit, s.description};
}
}  // namespace detail

inline constexpr std::array<parameter_info, 13> parameter_table{{
    detail::parameter_row(&parameters::m, "m"),
    detail::parameter_row(&parameters::e, "e"),
    detail::parameter_row(&parameters::unbalance_phase, "unbalance_phase"),
    detail::parameter_row(&parameters::c_x, "c_x"),
    detail::parameter_row(&parameters::c_y, "c_y"),
    detail::parameter_row(&parameters::k_x, "k_x"),
    detail::parameter_row(&parameters::k_y, "k_y"),
    detail::parameter_row(&parameters::clearance, "clearance"),
    detail::parameter_row(&parameters::mu, "mu"),
    detail::parameter_row(&parameters::r, "r"),
    detail::parameter_row(&parameters::k1, "k1"),
    detail::parameter_row(&parameters::k3, "k3"),
    detail::parameter_row(&parameters::c2, "c2"),
}};

// The member named `name` (the registry's name: "k1", "clearance"), or input_error naming the
// names there are: the one look-up by name of the model's parameters (re-identification, fits).
double parameters::*parameter_member(std::string_view name);

// Why `v` is not a valid value of the parameter ("parameter mu must be finite and >= 0 (got -1):
// friction opposes the sliding"), or empty if it is. Parameters are named by their file key,
// the spelling a parameter file, a record's header and --help share.
std::string violation(const parameter_info& info, double v);

// Throws input_error naming the first parameter that is non-finite or violates its range.
void validate(const parameters& p);

}  // namespace rubref
