// Parameters: the paper's values as defaults, and validation that names what is wrong before
// anything is integrated.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "ref/base/errors.hpp"
#include "ref/format/record.hpp"
#include "ref/model/parameter_io.hpp"
#include "ref/run/simulate.hpp"

namespace rubref {
namespace {

// §3, Eq. 6 text, Table 2 of the paper, in SI units.
TEST(parameters, defaults_are_the_papers) {
  const parameters p;
  EXPECT_EQ(p.m, 1.52);
  EXPECT_EQ(p.e, 0.0706e-3);
  EXPECT_EQ(p.unbalance_phase, 0.0);  // Eq. 1: the unbalance at +x at t = 0
  EXPECT_EQ(p.c_x, 15.100);
  EXPECT_EQ(p.c_y, 14.727);
  EXPECT_EQ(p.k_x, 38.521e3);
  EXPECT_EQ(p.k_y, 41.017e3);
  EXPECT_EQ(p.clearance, 0.3e-3);
  EXPECT_EQ(p.mu, 0.24);
  EXPECT_EQ(p.r, 0.86);
  EXPECT_EQ(p.k1, 3.946e6);
  EXPECT_EQ(p.k3, 1.408e11);
  EXPECT_EQ(p.c2, 3.720e4);
  EXPECT_NO_THROW(validate(p));
}

std::string error_of(const parameters& p) {
  try {
    validate(p);
  } catch (const input_error& e) {
    return e.what();
  }
  return "";
}

TEST(parameters, every_bad_value_is_named) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const auto& info : parameter_table) {
    std::vector<double> bad{nan, inf, -inf};
    const valid_range& range = info.row->range;
    if (std::isfinite(range.lo)) bad.push_back(range.lo - 1.0);
    if (std::isfinite(range.lo) && range.lo_open) bad.push_back(range.lo);
    if (std::isfinite(range.hi)) bad.push_back(range.hi + 0.5);
    for (const double v : bad) {
      parameters p;
      p.*info.member = v;
      const std::string msg = error_of(p);
      EXPECT_NE(msg.find("parameter " + std::string(info.key)), std::string::npos) << info.key << " = " << v << ": '" << msg << "'";
    }
  }
}

TEST(parameters, boundary_values_that_are_physical_pass) {
  parameters p;
  p.r = 0.0;  // plastic impact
  p.mu = 0.0;
  p.e = 0.0;
  p.c_x = p.c_y = 0.0;
  p.k3 = p.c2 = 0.0;
  EXPECT_NO_THROW(validate(p));
  p.r = 1.0;  // elastic impact
  EXPECT_NO_THROW(validate(p));
}

TEST(parameters, json_round_trip_and_errors) {
  parameters p;
  p.k1 = 1e7;
  p.clearance = 2e-4;
  parameters q;
  apply_json(q, nlohmann::json::parse(to_json(p).dump()), "p.json");
  EXPECT_EQ(q, p);
  EXPECT_THROW(apply_json(q, nlohmann::json::parse(R"({"k_1": 1})"), "p.json"), input_error);
  EXPECT_THROW(apply_json(q, nlohmann::json::parse(R"({"k1_N_m": "1e6"})"), "p.json"), input_error);
  EXPECT_THROW(apply_json(q, nlohmann::json::parse("[1, 2]"), "p.json"), input_error);
  // An out-of-range value is refused where it is read, naming the file and its line.
  try {
    apply_parameter_text(q, "{\n  \"m_kg\": 1.52,\n  \"mu\": -0.1\n}\n", "p.json");
    ADD_FAILURE() << "mu = -0.1 accepted";
  } catch (const input_error& e) {
    EXPECT_EQ(std::string(e.what()), "p.json:3: parameter mu must be finite and >= 0 (got -0.10000000000000001): friction opposes the sliding");
  }
}

TEST(run_request, bad_settings_are_rejected_before_integration) {
  const auto rejects = [](auto&& mutate, const char* what) {
    run_request req;
    mutate(req);
    try {
      simulate(req);
      ADD_FAILURE() << "accepted: " << what;
    } catch (const input_error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  rejects([](run_request& r) { r.rpm = 0.0; }, "`rpm` must be");
  rejects([](run_request& r) { r.rpm = std::nan(""); }, "`rpm` must be");
  rejects([](run_request& r) { r.rpm = 1e9; }, "`rpm` must be");
  rejects([](run_request& r) { r.variant = "hertz"; }, "unknown variant 'hertz'");
  rejects([](run_request& r) { r.record_revs = 0; }, "revs");
  rejects([](run_request& r) { r.samples_per_rev = 2; }, "`samples_per_rev`");
  rejects([](run_request& r) { r.integration.stepper.rtol = -1.0; }, "rtol");
  rejects([](run_request& r) { r.integration.stepper.atol = 0.0; }, "atol");
  rejects([](run_request& r) { r.params.m = -1.52; }, "m_kg");
  rejects([](run_request& r) {
    r.variant = "restitution";
    r.initial_state = {0.0, 1e-3, 0.0, 0.0};
  }, "inside the stator");
  EXPECT_THROW(parse_stepper("euler"), input_error);
}

// Numerically dangerous (kMaxRateTimesDuration): the fastest rate times the run's duration. The
// paper's run is ~1.3e4 (sqrt(k1/m) = 1.6e3 1/s over 7.8 s); a 1e-30 kg rotor or a 1e30 N/m
// contact are refused with the rate named; the contact stiffness does not count for the
// restitution law, which has none.
TEST(run_request, numerically_dangerous_rates_are_rejected_with_the_rate_named) {
  const auto message = [](const run_request& req) -> std::string {
    try {
      validate(req);
      return {};
    } catch (const input_error& e) {
      return e.what();
    }
  };
  run_request req;
  EXPECT_EQ(message(req), "");
  req.params.k1 = 1e30;
  EXPECT_NE(message(req).find("numerically dangerous parameters: sqrt(k1/m)"), std::string::npos) << message(req);
  req.variant = "restitution";
  EXPECT_EQ(message(req), "");
  req = run_request{};
  req.params.m = 1e-30;
  EXPECT_NE(message(req).find("m_kg = 1e-30"), std::string::npos) << message(req);
  // A stiff but legitimate contact (1e10 N/m on 1.52 kg: 8.1e4 1/s over 7.8 s) passes.
  req = run_request{};
  req.params.k1 = 1e10;
  EXPECT_EQ(message(req), "");
}

// A record read from a file names the file and line in every metadata error.
TEST(record, metadata_errors_name_the_file_and_line) {
  const record r = parse_record("# format: rubref-record 1\n\n# m_kg: heavy\nt_s,x_m,y_m,speed_rpm\n0,0,0,1\n", "r.csv");
  try {
    r.number("m_kg");
    FAIL();
  } catch (const input_error& e) {
    EXPECT_EQ(std::string(e.what()), "r.csv:3: metadata 'm_kg' is not a number: 'heavy'");
  }
  EXPECT_EQ(r.first_data_line, 5u);
  EXPECT_EQ(r.where_row(0), "r.csv:5: ");
}

}  // namespace
}  // namespace rubref
