// Sensitivities, monodromy and shooting for every variant's rotor model, with and without
// effects, compiled once here (declared `extern` in shooting.hpp).
#include "ref/integrate/shooting.hpp"

namespace rubref {

#define RUBREF_MODEL_SHOOTING(LAW) RUBREF_SHOOTING_INSTANCE(, rotor_system<LAW>)
#define RUBREF_EFFECTS_SHOOTING(LAW) RUBREF_SHOOTING_INSTANCE(, rotor_with_effects<LAW>)
RUBREF_FOR_EACH_VARIANT(RUBREF_MODEL_SHOOTING)
RUBREF_FOR_EACH_COMPLIANT_VARIANT(RUBREF_EFFECTS_SHOOTING)

}  // namespace rubref
