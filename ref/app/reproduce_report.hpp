#pragma once
// report.md of `rubref reproduce`, written from its numbers (reproduce.json) alone, so every
// number the report states is one the run produced and a reader can find in that file.

#include <nlohmann/json.hpp>
#include <string>

namespace rubref {

std::string report_markdown(const nlohmann::ordered_json& numbers);


}  // namespace rubref
