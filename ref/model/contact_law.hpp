#pragma once
// The ContactLaw concept (docs/concepts.md). A contact variant is either
//  - compliant: a normal force f_N(z, z_dot) acting while the penetration z = y - delta > 0
//    (Eq. 2), with Coulomb friction f_T = mu f_N added by the rotor system; or
//  - an impact law: no force, but a velocity map applied at y = delta (Eq. 6).
// Each variant is a small value type built from `parameters` by `from`, so a generic test can
// construct it, and names itself for the CLI and the record metadata.

#include <array>
#include <concepts>
#include <string_view>

#include "ref/model/parameters.hpp"

namespace rubref {

template <class L>
concept named_law = requires(const parameters& p) {
  { L::name } -> std::convertible_to<std::string_view>;       // CLI name, e.g. "identified"
  { L::equation } -> std::convertible_to<std::string_view>;   // one line for --help and docs
  { L::from(p) } -> std::same_as<L>;
};

template <class L>
concept compliant_law = named_law<L> && requires(const L law, double z, double z_dot) {
  { law.normal_force(z, z_dot) } noexcept -> std::same_as<double>;  // N, for z > 0
  // (df_N/dz, df_N/dz_dot): the monodromy's variational equations (ref/integrate/shooting.hpp)
  { law.normal_force_gradient(z, z_dot) } noexcept -> std::same_as<std::array<double, 2>>;
};

template <class L>
concept impact_law = named_law<L> && requires(const L law, double v_normal) {
  { law.rebound_velocity(v_normal) } noexcept -> std::same_as<double>;  // m/s
  { law.rebound_slope(v_normal) } noexcept -> std::same_as<double>;      // d rebound / d v_normal
};

template <class L>
concept contact_variant = compliant_law<L> || impact_law<L>;

}  // namespace rubref
