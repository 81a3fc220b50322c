#include "ref/orbits/periodic_orbit_io.hpp"

#include <cmath>
#include <string>

#include "ref/analysis/orbit_io.hpp"
#include "ref/analysis/orbit_summary.hpp"
#include "ref/base/version.hpp"

namespace rubref {

record periodic_orbit_record(const periodic_orbit_request& req, const periodic_orbit_result& r) {
  record rec = to_record(r.samples);
  rec.set("generator", "rubref " + std::string(version()) + " orbit");
  rec.set("method", r.method);
  rec.set("period_revs", static_cast<double>(req.periods));
  return rec;
}

nlohmann::ordered_json periodic_orbit_json(const periodic_orbit_request& req, const periodic_orbit_result& r) {
  nlohmann::ordered_json j = to_json(summarize(r.samples, summary_spectrum::one_x), r.samples);  // writes the 1X alone
  j["method"] = r.method;
  j["start"] = r.start;
  j["converged"] = r.converged;
  if (!r.converged) j["failure"] = r.failure;
  j["period_revs"] = req.periods;
  j["period_s"] = req.periods * 60.0 / req.run.rpm;
  j["newton_iterations"] = r.iterations;
  if (r.converged) {
    j["shooting_residual_m"] = r.residual;
    j["stable"] = r.stable;
    j["max_floquet_modulus"] = r.max_multiplier_modulus;
    nlohmann::ordered_json mults = nlohmann::ordered_json::array();
    for (const auto& m : r.multipliers) mults.push_back({{"re", m.real()}, {"im", m.imag()}, {"modulus", std::abs(m)}});
    j["floquet_multipliers"] = mults;
    j["events_per_period"] = r.events_per_period;
  }
  const state_type& s = r.samples.request.initial_state;
  j["initial_state"] = {s[0], s[1], s[2], s[3]};
  return j;
}

}  // namespace rubref
