#include "ref/format/record.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>

#include "ref/base/errors.hpp"
#include "ref/format/table.hpp"

namespace rubref {

namespace {

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r");
  return s.substr(first, last - first + 1);
}

bool parse_double(std::string_view s, double& out) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size() && !s.empty();
}

[[noreturn]] void fail(std::string_view source, std::size_t line, const std::string& what) {
  throw input_error(std::string(source) + ":" + std::to_string(line) + ": " + what);
}

}  // namespace

const std::string* record::find(std::string_view key) const {
  for (const auto& [k, v] : metadata)
    if (k == key) return &v;
  return nullptr;
}

std::string record::where(std::string_view key) const {
  if (source.empty()) return {};
  for (std::size_t i = 0; i < metadata.size() && i < metadata_lines.size(); ++i)
    if (metadata[i].first == key) return source + ":" + std::to_string(metadata_lines[i]) + ": ";
  return source + ": ";
}

std::string record::where_row(std::size_t row) const {
  if (source.empty()) return {};
  if (first_data_line == 0) return source + ": ";
  return source + ":" + std::to_string(first_data_line + row) + ": ";
}

double record::number(std::string_view key) const {
  const std::string* v = find(key);
  if (!v) throw input_error(where(key) + "no metadata key '" + std::string(key) + "'");
  double out = 0.0;
  if (!parse_double(*v, out)) throw input_error(where(key) + "metadata '" + std::string(key) + "' is not a number: '" + *v + "'");
  return out;
}

const std::vector<double>& record::column(std::string_view name) const {
  for (std::size_t c = 0; c < columns.size(); ++c)
    if (columns[c] == name) return data[c];
  throw input_error(where({}) + "no column '" + std::string(name) + "'");
}

void record::set(std::string key, std::string value) {
  for (auto& [k, v] : metadata)
    if (k == key) {
      v = std::move(value);
      return;
    }
  metadata.emplace_back(std::move(key), std::move(value));
}

void record::set(std::string key, double value) { set(std::move(key), format_number(value)); }

void record::add_column(std::string name, std::vector<double> values) {
  columns.push_back(std::move(name));
  data.push_back(std::move(values));
}

std::string to_csv(const record& r, number_format format) {
  const auto number = format == number_format::shortest ? format_number : format_number_17;
  for (std::size_t i = 0; i < kRequiredColumns.size(); ++i)
    if (r.columns.size() <= i || r.columns[i] != kRequiredColumns[i])
      throw input_error("record columns must start with t_s,x_m,y_m,speed_rpm");
  const std::size_t n = r.rows();
  for (const auto& col : r.data)
    if (col.size() != n) throw input_error("record columns have different lengths");

  std::string out;
  out.reserve(64 * (n + r.metadata.size() + 2) * std::max<std::size_t>(1, r.columns.size() / 2));
  std::vector<std::pair<std::string, std::string>> meta{{"format", std::string(kRecordFormat)}};
  for (const auto& kv : r.metadata)
    if (kv.first != "format") meta.push_back(kv);
  write_metadata(out, meta);
  for (std::size_t c = 0; c < r.columns.size(); ++c) {
    if (c) out += ',';
    out += r.columns[c];
  }
  out += '\n';
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t c = 0; c < r.columns.size(); ++c) {
      if (c) out += ',';
      out += number(r.data[c][i]);
    }
    out += '\n';
  }
  return out;
}

