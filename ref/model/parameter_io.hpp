#pragma once
// Parameters in and out of files. Keys are parameter_table's `key`s (with units), the same in a
// JSON parameter file and in a record's metadata, so either can configure a run.

#include <filesystem>
#include <string_view>
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

// Every parameter into / out of a record's metadata.
void write_parameters(record& r, const parameters& p);
parameters read_parameters(const record& r);  // missing keys keep the paper's defaults

}  // namespace rubref
