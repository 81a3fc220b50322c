// Order-tracked tables (docs/data-format.md, "Order-tracked tables"): every convention reads back
// the same complex vectors, and every malformed or ambiguous table is one error naming what to
// declare.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "ref/base/errors.hpp"
#include "ref/format/order_table.hpp"

namespace rubref {
namespace {

using cplx = std::complex<double>;

// Two probes, 1X and 2X, vectors spread over every quadrant and five decades.
order_table made_table() {
  order_table t;
  t.source = "made";
  t.orders = {{"x", 1, 0.0, {}, "", ""}, {"x", 2, 0.0, {}, "", ""}, {"y", 1, std::numbers::pi / 2.0, {}, "", ""}, {"y", 2, std::numbers::pi / 2.0, {}, "", ""}};
  for (int i = 0; i < 40; ++i) {
    t.rpm.push_back(500.0 + 37.5 * i);
    t.line.push_back(0);
    for (std::size_t o = 0; o < t.orders.size(); ++o)
      t.orders[o].vector.push_back(std::polar(1e-8 * std::pow(10.0, (i + o) % 5), 0.37 * i - 2.9 + static_cast<double>(o)));
  }
  return t;
}

struct convention_case {
  std::string amplitude, phase, unit, phase_unit;
  bool declare, suffixes;
};

TEST(OrderTable, EveryConventionReadsBackTheSameVectors) {
  const order_table truth = made_table();
  int cases = 0;
  for (const std::string amplitude : {"0-peak", "pk-pk", "rms"})
    for (const std::string phase : {"lead", "lag"})
      for (const std::string unit : {"m", "mm", "um", "mil", "V", "mV"})
        for (const std::string phase_unit : {"deg", "rad"})
          for (const bool declare : {true, false})
            for (const bool suffixes : {true, false}) {
              if (!declare && !suffixes && unit == "V") continue;  // covered by the given-units cases
              order_table_style style;
              style.amplitude = amplitude, style.phase = phase, style.amplitude_unit = unit, style.phase_unit = phase_unit;
              style.scale_mV_per_um = 7.874;  // the RK-4 kit's 3300 XL probes (200 mV/mil)
              style.declare = declare, style.unit_suffixes = suffixes;
              const std::string csv = to_csv(truth, style);
              order_conventions given;
              if (!declare) {
                given.amplitude = amplitude, given.phase = phase;
                if (!suffixes) given.amplitude_unit = unit, given.phase_unit = phase_unit;
                given.probe_angles_deg = {{"x", 0.0}, {"y", 90.0}};
              }
              const order_table read = parse_order_table(csv, "t.csv", given);
              ASSERT_EQ(read.orders.size(), truth.orders.size()) << csv.substr(0, 300);
              for (std::size_t o = 0; o < truth.orders.size(); ++o) {
                EXPECT_EQ(read.orders[o].probe, truth.orders[o].probe);
                EXPECT_EQ(read.orders[o].order, truth.orders[o].order);
                ASSERT_TRUE(read.orders[o].probe_angle.has_value());
                EXPECT_NEAR(*read.orders[o].probe_angle, *truth.orders[o].probe_angle, 1e-15);
                for (std::size_t i = 0; i < truth.rows(); ++i)
                  // 1e-12 relative: a unit's and a convention's factors, applied and undone, each
                  // round to the last bits; the numbers themselves are written exactly.
                  EXPECT_LT(std::abs(read.orders[o].vector[i] - truth.orders[o].vector[i]), 1e-12 * std::abs(truth.orders[o].vector[i]))
                      << amplitude << " " << phase << " " << unit << " " << phase_unit << " declare " << declare << " row " << i;
              }
              ++cases;
            }
  EXPECT_EQ(cases, 3 * 2 * 6 * 2 * 4 - 3 * 2 * 2);
}

TEST(OrderTable, RowsAreReadInRisingSpeedAndWhatWasDoneIsSaid) {
  const std::string head = "# amplitude: 0-peak\n# phase: lead\nrpm,amp_1x_um,phase_1x_deg,comment_id\n";
  // A coast-down.
  order_table t = parse_order_table(head + "3000,1,0,1\n2000,2,10,2\n1000,3,20,3\n", "c.csv", {});
  EXPECT_EQ(t.rpm, (std::vector<double>{1000, 2000, 3000}));
  EXPECT_NEAR(std::abs(t.orders[0].vector[0]), 3e-6, 1e-18);
  EXPECT_EQ(t.line, (std::vector<std::size_t>{6, 5, 4}));
  const auto said = [&](const std::string& what) {
    for (const auto& n : t.notes)
      if (n.find(what) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(said("coast-down"));
  EXPECT_TRUE(said("'comment_id'"));
  // Out of order, with a repeated speed.
  t = parse_order_table(head + "1000,1,0,1\n3000,2,10,2\n2000,3,20,3\n2000,4,30,4\n", "o.csv", {});
  EXPECT_EQ(t.rpm, (std::vector<double>{1000, 2000, 2000, 3000}));
  EXPECT_TRUE(said("not in speed order"));
  EXPECT_TRUE(said("1 rows repeat"));
  // A dwell: most rows within 1 % of one speed.
  std::string rows;
  for (int i = 0; i < 10; ++i) rows += std::to_string(1000 + 100 * i) + ",1,0,0\n";
  for (int i = 0; i < 30; ++i) rows += std::to_string(2000 + i / 2) + (i % 2 ? ".5" : "") + ",1,0,0\n";
  t = parse_order_table(head + rows, "d.csv", {});
  EXPECT_TRUE(said("30 rows (75 % of the table) dwell at"));
}

TEST(OrderTable, ATimeColumnIsEachRowsTimeAndWritesBack) {
  // A shuffled coast-down with its times: they follow the rows into rising speed.
  const std::string head = "# amplitude: 0-peak\n# phase: lead\nrpm,time_s,amp_1x_um,phase_1x_deg\n";
  const order_table t = parse_order_table(head + "2000,1.5,1,0\n3000,0.5,2,10\n1000,2.5,3,20\n", "t.csv", {});
  EXPECT_EQ(t.time_s, (std::vector<double>{2.5, 1.5, 0.5}));
  for (const auto& n : t.notes) EXPECT_EQ(n.find("time_s"), std::string::npos) << n;  // read, not ignored
  const order_table back = parse_order_table(to_csv(t, {}), "back.csv", {});
  EXPECT_EQ(back.time_s, t.time_s);
  EXPECT_TRUE(parse_order_table(head.substr(0, head.find("rpm")) + "rpm,amp_1x_um,phase_1x_deg\n1000,1,0\n", "n.csv", {}).time_s.empty());
}

TEST(OrderTable, TheSharedFilesTwoAmplitudeColumnsAreCheckedAgainstEachOther) {
  // The RK-4 file's header: amp_1x in mils, amp_1x_um in micrometres (data/rk4_runup/README.md).
  const std::string head = "rpm,amp_1x,phase_1x_deg,amp_1x_um\n";
  order_conventions given;
  given.amplitude = "0-peak", given.phase = "lead";
  // Without a unit for amp_1x, amp_1x_um is read and amp_1x is said to be left.
  order_table t = parse_order_table(head + "1000,0.1,10,2.54\n1100,0.2,20,5.08\n", "rk4.csv", given);
  EXPECT_NEAR(std::abs(t.orders[0].vector[1]), 5.08e-6, 1e-18);
  EXPECT_NE(t.notes.front().find("'amp_1x' not read"), std::string::npos);
  // With mils declared, both are read and agree.
  given.amplitude_unit = "mil";
  t = parse_order_table(head + "1000,0.1,10,2.54\n1100,0.2,20,5.08\n", "rk4.csv", given);
  EXPECT_NEAR(std::abs(t.orders[0].vector[0]), 2.54e-6, 1e-18);
  // A wrong declared unit shows.
  given.amplitude_unit = "um";
  EXPECT_THROW(parse_order_table(head + "1000,0.1,10,2.54\n", "rk4.csv", given), input_error);
}

struct malformed {
  const char* name;
  std::string text;
  std::string given_amplitude;  // "" or a convention given from outside
  std::string message;          // a substring of the one-line error
};

class MalformedOrderTable : public ::testing::TestWithParam<malformed> {};

TEST_P(MalformedOrderTable, IsOneLineNamingWhatToDeclare) {
  const malformed& m = GetParam();
  order_conventions given;
  given.amplitude = m.given_amplitude;
  try {
    parse_order_table(m.text, "bad.csv", given);
    FAIL() << "accepted: " << m.name;
  } catch (const input_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(m.message), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos);
    EXPECT_EQ(what.rfind("bad.csv", 0), 0u) << what;
  }
}

const std::string kDeclared = "# amplitude: pk-pk\n# phase: lag\n";
INSTANTIATE_TEST_SUITE_P(
    OrderTable, MalformedOrderTable,
    ::testing::Values(
        malformed{"no_amplitude_convention", "# phase: lead\nrpm,amp_1x_um,phase_1x_deg\n1000,1,0\n", "", "the amplitude convention is not declared"},
        malformed{"no_phase_convention", "# amplitude: rms\nrpm,amp_1x_um,phase_1x_deg\n1000,1,0\n", "", "the phase convention is not declared"},
        malformed{"no_amplitude_unit", kDeclared + "rpm,amp_1x,phase_1x_deg\n1000,1,0\n", "", "column 'amp_1x' has no unit: declare it"},
        malformed{"no_phase_unit", kDeclared + "rpm,amp_1x_um,phase_1x\n1000,1,0\n", "", "column 'phase_1x' has no unit"},
        malformed{"unknown_unit", kDeclared + "rpm,amp_1x_furlong,phase_1x_deg\n1000,1,0\n", "", "unknown amplitude unit 'furlong'"},
        malformed{"volts_without_scale", kDeclared + "rpm,amp_1x_v,phase_1x_deg\n1000,1,0\n", "", "declare the probe sensitivity"},
        malformed{"unknown_amplitude_convention", "# amplitude: peak-ish\n# phase: lag\nrpm,amp_1x_um,phase_1x_deg\n1000,1,0\n", "",
                  "unknown amplitude convention 'peak-ish'"},
        malformed{"conflicting_conventions", kDeclared + "rpm,amp_1x_um,phase_1x_deg\n1000,1,0\n", "rms", "say it once"},
        malformed{"two_speed_columns", kDeclared + "rpm,speed_hz,amp_1x_um,phase_1x_deg\n1000,16,1,0\n", "", "two speed columns"},
        malformed{"amplitude_without_phase", kDeclared + "rpm,amp_1x_um\n1000,1\n", "", "no phase column for 1X"},
        malformed{"phase_without_amplitude", kDeclared + "rpm,amp_1x_um,phase_1x_deg,x_phase_2x_deg\n1000,1,0,0\n", "", "no amplitude column for x 2X"},
        malformed{"negative_amplitude", kDeclared + "rpm,amp_1x_um,phase_1x_deg\n1000,-1,0\n", "", "a negative amplitude"},
        malformed{"zero_speed", kDeclared + "rpm,amp_1x_um,phase_1x_deg\n0,1,0\n", "", "must be positive"},
        malformed{"not_a_number", kDeclared + "rpm,amp_1x_um,phase_1x_deg\n1000,abc,0\n", "", "not a finite number"},
        malformed{"two_rows_at_one_time", kDeclared + "rpm,time_s,amp_1x_um,phase_1x_deg\n1000,2,1,0\n1100,2,1,0\n", "", "two rows have the same time_s"},
        malformed{"no_order_columns", kDeclared + "rpm,vibration\n1000,1\n", "", "an order-tracked table needs"},
        malformed{"angle_for_unknown_probe", kDeclared + "# probe_angle_deg.z: 45\nrpm,x_amp_1x_um,x_phase_1x_deg\n1000,1,0\n", "",
                  "no probe of this table"},
        malformed{"unnamed_angle_with_two_probes", kDeclared + "# probe_angle_deg: 45\nrpm,x_amp_1x_um,x_phase_1x_deg,y_amp_1x_um,y_phase_1x_deg\n1000,1,0,1,0\n",
                  "", "a probe angle without a probe name"}),
    [](const ::testing::TestParamInfo<malformed>& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace rubref
