#include "ref/analysis/orbit_io.hpp"

#include <numbers>

#include "ref/base/version.hpp"
#include "ref/model/parameter_io.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

void orbit_columns::append(std::span<const orbit_sample> samples, double speed_rpm, double time_shift) {
  for (const auto& smp : samples) {
    t.push_back(smp.t + time_shift);
    x.push_back(smp.s[idx::x]);
    y.push_back(smp.s[idx::y]);
    rpm.push_back(speed_rpm);
    vx.push_back(smp.s[idx::vx]);
    vy.push_back(smp.s[idx::vy]);
    fn.push_back(smp.fn);
  }
}

void orbit_columns::move_into(record& r) {
  r.add_column("t_s", std::move(t));
  r.add_column("x_m", std::move(x));
  r.add_column("y_m", std::move(y));
  r.add_column("speed_rpm", std::move(rpm));
  r.add_column("vx_m_s", std::move(vx));
  r.add_column("vy_m_s", std::move(vy));
  r.add_column("fn_N", std::move(fn));
}

record to_record(const orbit& o) {
  const auto& req = o.request;
  const double period = 60.0 / req.rpm;
  const stepper_settings steps = with_default_steps(req.integration.stepper, period);
  record r;
  r.set("generator", "rubref " + std::string(version()) + " simulate");
  r.set("commit", std::string(commit()));
  r.set("variant", req.variant);
  r.set("contact_law", std::string(visit_variant(req.variant, []<class V>() { return V::equation; })));
  write_parameters(r, req.params);
  r.set("speed_rpm", req.rpm);
  r.set("samples_per_rev", static_cast<double>(req.samples_per_rev));
  r.set("sample_rate_hz", req.samples_per_rev / period);
  r.set("settle_revs", static_cast<double>(req.settle_revs));
  r.set("record_revs", static_cast<double>(req.record_revs));
  r.set("initial_state", format_number(req.initial_state[0]) + " " + format_number(req.initial_state[1]) + " " +
                             format_number(req.initial_state[2]) + " " + format_number(req.initial_state[3]));
  r.set("stepper", std::string(to_string(steps.kind)));
  if (steps.kind == stepper_kind::rk4) {
    r.set("dt_s", steps.dt);
  } else {
    r.set("rtol", steps.rtol);
    r.set("atol", steps.atol);
    r.set("max_dt_s", steps.max_dt);
  }
  r.set("event_time_tolerance_s", req.integration.events.time_tolerance);
  r.set("stick_time_revs", req.integration.events.stick_time);

  orbit_columns cols;
  cols.append(o.samples, req.rpm);
  cols.move_into(r);
  return r;
}

nlohmann::ordered_json to_json(const orbit_summary& s, const orbit& o) {
  nlohmann::ordered_json j;
  j["generator"] = "rubref " + std::string(version());
  j["variant"] = o.request.variant;
  j["speed_rpm"] = o.request.rpm;
  j["clearance_m"] = o.request.params.clearance;
  j["record_revs"] = o.request.record_revs;
  j["peak_to_peak_x_m"] = s.peak_to_peak_x;
  j["peak_to_peak_y_m"] = s.peak_to_peak_y;
  j["max_radius_m"] = s.max_radius;
  j["max_penetration_m"] = s.max_penetration;
  j["max_normal_force_N"] = s.max_normal_force;
  j["contact_episodes_per_rev"] = s.contact_episodes_per_rev;
  j["contact_fraction"] = s.contact_fraction;
  j["regime"] = to_string(s.regime);
  j["forward_1x_m"] = std::abs(s.forward_1x);
  j["backward_1x_m"] = std::abs(s.backward_1x);
  j["forward_1x_phase_rad"] = std::arg(s.forward_1x);
  j["backward_1x_phase_rad"] = std::arg(s.backward_1x);
  j["whirl"] = s.backward_whirl() ? "backward" : "forward";
  j["steps"] = o.counts.steps;
  j["events"] = o.counts.events;
  if (o.request.integration.stepper.kind == stepper_kind::rk4) {  // the fixed step's contact resolution
    j["max_contact_rate_dt"] = o.counts.max_contact_rate_dt;
    j["coarse_contact_steps"] = o.counts.coarse_contact_steps;
  }
  return j;
}

}  // namespace rubref
