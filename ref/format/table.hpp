#pragma once
// Result tables (sweeps, waterfalls): the record format's `# key: value` metadata and a CSV
// header, but free columns, text allowed (docs/data-format.md, "Tables").

#include <string>
#include <utility>
#include <vector>

namespace rubref {

struct table {
  std::vector<std::pair<std::string, std::string>> metadata;
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> rows;
};

// Appends "# key: value" lines to `out`.
void write_metadata(std::string& out, const std::vector<std::pair<std::string, std::string>>& metadata);

std::string to_csv(const table& t);  // input_error on a row of the wrong width

}  // namespace rubref
