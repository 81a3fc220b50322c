#pragma once
// The loop's report (docs/loop.md, step 6): report.json, report.md, and the data of its figures.

#include <nlohmann/json.hpp>
#include <string>

#include "ref/loop/loop.hpp"

namespace rubref {

nlohmann::ordered_json to_json(const loop_result& r);
std::string to_markdown(const loop_result& r);
// Data for scripts/plot_loop.py.
nlohmann::ordered_json plot_data(const loop_result& r);

}  // namespace rubref
