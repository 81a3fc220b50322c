#include "ref/orbits/fit_orbits.hpp"

namespace rubref {

void fit_orbit_options::validate() const {
  check({"fit_orbits", "max_iterations"}, max_iterations);
  check({"fit_orbits", "max_steps_per_revolution"}, max_steps_per_revolution);
  check({"", "tolerance"}, tolerance);
  check({"fit_orbits", "tolerance_scale"}, tolerance_scale);
}

shooting_settings fit_shooting(int periods, const fit_orbit_options& o) {
  o.validate();
  shooting_settings set;
  set.max_iterations = o.max_iterations;
  set.tolerance = o.tolerance * o.tolerance_scale;
  set.integration.stepper.rtol *= o.tolerance_scale;
  set.integration.stepper.atol *= o.tolerance_scale;
  set.integration.max_steps = static_cast<std::size_t>(o.max_steps_per_revolution) * static_cast<std::size_t>(std::max(periods, 1));
  return set;
}

integration_options fit_sampling(int revolutions, const fit_orbit_options& o) {
  o.validate();
  integration_options opt;  // the registry's rtol and atol
  opt.stepper.rtol *= o.tolerance_scale;
  opt.stepper.atol *= o.tolerance_scale;
  opt.max_steps = static_cast<std::size_t>(o.max_steps_per_revolution) * static_cast<std::size_t>(std::max(revolutions, 1));
  return opt;
}

integration_options fit_settling(int revolutions, const fit_orbit_options& o) {
  integration_options opt = fit_sampling(revolutions, o);
  opt.stepper.rtol *= kSettleLoosening;
  opt.stepper.atol *= kSettleLoosening;
  return opt;
}

}  // namespace rubref
