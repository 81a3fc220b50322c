#pragma once
// Parameters in and out of files. Keys are parameter_table's `key`s (with units), the same in a
// JSON parameter file and in a record's metadata, so either can configure a run.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>
#include <nlohmann/json.hpp>

#include "ref/format/record.hpp"
#include "ref/model/parameters.hpp"

namespace rubref {

nlohmann::ordered_json to_json(const parameters& p);

// Overrides the parameters named in a JSON object; unknown keys and non-numbers are input_errors.
void apply_json(parameters& p, const nlohmann::json& j, std::string_view source);
// A JSON parameter file's text; input_error "<source>[:<line>]: <problem>".
void apply_parameter_text(parameters& p, std::string_view text, std::string_view source);
void apply_parameter_file(parameters& p, const std::filesystem::path& path);

// Lengths are in metres: a clearance or unbalance of centimetres or more is no rotor kit's and
// most likely millimetres typed as metres. It still runs (a large clearance means no contact), so
// each front end says it as a warning: the command line on stderr, Python as warnings.warn.
inline constexpr double kImplausibleLength = 0.01;  // m
// One line per such length ("clearance_m = 0.3 m is larger than any rotor kit's; ..."), else none.
std::vector<std::string> unit_warnings(const parameters& p);

// Every parameter into / out of a record's metadata.
void write_parameters(record& r, const parameters& p);
parameters read_parameters(const record& r);  // missing keys keep the paper's defaults

}  // namespace rubref
