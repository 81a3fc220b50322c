#pragma once
// A continuation's files (docs/orbits.md, "Outputs"): branch.csv, one row per point with its
// stability and the state that restarts it, and summary.json with the special points.

#include <nlohmann/json.hpp>

#include "ref/format/table.hpp"
#include "ref/orbits/continuation.hpp"

namespace rubref {

table branch_table(const continuation_request& req, const continuation_result& r);
nlohmann::ordered_json branch_summary_json(const continuation_request& req, const continuation_result& r);

}  // namespace rubref
