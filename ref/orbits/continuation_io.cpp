#include "ref/orbits/continuation_io.hpp"

#include "ref/base/version.hpp"
#include "ref/format/record.hpp"
#include "ref/model/parameter_io.hpp"

namespace rubref {

namespace {
std::vector<std::pair<std::string, std::string>> branch_metadata(const continuation_request& req) {
  record meta;
  meta.set("generator", "rubref " + std::string(version()) + " continuation");
  meta.set("commit", std::string(commit()));
  meta.set("variant", req.variant);
  write_parameters(meta, req.params);
  meta.set("continuation_parameter", std::string(to_string(req.parameter)));
  meta.set("from", req.from);
  meta.set("to", req.to);
  meta.set("direction", std::string(req.downward ? "down" : "up"));
  if (req.parameter != continuation_parameter::speed) meta.set("speed_rpm", req.rpm);
  meta.set("period_revs", static_cast<double>(req.periods));
  meta.set("tolerance_m", req.tolerance);
  return meta.metadata;
}
}  // namespace

table branch_table(const continuation_request& req, const continuation_result& r) {
  table t;
  t.metadata = branch_metadata(req);
  if (req.parameter != continuation_parameter::speed) t.columns.emplace_back(column_name(req.parameter));
  for (const char* c : {"speed_rpm", "stable", "max_floquet_modulus", "period_revs", "forward_1x_m", "backward_1x_m", "max_radius_m",
                        "peak_to_peak_x_m", "peak_to_peak_y_m", "max_penetration_m", "max_z_m", "contacts_per_rev", "x0_m", "y0_m", "vx0_m_s", "vy0_m_s"})
    t.columns.emplace_back(c);
  for (const auto& p : r.points) {
    std::vector<std::string> row;
    if (req.parameter != continuation_parameter::speed) row.push_back(format_number_17(p.parameter));
    row.push_back(format_number_17(p.rpm));
    row.push_back(p.stable ? "1" : "0");
    row.push_back(format_number_17(p.max_floquet_modulus));
    row.push_back(std::to_string(req.periods));
    row.push_back(format_number_17(std::abs(p.summary.forward_1x)));
    row.push_back(format_number_17(std::abs(p.summary.backward_1x)));
    row.push_back(format_number_17(p.summary.max_radius));
    row.push_back(format_number_17(p.summary.peak_to_peak_x));
    row.push_back(format_number_17(p.summary.peak_to_peak_y));
    row.push_back(format_number_17(std::max(p.max_z, 0.0)));
    row.push_back(format_number_17(p.max_z));
    row.push_back(format_number_17(p.summary.contact_episodes_per_rev));
    for (const double v : p.state) row.push_back(format_number_17(v));
    t.rows.push_back(std::move(row));
  }
  return t;
}

nlohmann::ordered_json branch_summary_json(const continuation_request& req, const continuation_result& r) {
  nlohmann::ordered_json j;
  j["generator"] = "rubref " + std::string(version()) + " continuation";
  j["variant"] = req.variant;
  j["parameter"] = std::string(to_string(req.parameter));
  j["from"] = req.from;
  j["to"] = req.to;
  j["direction"] = req.downward ? "down" : "up";
  j["points"] = r.points.size();
  j["start"] = r.start;
  j["stopped"] = r.stopped;
  j["reached_end"] = r.reached_end;
  for (const auto kind : {special_kind::fold, special_kind::grazing, special_kind::period_doubling, special_kind::neimark_sacker}) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const auto& s : r.special) {
      if (s.kind != kind) continue;
      nlohmann::ordered_json e;
      e[std::string(column_name(req.parameter))] = s.parameter;
      if (req.parameter != continuation_parameter::speed) e["speed_rpm"] = s.rpm;
      e["located"] = s.located;
      e["after_point"] = s.after_point;
      e["state"] = {s.state[0], s.state[1], s.state[2], s.state[3]};
      list.push_back(e);
    }
    const std::string key = kind == special_kind::fold ? "folds"
                            : kind == special_kind::grazing ? "grazings"
                            : kind == special_kind::period_doubling ? "period_doublings"
                                                                    : "neimark_sacker";
    j[key] = list;
  }
  return j;
}

}  // namespace rubref
