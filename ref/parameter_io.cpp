#include "ref/parameter_io.hpp"

#include <fstream>

#include "ref/errors.hpp"

namespace rubref {

nlohmann::ordered_json to_json(const parameters& p) {
  nlohmann::ordered_json j;
  for (const auto& info : parameter_table) j[std::string(info.key)] = p.*info.member;
  return j;
}

void apply_json(parameters& p, const nlohmann::json& j, std::string_view source) {
  const std::string src(source);
  if (!j.is_object()) throw input_error(src + ": expected a JSON object of parameters");
  for (const auto& [key, value] : j.items()) {
    const auto* info = std::find_if(parameter_table.begin(), parameter_table.end(),
                                    [&](const parameter_info& i) { return i.key == key; });
    if (info == parameter_table.end()) throw input_error(src + ": unknown parameter '" + key + "'");
    if (!value.is_number()) throw input_error(src + ": parameter '" + key + "' is not a number");
    p.*info->member = value.get<double>();
  }
}

void apply_parameter_file(parameters& p, const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw input_error(path.string() + ": cannot open parameter file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    // e.what() is one line: "[json.exception.parse_error.101] parse error at line 1, column 2: ..."
    throw input_error(path.string() + ": " + e.what());
  }
  apply_json(p, j, path.string());
}

void write_parameters(record& r, const parameters& p) {
  for (const auto& info : parameter_table) r.set(std::string(info.key), p.*info.member);
}

parameters read_parameters(const record& r) {
  parameters p;
  for (const auto& info : parameter_table)
    if (r.find(info.key)) p.*info.member = r.number(info.key);
  return p;
}

}  // namespace rubref
