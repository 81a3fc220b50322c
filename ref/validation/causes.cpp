#include "ref/validation/causes.hpp"

namespace rubref {

std::string_view to_string(cause_code c) {
  for (const auto& info : cause_table)
    if (info.code == c) return info.name;
  return "?";
}

std::string_view to_string(cause_confidence c) { return c == cause_confidence::confirmed ? "confirmed" : "likely"; }

nlohmann::ordered_json to_json(const cause& c) {
  return {{"code", to_string(c.code)}, {"confidence", to_string(c.confidence)}, {"detail", c.detail}, {"fitted", c.fitted}};
}

}  // namespace rubref
