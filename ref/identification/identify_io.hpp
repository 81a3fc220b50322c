#pragma once
// An identification's files (docs/identification.md, "Outputs"): identification.json and
// identification.md. `rubref identify`, `rubref reproduce` and the Python module write the same.

#include <nlohmann/json.hpp>
#include <string>

#include "ref/identification/identify.hpp"

namespace rubref {

nlohmann::ordered_json to_json(const identification& id, const identify_settings& s);
std::string to_markdown(const identification& id);

}  // namespace rubref
