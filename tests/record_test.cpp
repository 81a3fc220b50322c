// The record format (docs/data-format.md): exact round trip, and a precise one-line error for
// every kind of malformed file.

#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "ref/analysis/orbit_io.hpp"
#include "ref/base/errors.hpp"
#include "ref/format/record.hpp"
#include "ref/model/parameter_io.hpp"
#include "ref/run/simulate.hpp"

namespace rubref {
namespace {

TEST(record, simulated_orbit_round_trips_bit_for_bit) {
  run_request req;
  req.settle_revs = 5;
  req.record_revs = 2;
  req.samples_per_rev = 32;
  const record written = to_record(simulate(req));
  const record read = parse_record(to_csv(written), "memory");
  ASSERT_EQ(read.columns, written.columns);
  for (std::size_t c = 0; c < read.columns.size(); ++c) {
    ASSERT_EQ(read.data[c].size(), written.data[c].size());
    for (std::size_t i = 0; i < read.data[c].size(); ++i)
      ASSERT_EQ(std::memcmp(&read.data[c][i], &written.data[c][i], sizeof(double)), 0) << read.columns[c] << " row " << i;
  }
  EXPECT_EQ(read_parameters(read), req.params);
  EXPECT_EQ(read.number("speed_rpm"), req.rpm);
  EXPECT_EQ(*read.find("variant"), req.variant);
  EXPECT_EQ(*read.find("format"), kRecordFormat);
}

TEST(record, shortest_round_trip_numbers) {
  for (const double v : {0.1, 1.0 / 3.0, -2.5e-300, 6.02214076e23, 5e-324}) {
    double back = 0;
    const std::string s = format_number(v);
    std::sscanf(s.c_str(), "%lf", &back);
    EXPECT_EQ(back, v) << s;
  }
}

// Golden files write 17 significant digits: every double reads back to itself, and the digits
// are all there even when fewer would do.
TEST(record, seventeen_digit_numbers_round_trip) {
  for (const double v : {0.1, 1.0 / 3.0, -2.5e-300, 6.02214076e23, 1600.0, 0.0}) {
    double back = 1;
    const std::string s = format_number_17(v);
    std::sscanf(s.c_str(), "%lf", &back);
    EXPECT_EQ(back, v) << s;
    EXPECT_EQ(s.substr(0, s.find('e')).size(), (v < 0 ? 1u : 0u) + 18u) << s;  // d.dddddddddddddddd
  }
  EXPECT_EQ(format_number_17(0.1), "1.0000000000000001e-01");
  record r;
  r.add_column("t_s", {7.5});
  r.add_column("x_m", {0.1});
  r.add_column("y_m", {0.0});
  r.add_column("speed_rpm", {1600.0});
  const record back = parse_record(to_csv(r, number_format::significant_17), "memory");
  EXPECT_EQ(back.column("x_m")[0], 0.1);
}

TEST(record, accepts_crlf_and_plain_measurement_files) {
  const record r = parse_record("# clearance_m: 3e-4\r\nt_s,x_m,y_m,speed_rpm\r\n0,1e-4,2e-4,1600\r\n1e-4,1.1e-4,2.1e-4,1600\r\n", "m.csv");
  EXPECT_EQ(r.rows(), 2u);
  EXPECT_EQ(r.number("clearance_m"), 3e-4);
  EXPECT_EQ(r.column("y_m")[1], 2.1e-4);
}

struct malformed {
  const char* name;
  const char* text;
  const char* expected;  // the error must contain this (file:line: problem)
};

class record_errors : public ::testing::TestWithParam<malformed> {};

TEST_P(record_errors, name_file_line_and_problem) {
  const auto& c = GetParam();
  try {
    parse_record(c.text, "bad.csv");
    FAIL() << "accepted: " << c.text;
  } catch (const input_error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(c.expected), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "not one line: " << msg;
  }
}

INSTANTIATE_TEST_SUITE_P(
    record, record_errors,
    ::testing::Values(
        malformed{"empty", "", "bad.csv:0: no column header"},
        malformed{"only_metadata", "# a: 1\n", "bad.csv:1: no column header"},
        malformed{"no_data", "t_s,x_m,y_m,speed_rpm\n", "bad.csv:1: no data rows"},
        // A header not rubref's is quoted, with what it must be and, where it tells, what to change.
        malformed{"wrong_columns", "time,x,y,rpm\n0,0,0,0\n",
                  "bad.csv:1: header 'time,x,y,rpm' must start with t_s,x_m,y_m,speed_rpm (units s, m, m, rpm): if the values are in these units, "
                  "rename time to t_s, x to x_m, y to y_m, rpm to speed_rpm"},
        malformed{"unknown_columns", "a,b,c,d\n0,0,0,0\n", "bad.csv:1: header 'a,b,c,d' must start with t_s,x_m,y_m,speed_rpm (units s, m, m, rpm)"},
        malformed{"misspelt_column", "t_s,x_m,y_n,speed_rpm\n0,0,0,0\n", "must start with t_s,x_m,y_m,speed_rpm (units s, m, m, rpm): column 3 is 'y_n'; did you mean 'y_m'?"},
        malformed{"millimetre_columns", "t_s,x_mm,y_mm,speed_rpm\n0,0,0,0\n", "column 'x_mm' is in mm: rubref reads x_m in m (divide by 1000)"},
        malformed{"hertz_column", "t_s,x_m,y_m,speed_Hz\n0,0,0,0\n", "column 'speed_Hz' is in Hz: rubref reads speed_rpm in rpm (multiply by 60)"},
        malformed{"columns_reordered", "x_m,y_m,t_s,speed_rpm\n0,0,0,0\n", "header 'x_m,y_m,t_s,speed_rpm' must start with t_s,x_m,y_m,speed_rpm (units s, m, m, rpm): 't_s' is column 3, not 1"},
        malformed{"too_few_columns", "t_s,x_m,y_m\n0,0,0\n", "header 't_s,x_m,y_m' must start with t_s,x_m,y_m,speed_rpm (units s, m, m, rpm): it has 3 columns"},
        malformed{"long_header_cut", "Time [s],Probe X [um],Probe Y [um],Speed [rpm],Keyphasor [V],Probe X gap [V],Probe Y gap [V]\n0,0,0,0,0,0,0\n",
                  "header 'Time [s],Probe X [um],Probe Y [um],Speed [rpm],Keyphasor [V],...' must start"},
        malformed{"no_header", "0,0.1,0.2,1500\n1,0.1,0.2,1500\n", "bad.csv:1: header '0,0.1,0.2,1500' must start with t_s,x_m,y_m,speed_rpm (units s, m, m, rpm): the first line holds numbers, not column names: the header line is missing"},
        malformed{"no_header_repeated_value", "0,0,0,1500\n1,0,0,1500\n", "bad.csv:1: column '0' appears twice: the first line holds numbers, not column names"},
        malformed{"duplicate_column", "t_s,x_m,y_m,speed_rpm,x_m\n", "bad.csv:1: column 'x_m' appears twice"},
        malformed{"bad_metadata", "# no colon here\nt_s,x_m,y_m,speed_rpm\n0,0,0,0\n", "bad.csv:1: metadata line"},
        malformed{"duplicate_key", "# a: 1\n# a: 2\n", "bad.csv:2: metadata key 'a' given twice"},
        malformed{"future_format", "# format: rubref-record 9\n", "bad.csv:1: unsupported format"},
        malformed{"not_a_number", "t_s,x_m,y_m,speed_rpm\n0,abc,0,0\n", "bad.csv:2: column 'x_m': not a finite number"},
        malformed{"nan", "t_s,x_m,y_m,speed_rpm\n0,nan,0,0\n", "bad.csv:2: column 'x_m': not a finite number"},
        malformed{"inf", "t_s,x_m,y_m,speed_rpm\n0,0,inf,0\n", "bad.csv:2: column 'y_m': not a finite number"},
        malformed{"too_few", "t_s,x_m,y_m,speed_rpm\n0,0,0\n", "bad.csv:2: expected 4 values, got 3"},
        malformed{"too_many", "t_s,x_m,y_m,speed_rpm\n0,0,0,0,0\n", "bad.csv:2: more than 4 values"},
        malformed{"empty_field", "t_s,x_m,y_m,speed_rpm\n0,,0,0\n", "bad.csv:2: column 'x_m'"},
        malformed{"late_metadata", "t_s,x_m,y_m,speed_rpm\n0,0,0,0\n# a: 1\n", "bad.csv:3: metadata after the column header"},
        malformed{"blank_inside", "t_s,x_m,y_m,speed_rpm\n0,0,0,0\n\n1,0,0,0\n", "bad.csv:3: empty line inside the data"},
        malformed{"time_backwards", "t_s,x_m,y_m,speed_rpm\n0,0,0,0\n1,0,0,0\n1,0,0,0\n", "bad.csv:4: t_s is not strictly increasing"},
        // What spreadsheets and pandas write, each named for what it is.
        malformed{"byte_order_mark", "\xEF\xBB\xBFt_s,x_m,y_m,speed_rpm\n0,0,0,0\n", "bad.csv:1: the file starts with a UTF-8 byte-order mark"},
        malformed{"semicolons", "t_s;x_m;y_m;speed_rpm\n0;0,1;0;0\n", "bad.csv:1: header 't_s;x_m;y_m;speed_rpm' must start with t_s,x_m,y_m,speed_rpm (units s, m, m, rpm): columns are separated by ';'"},
        malformed{"decimal_commas", "t_s,x_m,y_m,speed_rpm\n0,0,1,0,2,1600\n", "bad.csv:2: more than 4 values: decimal commas?"},
        malformed{"tabs", "t_s\tx_m\ty_m\tspeed_rpm\n0\t0\t0\t0\n", "columns are separated by tabs"},
        malformed{"quoted_header", "\"t_s\",\"x_m\",\"y_m\",\"speed_rpm\"\n0,0,0,0\n", "bad.csv:1: header '\"t_s\",\"x_m\",\"y_m\",\"speed_rpm\"' must start with t_s,x_m,y_m,speed_rpm (units s, m, m, rpm): column names are quoted"},
        malformed{"pandas_index", ",t_s,x_m,y_m,speed_rpm\n0,0,0,0,0\n", "bad.csv:1: empty column name in header: the first column ('') looks like a row index"},
        malformed{"named_index", "index,t_s,x_m,y_m,speed_rpm\n0,0,0,0,0\n", "the first column ('index') looks like a row index"}),
    [](const ::testing::TestParamInfo<malformed>& info) { return std::string(info.param.name); });

TEST(record, nul_byte_is_an_error) {
  using namespace std::string_literals;
  EXPECT_THROW(parse_record("t_s,x_m,y_m,speed_rpm\n0,0\0,0,0\n"s, "bad.csv"), input_error);
}

}  // namespace
}  // namespace rubref
