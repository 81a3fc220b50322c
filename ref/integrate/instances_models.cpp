// The integrator for every variant's rotor model, with and without effects, compiled once here
// (declared `extern` in hybrid_integrator.hpp).
#include "ref/integrate/hybrid_integrator.hpp"

namespace rubref {

#define RUBREF_MODEL_INTEGRATOR(LAW) RUBREF_INTEGRATOR_INSTANCE(, rotor_system<LAW>)
#define RUBREF_EFFECTS_INTEGRATOR(LAW) RUBREF_INTEGRATOR_INSTANCE(, rotor_with_effects<LAW>)
RUBREF_FOR_EACH_VARIANT(RUBREF_MODEL_INTEGRATOR)
RUBREF_FOR_EACH_COMPLIANT_VARIANT(RUBREF_EFFECTS_INTEGRATOR)

}  // namespace rubref
