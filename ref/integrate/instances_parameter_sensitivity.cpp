// The paper's rotor models' flows with a parameter column (continuation's dP/dlambda), compiled once
// here (declared `extern` in shooting.hpp); a file of their own, so that they build beside
// instances_shooting.cpp.
#include "ref/integrate/shooting.hpp"

namespace rubref {

#define RUBREF_MODEL_PARAMETER_SENSITIVITY(LAW) RUBREF_PARAMETER_SENSITIVITY_INSTANCE(, rotor_system<LAW>)
RUBREF_FOR_EACH_VARIANT(RUBREF_MODEL_PARAMETER_SENSITIVITY)

}  // namespace rubref
