#include "ref/model/parameter_io.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"

namespace rubref {

nlohmann::ordered_json to_json(const parameters& p) {
  nlohmann::ordered_json j;
  for (const auto& info : parameter_table) j[std::string(info.key)] = p.*info.member;
  return j;
}

namespace {

// The line of the first `"key"` in the text, for messages about a key (0: not found).
std::size_t line_of_key(std::string_view text, const std::string& key) {
  const std::size_t at = text.find('"' + key + '"');
  if (at == std::string_view::npos) return 0;
  return 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

void apply_json(parameters& p, const nlohmann::json& j, std::string_view source, std::string_view text) {
  const std::string src(source);
  if (!j.is_object()) throw input_error(src + ": expected a JSON object of parameters");
  for (const auto& item : j.items()) {
    const std::string& key = item.key();
    const auto& value = item.value();
    const std::size_t line = line_of_key(text, key);
    const std::string at = src + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": ";
    const auto* info = std::find_if(parameter_table.begin(), parameter_table.end(),
                                    [&](const parameter_info& i) { return i.key == key; });
    if (info == parameter_table.end()) {
      std::vector<std::string> keys;
      for (const auto& i : parameter_table) keys.emplace_back(i.key);
      throw input_error(at + "unknown parameter '" + key + "'" + did_you_mean(key, keys));
    }
    if (!value.is_number()) throw input_error(at + "parameter '" + key + "' is not a number");
    // A file's value must be valid on its own (a later option may not rescue it): said here,
    // where the file and line are known.
    if (const std::string why = violation(*info, value.get<double>()); !why.empty()) throw input_error(at + why);
    p.*info->member = value.get<double>();
  }
}

}  // namespace

void apply_json(parameters& p, const nlohmann::json& j, std::string_view source) { apply_json(p, j, source, {}); }

std::vector<std::string> unit_warnings(const parameters& p) {
  std::vector<std::string> out;
  for (const auto& [value, key] : {std::pair{p.clearance, "clearance_m"}, std::pair{p.e, "e_m"}})
    if (value >= kImplausibleLength)
      out.push_back(std::string(key) + " = " + format_digits(value) + " m is larger than any rotor kit's; if millimetres were meant, " +
                    format_digits(value) + " mm is " + format_digits(value * 1e-3) + " m");
  return out;
}

void apply_parameter_text(parameters& p, std::string_view text, std::string_view source) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    // e.what() is one line: "[json.exception.parse_error.101] parse error at line 1, column 2: ..."
    throw input_error(std::string(source) + ": " + e.what());
  }
  apply_json(p, j, source, text);
}

void apply_parameter_file(parameters& p, const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw input_error(path.string() + ": cannot open parameter file");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw input_error(path.string() + ": read error");
  apply_parameter_text(p, text.str(), path.string());
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
