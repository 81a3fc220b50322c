#pragma once
// Golden orbits (golden/, docs/validation.md): steady-state orbits of every variant at the
// clearances and speeds of the paper's Figs. 10-12, made by a deliberately careful method, with
// their provenance and the tolerance a comparison should use, in the record format.
//
// A case is compared one of two ways, decided when it is generated:
//  - orbit:      two independent careful integrations agree to 1e-9 of the orbit, so the orbit
//                itself is the reference; a candidate must match it sample by sample.
//  - statistics: they do not (the steady state is chaotic: a difference of 1e-15 m grows to
//                ~0.1 mm over the settling revolutions), so no code can reproduce the samples and
//                only the orbit's statistics (peak-to-peak, 1X whirl, contact share) are compared,
//                with tolerances measured from an ensemble of careful runs.

#include <array>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ref/format/record.hpp"
#include "ref/run/simulate.hpp"

namespace rubref {

// What validation compares besides the samples, all from the recorded samples alone so that any
// implementation's output yields them the same way.
struct orbit_statistics {
  double peak_to_peak_x = 0.0;  // m
  double peak_to_peak_y = 0.0;  // m
  double max_radius = 0.0;      // m, max |x + j y|
  double forward_1x = 0.0;      // m, |coefficient of e^{+j w t}| of x + j y (Eq. 7), least squares
  double backward_1x = 0.0;     // m, |coefficient of e^{-j w t}|
  double contact_fraction = 0.0;  // share of samples with y > clearance
};

struct statistic_info {
  double orbit_statistics::*member;
  std::string_view key;  // record metadata key and JSON name (with unit)
  std::string_view description;
};

inline constexpr std::array<statistic_info, 6> statistic_table{{
    {&orbit_statistics::peak_to_peak_x, "peak_to_peak_x_m", "peak-to-peak x"},
    {&orbit_statistics::peak_to_peak_y, "peak_to_peak_y_m", "peak-to-peak y"},
    {&orbit_statistics::max_radius, "max_radius_m", "largest |x + j y|"},
    {&orbit_statistics::forward_1x, "forward_1x_m", "forward 1X whirl amplitude"},
    {&orbit_statistics::backward_1x, "backward_1x_m", "backward 1X whirl amplitude"},
    {&orbit_statistics::contact_fraction, "contact_fraction", "share of samples with y > clearance"},
}};

// Statistics of samples (t, x, y) of a rotor at `omega` rad/s with clearance `delta` m. The 1X
// components are the least-squares fit of a + b e^{jwt} + c e^{-jwt} to x + j y: on whole
// revolutions sampled uniformly that is the DFT bin, and it needs neither.
orbit_statistics statistics_of(std::span<const double> t, std::span<const double> x, std::span<const double> y,
                               double omega, double clearance);

enum class comparison_kind { orbit, statistics };
std::string_view to_string(comparison_kind k);

// The case matrix of the golden files: every variant x clearance x speed.
struct golden_spec {
  std::string variant;
  double clearance;           // m
  double rpm;
  double e = parameters{}.e;  // m, the unbalance eccentricity (the paper's unless a case needs more)
  std::string feature;        // what the case is there for, in its file name ("" for the matrix)
};
inline constexpr std::array<double, 3> kGoldenClearances{0.2e-3, 0.3e-3, 0.4e-3};         // m, Fig. 12
inline constexpr std::array<double, 5> kGoldenSpeeds{1450.0, 1550.0, 1600.0, 1650.0, 1750.0};  // rpm
inline constexpr int kGoldenSettleRevs = 200;    // from rest at t = 0 (~40 decay times 2m/c)
inline constexpr int kGoldenRecordRevs = 8;      // holds two periods of any period <= 4 rev
inline constexpr int kGoldenSamplesPerRev = 128;

// Every variant x clearance x speed, then the cases beyond the matrix (long_contact_case).
std::vector<golden_spec> golden_matrix();
// A periodic case with one long contact episode per revolution (ref/validation/golden.cpp says why this one).
golden_spec long_contact_case();
// A restitution case whose chatter ends in sticking and release every revolution (golden.cpp says why this one).
golden_spec chatter_sticking_case();
// e.g. "identified_0.3mm_1600rpm.csv", "restitution_0.02mm_600rpm_chatter-sticking.csv"
std::string golden_file_name(const golden_spec& spec);

// The case as rubref runs it by default (its fast path): paper parameters with the case's
// clearance, from rest at t = 0, kGoldenSettleRevs then kGoldenRecordRevs at kGoldenSamplesPerRev.
run_request golden_request(const golden_spec& spec);

// The careful method the files are made with, and the independent one that cross-checks it.
integration_options golden_method();       // rkf78, rtol 1e-13, atol 1e-18
integration_options golden_cross_check();  // Bulirsch-Stoer at the same tolerances, free flight integrated

// Orbit tolerance of a case: 1e-4 of the largest radius (docs/validation.md, "What the
// tolerance means"): 50x above what event-located integration at rtol 1e-6 reaches (8.2e-10 m
// on identified, 0.3 mm, 1650 rpm), and 20x below a small real fault (r = 0.85 instead of 0.86:
// 1.2e-6 m on restitution, 0.3 mm, 1650 rpm); both examples are run in docs/validation.md.
inline constexpr double kGoldenOrbitRelTol = 1e-4;
// Two careful integrations that agree to this share of the orbit make it an `orbit` case
// (they agree to ~1e-12 on periodic cases and differ by ~0.2 on chaotic ones).
inline constexpr double kReproducibleRelTol = 1e-9;

// Newton's tolerance on a periodic case's fixed point: the shooting's own (kShootingTolerance,
// 1e-12 m), 3e-5 of the cases' orbit tolerance; the files reach 1e-14 m and below.
inline constexpr double kGoldenShootingTolerance = kShootingTolerance;

// Another stable steady state of a case's model, reached from another start than the file's (rest
// at t = 0 with the file's unbalance phase): docs/validation.md, "Coexisting attractors". A
// candidate that started elsewhere can settle there and fail for that reason alone.
struct coexisting_attractor {
  std::string start;            // how it is reached, e.g. "rest, unbalance phase 90 deg"
  int period_revs = 1;          // revolutions per period (>= 1)
  state_type state{};           // on it at t = settle_revs T, in the file's frame (its unbalance phase)
  double max_multiplier = 0.0;  // largest Floquet multiplier modulus (< 1: stable)
};

// Header keys of the attractor scan: `coexisting_attractors: N` (absent: the file predates the
// scan), then for k = 1..N `attractor_<k>_start`, `attractor_<k>_period_revs`,
// `attractor_<k>_state` ("x y vx vy", 17 digits) and `attractor_<k>_max_multiplier`.
std::string attractor_key(int k, std::string_view field);  // "attractor_<k>_<field>"

// The attractor scan of make_golden (docs/validation.md, "Coexisting attractors"): other starts
// than the file's, each settled by rubref's fast path, its period found, then shot with the
// careful stepper at t = settle_revs T; the stable orbits that are not the case's own are kept.
// Each start settles to t = kGoldenSettleRevs T, as the file's run from rest, and once more as
// long if it is not periodic by then.
inline constexpr int kScanExtraSettleRevs = 200;
inline constexpr int kScanPoincareRevs = 8;       // revolution starts compared: two periods of 4
inline constexpr int kScanMaxPeriodRevs = 4;      // the periods the golden record itself resolves
// A start has settled on a period-p orbit when its revolution-start states repeat every p
// revolutions to this share of the case's radius (the shooting's norm): 200 revolutions from
// rest bring the files' own transients to ~1e-11 of it; 1e-6 leaves room for a slower decay
// and is still far inside Newton's basin, which the shooting then confirms.
inline constexpr double kScanPeriodRelTol = 1e-6;
// The shot orbit must lie this close (share of the radius) to the settled state it was shot
// from, or Newton went elsewhere and the start did not reach it: 100x the period test.
inline constexpr double kScanReachedRelTol = 1e-4;
// Two shot orbits are the same attractor when one's state is within this share of the case's
// radius of a revolution shift of the other: both are converged to 1e-12 m (~2e-9 of a 0.5 mm
// orbit); distinct attractors differ by microns, far above.
inline constexpr double kDistinctAttractorRelTol = 1e-6;

// The shooting's norm on a state difference: max(|dx|, |dy|, |dvx| / |w|, |dvy| / |w|), m.
double state_distance(const state_type& a, const state_type& b, double omega);

// The states of a shot orbit at t0 + k T for k < revs (the careful method): its revolution shifts.
std::vector<state_type> revolution_states(const run_request& careful, const state_type& on_orbit, int revs, double t0);

struct attractor_scan {
  std::vector<coexisting_attractor> attractors;  // distinct, in the order of the starts that reach them
  int starts = 0;
  int unsettled = 0;        // starts on no stable orbit of period <= kScanMaxPeriodRevs (chaotic)
  std::string description;  // the header key `attractor_scan`
};

// Scans the model of `spec` from the other starts: rest at t = k T / 8 (unbalance phase k 45 deg,
// k = 1..7), the contact-free response at t = 0, and rest at (0, 0.9 delta), (0, -0.9 delta),
// (0.9 delta, 0), (-0.9 delta, 0) at t = 0. `own` are the case's own states at
// t = settle_revs T + k T (every revolution start of its record), `radius` its largest radius (m).
attractor_scan scan_attractors(const golden_spec& spec, std::span<const state_type> own, double radius, unsigned threads = 1);

// A golden file as read back: the run that makes it, how to compare, and its samples.
struct golden_case {
  std::string name;           // file name
  run_request request;        // variant, parameters, speed, sampling; rubref's default integration
  comparison_kind comparison = comparison_kind::orbit;
  int period_revs = 0;        // the orbit repeats every period_revs revolutions; 0: not within the record
  double orbit_tolerance = 0.0;    // m, on the largest sample error (orbit cases)
  orbit_statistics statistics;     // of the golden samples
  orbit_statistics statistics_tolerance;
  std::vector<double> t, x, y, vx, vy;  // the samples
  bool attractors_scanned = false;      // the header has `coexisting_attractors`
  std::vector<coexisting_attractor> attractors;  // other stable orbits from other starts
  double omega() const { return rpm_to_rad_s(request.rpm); }
};

// Reads a golden record; input_error naming the source and the missing or bad key.
golden_case read_golden_case(const record& r, const std::string& source);

// Makes the golden record of `spec` with the careful method, cross-checked, on `threads`
// threads (ensemble runs of statistics cases). `date` goes into the provenance (YYYY-MM-DD).
record make_golden(const golden_spec& spec, std::string_view date, unsigned threads = 1);

}  // namespace rubref