namespace {
// What a header that does not start with t_s,x_m,y_m,speed_rpm most likely is, in the words a
// user of a spreadsheet or pandas would recognise; "" when nothing specific fits.
std::string explain_header(std::string_view line) {
  const auto has = [&](std::string_view s) { return line.find(s) != std::string_view::npos; };
  if (has(";") && !has(","))
    return "columns are separated by ';' (a spreadsheet's export for decimal commas?): rubref reads ',' between columns and "
           "'.' as the decimal point";
  if (has("\t") && !has(",")) return "columns are separated by tabs: rubref reads ',' between columns";
  if (has("\"") || has("'")) return "column names are quoted: write them bare, e.g. t_s,x_m,y_m,speed_rpm";
  const std::string_view first = trim(line.substr(0, std::min(line.find(','), line.size())));
  if (first.empty() || first == "index" || first == "Unnamed: 0" || first == "i" || first == "n")
    if (has(",t_s,x_m,y_m,speed_rpm") || has(", t_s"))
      return "the first column ('" + std::string(first) + "') looks like a row index: write the file without it (pandas: to_csv(index=False))";
  if (double v = 0.0; parse_double(first, v)) return "the first line holds numbers, not column names: the header line is missing";
  return {};
}

// A header as found, for a message: its columns joined by ',', cut after the last whole column
// within 60 characters (a rig's export can have dozens).
std::string quoted_header(const std::vector<std::string>& columns) {
  constexpr std::size_t kShown = 60;
  std::string h;
  for (const auto& c : columns) {
    const std::string next = (h.empty() ? "" : ",") + c;
    if (h.size() + next.size() > kShown) {
      h += h.empty() ? c.substr(0, kShown) + "..." : ",...";
      break;
    }
    h += next;
  }
  return "'" + h + "'";
}

// What to change in a record's header that does not start with t_s,x_m,y_m,speed_rpm (""
// when nothing more specific than the rule applies): a required column out of place, a required
// quantity in another unit (the names carry the unit, and rubref reads SI), or a misspelt name.
// Nothing when the whole header is a spreadsheet's or pandas' habit (explain_header says which).
std::string record_header_hint(const std::vector<std::string>& columns) {
  std::string line;
  for (const auto& c : columns) line += (line.empty() ? "" : ",") + c;
  if (!explain_header(line).empty()) return {};
  const std::vector<std::string> required(kRequiredColumns.begin(), kRequiredColumns.end());
  // Units a rig's export uses for the four quantities, and how to convert each to rubref's.
  struct other_unit {
    std::string_view quantity, unit, conversion;
  };
  static constexpr std::array<other_unit, 11> others{{{"t", "ms", "divide by 1000"},
                                                      {"t", "us", "divide by 1e6"},
                                                      {"x", "mm", "divide by 1000"},
                                                      {"x", "um", "divide by 1e6"},
                                                      {"x", "mil", "multiply by 2.54e-5"},
                                                      {"y", "mm", "divide by 1000"},
                                                      {"y", "um", "divide by 1e6"},
                                                      {"y", "mil", "multiply by 2.54e-5"},
                                                      {"speed", "hz", "multiply by 60"},
                                                      {"speed", "rps", "multiply by 60"},
                                                      {"speed", "rad_s", "multiply by 30/pi"}}};
  for (std::size_t i = 0; i < required.size() && i < columns.size(); ++i) {
    const std::string& want = required[i];
    const std::string& got = columns[i];
    if (got == want) continue;
    const auto at = std::find(columns.begin(), columns.end(), want);
    if (at != columns.end())
      return "'" + want + "' is column " + std::to_string(at - columns.begin() + 1) + ", not " + std::to_string(i + 1);
    const std::string_view quantity = std::string_view(want).substr(0, want.find('_'));
    std::string lowered = got;
    for (char& c : lowered) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    for (const auto& o : others)
      if (o.quantity == quantity && lowered == std::string(quantity) + "_" + std::string(o.unit))
        return "column '" + got + "' is in " + got.substr(quantity.size() + 1) + ": rubref reads " + want + " in " + want.substr(want.find('_') + 1) +
               " (" + std::string(o.conversion) + ")";
  }
  // The quantities' everyday names, which lack the unit rubref's names carry.
  static constexpr std::array<std::pair<std::string_view, std::string_view>, 7> plain{
      {{"t", "t_s"}, {"time", "t_s"}, {"time_s", "t_s"}, {"x", "x_m"}, {"y", "y_m"}, {"rpm", "speed_rpm"}, {"speed", "speed_rpm"}}};
  std::string renames;
  for (std::size_t i = 0; i < required.size() && i < columns.size(); ++i) {
    std::string lowered = columns[i];
    for (char& c : lowered) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    for (const auto& [name, is] : plain)
      if (lowered == name && is == required[i]) renames += (renames.empty() ? "" : ", ") + columns[i] + " to " + required[i];
  }
  if (!renames.empty()) return "if the values are in these units, rename " + renames;
  for (std::size_t i = 0; i < required.size() && i < columns.size(); ++i)
    if (columns[i] != required[i])
      if (const std::string hint = did_you_mean(columns[i], required); !hint.empty())
        return "column " + std::to_string(i + 1) + " is '" + columns[i] + "'" + hint;
  if (columns.size() > 1 && columns.size() < required.size()) return "it has " + std::to_string(columns.size()) + " columns";
  return {};
}
}  // namespace

