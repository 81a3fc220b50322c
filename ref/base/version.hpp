#pragma once
#include <string_view>

namespace rubref {
std::string_view version();  // project version, e.g. "0.1.0"
std::string_view commit();   // git commit at configure time, or "unknown"
}  // namespace rubref
