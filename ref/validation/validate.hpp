#pragma once
// `rubref validate`: another implementation's output against a golden case (docs/validation.md).
//
// The candidate is a record (t_s, x_m, y_m, speed_rpm; more columns are ignored) of the same
// run: rest at t = 0, the case's settle revolutions, then whole revolutions of the steady state.
//  - orbit cases: each candidate sample is compared with the golden orbit at the same time. If
//    the candidate sampled the case's own times, that is the file's sample. Otherwise its times
//    are taken modulo the orbit's period into the case's record ("resampled by phase"; for a
//    period of several revolutions, at the revolution offset that fits best), and the golden
//    orbit there is integrated again with the golden method, which must first reproduce the
//    file's own samples to kReintegrationTol. No interpolation: contact events make orbits
//    non-smooth between samples. Pass: the largest distance within the case's tolerance, and
//    every statistic within its tolerance.
//  - statistics cases (chaotic): the statistics of the candidate's own samples, each within its
//    tolerance.
// A candidate spanning less than one period of the case fails (`coverage`). A failure is
// diagnosed (ref/validation/diagnosis.hpp): causes from a fixed vocabulary, confirmed or likely.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ref/format/record.hpp"
#include "ref/validation/causes.hpp"
#include "ref/validation/diagnosis.hpp"
#include "ref/validation/golden.hpp"

namespace rubref {

// Integrating a case again with the golden method reproduces its file to this (same method,
// same code: ~1e-15 m; another build or compiler: rounding, amplified by the contacts).
inline constexpr double kReintegrationTol = 1e-11;  // m

struct statistic_check {
  std::string key;
  double golden = 0.0, candidate = 0.0, tolerance = 0.0;
  bool pass() const { return std::abs(candidate - golden) <= tolerance; }
};

struct validation_result {
  std::string case_name, candidate_name;
  std::string variant;
  double clearance = 0.0, rpm = 0.0;
  comparison_kind comparison = comparison_kind::orbit;
  int period_revs = 0;
  std::string sampling;  // how the candidate was put on the golden samples

  // Orbit cases (NaN otherwise): over the compared samples.
  double max_error = 0.0, rms_error = 0.0, tolerance = 0.0;  // m
  double worst_t = 0.0;                                      // s
  double worst_golden[2]{}, worst_candidate[2]{};            // (x, y), m

  std::vector<statistic_check> statistics;
  double spanned_revs = 0.0;       // revolutions the candidate spans
  bool covered = false;            // at least one period of the case
  int candidate_period_revs = -1;  // the candidate's own repetition (0: none, -1: too short to tell)
  std::vector<cause> causes;       // filled only when the case fails, most certain first
  bool pass = false;
};

// The candidate's samples, checked against the case (its speed, at least 4 samples): the reader
// behind validate_candidate, input_error naming the candidate otherwise.
candidate_data read_candidate(const golden_case& g, const record& candidate, const std::string& candidate_name);

// Compares `candidate` (named `candidate_name`) with the golden case `g`. input_error when the
// candidate cannot be compared at all (another speed, too short, before t = 0).
validation_result validate_candidate(const golden_case& g, const record& candidate, const std::string& candidate_name);

std::string to_text(const validation_result& r);
nlohmann::ordered_json to_json(const validation_result& r);

}  // namespace rubref
