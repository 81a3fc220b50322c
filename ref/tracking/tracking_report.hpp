#pragma once
// The report of `rubref loop` on an order-tracked table (docs/real-data.md): report.json,
// report.md, and the data of its figures (scripts/plot_tracking.py).

#include <nlohmann/json.hpp>
#include <string>

#include "ref/tracking/tracking_loop.hpp"

namespace rubref {

nlohmann::ordered_json to_json(const tracking_result& r);
std::string to_markdown(const tracking_result& r);
nlohmann::ordered_json plot_data(const tracking_result& r);

}  // namespace rubref
