#pragma once
// The one list of contact variants. Generic code (CLI dispatch, record metadata) and every
// typed test iterate over it, so a new variant is one header plus its entry here (in both lists
// below if it is a force law).

#include <string>
#include <string_view>
#include <vector>

#include "ref/base/errors.hpp"
#include "variants/identified.hpp"
#include "variants/piecewise_linear.hpp"
#include "variants/piecewise_nonlinear.hpp"
#include "variants/restitution.hpp"

namespace rubref {

template <class... Ts>
struct type_list {};

// X(type) for every variant, and for the compliant ones (a force law, not an impact map): the
// explicit instances of the integrator and the shooting (ref/integrate/instances_*.cpp) follow
// these. `all_variants` is made from the first; the second is checked against it below.
#define RUBREF_FOR_EACH_VARIANT(X) X(restitution) X(piecewise_linear) X(piecewise_nonlinear) X(identified)
#define RUBREF_FOR_EACH_COMPLIANT_VARIANT(X) X(piecewise_linear) X(piecewise_nonlinear) X(identified)

namespace detail {
template <class T, class... Ts>
type_list<Ts...> drop_first(type_list<T, Ts...>);
template <class... Ts>
constexpr int count_compliant(type_list<Ts...>) {
  return (0 + ... + (compliant_law<Ts> ? 1 : 0));
}
}  // namespace detail

#define RUBREF_DETAIL_COMMA_TYPE(T) , T
using all_variants = decltype(detail::drop_first(type_list<void RUBREF_FOR_EACH_VARIANT(RUBREF_DETAIL_COMMA_TYPE)>{}));
#define RUBREF_DETAIL_ASSERT_COMPLIANT(T) static_assert(compliant_law<T>, #T " is in RUBREF_FOR_EACH_COMPLIANT_VARIANT but not compliant");
RUBREF_FOR_EACH_COMPLIANT_VARIANT(RUBREF_DETAIL_ASSERT_COMPLIANT)
#define RUBREF_DETAIL_ONE(T) +1
static_assert(detail::count_compliant(all_variants{}) == 0 RUBREF_FOR_EACH_COMPLIANT_VARIANT(RUBREF_DETAIL_ONE),
              "every compliant variant belongs in RUBREF_FOR_EACH_COMPLIANT_VARIANT");
#undef RUBREF_DETAIL_COMMA_TYPE
#undef RUBREF_DETAIL_ASSERT_COMPLIANT
#undef RUBREF_DETAIL_ONE

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

// The variants' names, in list order.
inline std::vector<std::string> variant_name_list() { return detail::variant_name_list(all_variants{}); }

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
