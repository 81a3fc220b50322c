#pragma once
// rubref's one record format (docs/data-format.md), shared by every reader and writer:
//
//   # key: value              metadata, one per line, before anything else
//   t_s,x_m,y_m,speed_rpm[,extra columns]
//   <one row of numbers per sample>
//
// Numbers are written in the shortest form that reads back to the same double.

#include <array>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ref/base/number_text.hpp"

namespace rubref {

inline constexpr std::string_view kRecordFormat = "rubref-record 1";
inline constexpr std::array<std::string_view, 4> kRequiredColumns{"t_s", "x_m", "y_m", "speed_rpm"};

struct record {
  std::vector<std::pair<std::string, std::string>> metadata;  // in file order
  std::vector<std::string> columns;
  std::vector<std::vector<double>> data;  // data[c][row]
  // Where it was read from, for messages (parse_record fills them; empty/0 for a made record).
  std::string source;
  std::vector<std::size_t> metadata_lines;  // file line of each metadata entry
  std::size_t first_data_line = 0;          // file line of row 0

  // "<source>:<line>: " for metadata key `key` (or "<source>: " without a line; "" unread).
  std::string where(std::string_view key) const;
  // "<source>:<line>: " for data row `row`.
  std::string where_row(std::size_t row) const;

  std::size_t rows() const { return data.empty() ? 0 : data.front().size(); }
  const std::string* find(std::string_view key) const;
  double number(std::string_view key) const;                      // input_error if absent/bad, naming file and line
  const std::vector<double>& column(std::string_view name) const;  // input_error if absent, naming the file
  void set(std::string key, std::string value);
  void set(std::string key, double value);
  void add_column(std::string name, std::vector<double> values);
};

// How numbers in the rows are written: both read back to the identical double.
enum class number_format { shortest, significant_17 };

// Serialises a record; throws input_error if the columns are ragged or a required one is missing.
std::string to_csv(const record& r, number_format format = number_format::shortest);

// Parses a record; input_error "<source>:<line>: <problem>" on anything malformed.
record parse_record(std::string_view text, std::string_view source);
record read_record(const std::filesystem::path& path);

// The format's grammar without its columns' meaning: metadata, a header, rows of finite numbers
// (`format`: the only `# format:` value accepted; `header_example` is quoted when the header is
// missing). `header_problem` returns what is wrong with a header ("" when nothing); an
// order-tracked table (ref/format/order_table.hpp) is read by it too.
record parse_numeric_table(std::string_view text, std::string_view source, std::string_view format, std::string_view header_example,
                           const std::function<std::string(const std::vector<std::string>& columns)>& header_problem);
// A whole file as text; input_error naming the path when it cannot be read.
std::string read_text_file(const std::filesystem::path& path);

}  // namespace rubref
