#pragma once
// The one list of contact variants. Generic code (CLI dispatch, record metadata) and every
// typed test iterate over it, so a new variant is one header plus one entry here.

#include <string>
#include <string_view>
#include <vector>

#include "ref/errors.hpp"
#include "variants/identified.hpp"
#include "variants/piecewise_linear.hpp"
#include "variants/piecewise_nonlinear.hpp"
#include "variants/restitution.hpp"

namespace rubref {

template <class... Ts>
struct type_list {};

using all_variants = type_list<restitution, piecewise_linear, piecewise_nonlinear, identified>;

namespace detail {
template <class... Vs>
std::vector<std::string> variant_name_list(type_list<Vs...>) {
  return {std::string(Vs::name)...};
}

template <class F, class... Vs>
void for_each_in(F&& f, type_list<Vs...>) {
  (f(Vs::from(parameters{})), ...);
}

template <class F, class V, class... Rest>
decltype(auto) visit_in(std::string_view name, F&& f, type_list<V, Rest...>) {
  if (V::name == name) return f.template operator()<V>();
  if constexpr (sizeof...(Rest) > 0) {
    return visit_in(name, f, type_list<Rest...>{});
  } else {
    throw input_error("unknown variant '" + std::string(name) + "'" + did_you_mean(name, variant_name_list(all_variants{})));
  }
}
}  // namespace detail

// Calls f(law) with every variant built from the paper's parameters, in list order.
template <class F>
void for_each_variant(F&& f) {
  detail::for_each_in(f, all_variants{});
}

// Returns f.template operator()<V>() for the variant V named `name`; input_error if none is.
template <class F>
decltype(auto) visit_variant(std::string_view name, F&& f) {
  return detail::visit_in(name, f, all_variants{});
}

}  // namespace rubref
