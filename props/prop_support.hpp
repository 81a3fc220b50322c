#pragma once
// Shared by the property tests: the integration they use and iteration over the variant list.

#include <cmath>
#include <numbers>

#include "tests/test_support.hpp"

namespace rubref::props {

// rkf78 at rtol 1e-12: a state good to ~1e-12 of its scale, which every property tolerance is
// measured against, at a third of the cost of the unit tests' reference_options (rtol 1e-13).
inline integration_options careful() {
  integration_options opt = testing::reference_options();
  opt.stepper.rtol = 1e-12;
  opt.stepper.atol = 1e-17;
  return opt;
}

// The free vertical period 2 pi sqrt(m / k_y), s: a thrown rotor meets the stator within half.
inline double vertical_period(const parameters& p) { return 2.0 * std::numbers::pi * std::sqrt(p.m / p.k_y); }

// f.template operator()<V>() for every variant V of the one list, in order.
template <class F, class... Vs>
void for_each_variant_type(F&& f, type_list<Vs...>) {
  (f.template operator()<Vs>(), ...);
}
template <class F>
void for_each_variant_type(F&& f) {
  for_each_variant_type(f, all_variants{});
}

// The same for the compliant laws only (those with a normal force).
template <class F>
void for_each_compliant(F&& f) {
  for_each_variant_type([&]<class V>() {
    if constexpr (compliant_law<V>) f.template operator()<V>();
  });
}

}  // namespace rubref::props
