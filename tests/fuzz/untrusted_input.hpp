#pragma once
// Every reader of a file rubref accepts from outside, fed arbitrary bytes (docs/robustness.md).
// One function per reader, shared by the libFuzzer targets (tests/fuzz/*_fuzz.cpp, clang) and
// by the replay of the kept inputs in the ordinary suite (fuzz_regression_test, any compiler).
//
// A reader may accept the bytes or refuse them with input_error; the refusal must be one line
// that names the file. Anything else (another exception, a crash, undefined behaviour under
// the sanitizers, a hang) is a finding. Violations abort, which libFuzzer and ctest both see.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "ref/base/errors.hpp"
#include "ref/format/order_table.hpp"
#include "ref/format/record.hpp"
#include "ref/identification/dwells.hpp"
#include "ref/loop/loop.hpp"
#include "ref/model/parameter_io.hpp"
#include "ref/validation/golden.hpp"
#include "ref/validation/validate.hpp"

namespace rubref::fuzz {

// The name the readers are given; every refusal must carry it.
inline constexpr std::string_view kSource = "input.txt";

[[noreturn]] inline void finding(const std::string& what) {
  std::fprintf(stderr, "fuzz finding: %s\n", what.c_str());
  std::abort();
}

inline void expect(bool ok, const std::string& what) {
  if (!ok) finding(what);
}

// A refusal: one line, naming the file.
inline void check_refusal(const input_error& e) {
  const std::string m = e.what();
  expect(!m.empty(), "empty error message");
  expect(m.find('\n') == std::string::npos && m.find('\r') == std::string::npos, "error message is not one line: " + m);
  expect(m.starts_with(kSource), "error message does not name the file: " + m);
}

// Runs `read`; input_error is a refusal (checked), anything else escapes.
template <class Read>
void refuse_or_accept(Read&& read) {
  try {
    read();
  } catch (const input_error& e) {
    check_refusal(e);
  }
}

// A JSON parameter file (--params): accepted only with every value finite and in range.
inline void parameter_file(std::string_view bytes) {
  refuse_or_accept([&] {
    parameters p;
    apply_parameter_text(p, bytes, kSource);
    try {
      validate(p);
    } catch (const input_error&) {
      return;  // a parameter out of range: named by validate, whose messages have no file
    }
  });
}

// A measurement record (identify, loop): the record reader, its dwells and keyphasor.
inline void measurement(std::string_view bytes) {
  refuse_or_accept([&] {
    const record r = parse_record(bytes, kSource);
    for (const auto& col : r.data)
      for (const double v : col) expect(std::isfinite(v), "the record reader accepted a non-finite number");
    const auto& t = r.column("t_s");
    for (std::size_t i = 1; i < t.size(); ++i) expect(t[i] > t[i - 1], "the record reader accepted decreasing times");
    std::vector<std::string> notes;
    for (auto& d : split_dwells(r, std::string(kSource))) {
      expect(d.size() >= 16 && d.rpm > 0.0 && d.dt > 0.0, "split_dwells accepted an unusable dwell");
      loop_dwell ld{std::move(d), std::string(kSource)};
      align_by_keyphasor(ld, notes);
    }
  });
}

// A golden file (validate): the case's metadata and samples.
inline void golden(std::string_view bytes) {
  refuse_or_accept([&] {
    const golden_case g = read_golden_case(parse_record(bytes, kSource), std::string(kSource));
    expect(g.t.size() == static_cast<std::size_t>(g.request.record_revs) * static_cast<std::size_t>(g.request.samples_per_rev),
           "a golden case with a sample count other than its metadata's");
  });
}

// A candidate file (validate) against a case at 1600 rpm: its samples and their statistics.
inline void candidate(std::string_view bytes) {
  refuse_or_accept([&] {
    golden_case g;
    g.request.rpm = 1600.0;
    const candidate_data c = read_candidate(g, parse_record(bytes, kSource), std::string(kSource));
    expect(c.t.size() >= 4, "a candidate of fewer than 4 samples");
    statistics_of(c.t, c.x, c.y, rpm_to_rad_s(g.request.rpm), 3e-4);
  });
}

// An order-tracked table (loop on a table, docs/real-data.md), its conventions given as the
// RK-4 file needs them: accepted only with rows in rising speed, finite vectors, one per row.
inline void order_table_file(std::string_view bytes) {
  refuse_or_accept([&] {
    order_conventions given;
    given.amplitude = "0-peak", given.phase = "lead";
    const order_table t = parse_order_table(bytes, kSource, given);
    expect(t.rows() > 0 && !t.orders.empty(), "the table reader accepted a table without rows or orders");
    for (std::size_t i = 0; i < t.rows(); ++i) {
      expect(t.rpm[i] > 0.0 && std::isfinite(t.rpm[i]), "the table reader accepted a speed that is not positive");
      expect(i == 0 || t.rpm[i] >= t.rpm[i - 1], "the table reader left rows out of speed order");
    }
    for (const auto& o : t.orders) {
      expect(o.vector.size() == t.rows(), "a tracked order with another row count than the table's");
      for (const auto& v : o.vector) expect(std::isfinite(v.real()) && std::isfinite(v.imag()), "the table reader accepted a non-finite vector");
    }
  });
}

}  // namespace rubref::fuzz
