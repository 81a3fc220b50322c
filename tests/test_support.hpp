#pragma once
// Shared by the unit tests: the variant type list as gtest Types, and a recorder that keeps a
// whole hybrid trajectory (samples and events) for inspection.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "ref/integrate/hybrid_integrator.hpp"
#include "variants/all_variants.hpp"

namespace rubref::testing {

template <class>
struct as_gtest_types;
template <class... Ts>
struct as_gtest_types<type_list<Ts...>> {
  using type = ::testing::Types<Ts...>;
};
using all_variant_types = as_gtest_types<all_variants>::type;

// Typed-test names are the CLI names ("piecewise_linear"), not "0", "1", ...
struct variant_name {
  template <class V>
  static std::string GetName(int) {
    std::string n(V::name);
    for (char& c : n)
      if (c == '-') c = '_';
    return n;
  }
};

struct trajectory {
  hybrid_state end;
  std::vector<contact_event> events;
  std::vector<double> t;
  std::vector<state_type> s;
  std::vector<contact_phase> phase;

  template <class System>
  void on_sample(double time, const state_type& state, const System& sys) {
    t.push_back(time);
    s.push_back(state);
    phase.push_back(sys.phase());
  }
  void on_event(const contact_event& e) { events.push_back(e); }
};

template <class Law>
trajectory run(const rotor_system<Law>& model, const state_type& s0, double t_end, const integration_options& opt,
               const sample_grid& grid = {}) {
  trajectory out;
  out.end = integrate_hybrid(model, start_state(model, s0, 0.0), t_end, opt, grid, out);
  return out;
}

// The careful stepper every unit test compares against: rkf78 near the limit of double.
inline integration_options reference_options() {
  integration_options opt;
  opt.stepper.kind = stepper_kind::rkf78;
  opt.stepper.rtol = 1e-13;
  opt.stepper.atol = 1e-18;
  return opt;
}

inline integration_options options_for(stepper_kind kind, double rtol = 1e-10, double atol = 1e-15) {
  integration_options opt;
  opt.stepper.kind = kind;
  opt.stepper.rtol = rtol;
  opt.stepper.atol = atol;
  return opt;
}

}  // namespace rubref::testing
