#include "ref/format/table.hpp"

#include "ref/base/errors.hpp"

namespace rubref {

void write_metadata(std::string& out, const std::vector<std::pair<std::string, std::string>>& metadata) {
  for (const auto& [k, v] : metadata) {
    out += "# ";
    out += k;
    out += ": ";
    out += v;
    out += '\n';
  }
}

namespace {
void append_row(std::string& out, const std::vector<std::string>& cells) {
  for (std::size_t c = 0; c < cells.size(); ++c) {
    if (c) out += ',';
    out += cells[c];
  }
  out += '\n';
}
}  // namespace

std::string to_csv(const table& t) {
  std::string out;
  write_metadata(out, t.metadata);
  append_row(out, t.columns);
  for (const auto& row : t.rows) {
    if (row.size() != t.columns.size()) throw input_error("table row has " + std::to_string(row.size()) + " cells for " + std::to_string(t.columns.size()) + " columns");
    append_row(out, row);
  }
  return out;
}

}  // namespace rubref
