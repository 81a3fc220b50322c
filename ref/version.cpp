#include "ref/version.hpp"

namespace rubref {
std::string_view version() { return RUBREF_VERSION; }
std::string_view commit() { return RUBREF_COMMIT; }
}  // namespace rubref