record parse_numeric_table(std::string_view text, std::string_view source, std::string_view format, std::string_view header_example,
                           const std::function<std::string(const std::vector<std::string>& columns)>& header_problem) {
  if (text.substr(0, 3) == "\xEF\xBB\xBF")
    fail(source, 1, "the file starts with a UTF-8 byte-order mark (BOM): save it as UTF-8 without BOM");
  record r;
  r.source = std::string(source);
  std::size_t line_no = 0;
  std::size_t& first_data_line = r.first_data_line;
  bool header_seen = false;
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.find('\0') != std::string_view::npos) fail(source, line_no, "NUL byte in text");

    if (!header_seen) {
      if (trim(line).empty()) continue;
      if (line.front() == '#') {
        const std::string_view body = trim(line.substr(1));
        const auto colon = body.find(':');
        if (colon == std::string_view::npos || trim(body.substr(0, colon)).empty())
          fail(source, line_no, "metadata line is not '# key: value'");
        std::string key(trim(body.substr(0, colon)));
        std::string value(trim(body.substr(colon + 1)));
        if (r.find(key)) fail(source, line_no, "metadata key '" + key + "' given twice");
        if (key == "format" && value != format)
          fail(source, line_no, "unsupported format '" + value + "' (this reader knows '" + std::string(format) + "')");
        r.metadata.emplace_back(std::move(key), std::move(value));
        r.metadata_lines.push_back(line_no);
        continue;
      }
      // The column header.
      std::size_t cpos = 0;
      while (true) {
        const std::size_t comma = std::min(line.find(',', cpos), line.size());
        const std::string name(trim(line.substr(cpos, comma - cpos)));
        if (name.empty()) {
          const std::string why = explain_header(line);
          fail(source, line_no, "empty column name in header" + (why.empty() ? "" : ": " + why));
        }
        if (std::find(r.columns.begin(), r.columns.end(), name) != r.columns.end()) {
          const std::string why = explain_header(line);  // a first line of numbers repeats some
          fail(source, line_no, "column '" + name + "' appears twice" + (why.empty() ? "" : ": " + why));
        }
        r.columns.push_back(name);
        if (comma >= line.size()) break;
        cpos = comma + 1;
      }
      if (const std::string problem = header_problem(r.columns); !problem.empty()) {
        const std::string why = explain_header(line);
        fail(source, line_no, problem + (why.empty() ? "" : ": " + why));
      }
      r.data.assign(r.columns.size(), {});
      header_seen = true;
      continue;
    }

    if (trim(line).empty()) {
      if (pos >= text.size()) break;  // a final newline
      fail(source, line_no, "empty line inside the data");
    }
    if (line.front() == '#') fail(source, line_no, "metadata after the column header");
    if (first_data_line == 0) first_data_line = line_no;
    std::size_t cpos = 0;
    for (std::size_t c = 0; c < r.columns.size(); ++c) {
      const std::size_t comma = std::min(line.find(',', cpos), line.size());
      if (cpos > line.size()) fail(source, line_no, "expected " + std::to_string(r.columns.size()) + " values, got " + std::to_string(c));
      double v = 0.0;
      if (!parse_double(line.substr(cpos, comma - cpos), v) || !std::isfinite(v))
        fail(source, line_no, "column '" + r.columns[c] + "': not a finite number: '" +
                                  std::string(trim(line.substr(cpos, std::min<std::size_t>(comma - cpos, 40)))) + "'");
      r.data[c].push_back(v);
      cpos = comma + 1;
    }
    if (cpos <= line.size()) {
      // A row with up to twice the columns' values and no '.' at all: numbers written with decimal
      // commas (a European spreadsheet's CSV) split in two.
      const std::size_t values = static_cast<std::size_t>(std::count(line.begin(), line.end(), ',')) + 1;
      const bool decimal_commas = values <= 2 * r.columns.size() && line.find('.') == std::string_view::npos;
      fail(source, line_no, "more than " + std::to_string(r.columns.size()) + " values" +
                                (decimal_commas ? ": decimal commas? rubref reads '.' as the decimal point and ',' between columns" : ""));
    }
  }
  if (!header_seen) fail(source, line_no, "no column header (" + std::string(header_example) + ")");
  if (r.rows() == 0) fail(source, line_no, "no data rows");
  return r;
}

record parse_record(std::string_view text, std::string_view source) {
  record r = parse_numeric_table(text, source, kRecordFormat, "t_s,x_m,y_m,speed_rpm,...", [](const std::vector<std::string>& columns) {
    for (std::size_t i = 0; i < kRequiredColumns.size(); ++i)
      if (columns.size() <= i || columns[i] != kRequiredColumns[i]) {
        const std::string hint = record_header_hint(columns);
        return "header " + quoted_header(columns) + " must start with t_s,x_m,y_m,speed_rpm (units s, m, m, rpm)" +
               (hint.empty() ? "" : ": " + hint);
      }
    return std::string();
  });
  const auto& t = r.data[0];
  for (std::size_t i = 1; i < t.size(); ++i)
    if (!(t[i] > t[i - 1])) fail(source, r.first_data_line + i, "t_s is not strictly increasing");
  return r;
}

std::string read_text_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw input_error(path.string() + ": cannot open for reading");
  std::ostringstream buf;
  buf << in.rdbuf();
  if (in.bad()) throw input_error(path.string() + ": read error");
  return buf.str();
}

record read_record(const std::filesystem::path& path) { return parse_record(read_text_file(path), path.string()); }

}  // namespace rubref
