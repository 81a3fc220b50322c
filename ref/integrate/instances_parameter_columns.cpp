// The fits' flows of a periodic orbit's parameter columns (ref/integrate/parameter_columns.hpp) for
// every compliant variant's model with effects, compiled once here (declared `extern` there).
#include "ref/integrate/parameter_columns.hpp"

namespace rubref {

#define RUBREF_FIT_PARAMETER_COLUMNS(LAW) RUBREF_PARAMETER_COLUMNS_INSTANCE(, LAW)
RUBREF_FOR_EACH_COMPLIANT_VARIANT(RUBREF_FIT_PARAMETER_COLUMNS)

}  // namespace rubref
