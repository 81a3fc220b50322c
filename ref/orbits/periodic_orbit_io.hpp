#pragma once
// A periodic orbit's files (docs/orbits.md, "Outputs"): one period as a record and its summary
// JSON (the orbit's summary, how it was found, its Floquet multipliers). `rubref orbit` and the
// Python module write the same.

#include <nlohmann/json.hpp>

#include "ref/format/record.hpp"
#include "ref/orbits/periodic_orbit.hpp"

namespace rubref {

record periodic_orbit_record(const periodic_orbit_request& req, const periodic_orbit_result& r);
nlohmann::ordered_json periodic_orbit_json(const periodic_orbit_request& req, const periodic_orbit_result& r);

}  // namespace rubref
