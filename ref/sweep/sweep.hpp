#pragma once
// Quasi-static speed sweeps with continuation (docs/sweeps.md): at each speed of a grid the rotor
// settles, then whole revolutions are recorded and summarised; the state at the end of one speed
// starts the next. Every speed runs an integer number of revolutions from t = 0, so the unbalance
// phase w t is a multiple of 2 pi at each hand-over and the forcing is continuous across it.

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "ref/analysis/orbit_summary.hpp"
#include "ref/run/simulate.hpp"

namespace rubref {

enum class sweep_direction { up, down };
std::string_view to_string(sweep_direction d);

struct sweep_settings {
  std::string variant = "identified";
  parameters params;
  // Defaults, units and ranges: the settings registry (ref/model/settings.hpp).
  double from_rpm = default_of("sweep", "from_rpm");
  double to_rpm = default_of("sweep", "to_rpm");
  double step_rpm = default_of("sweep", "step_rpm");
  int first_settle_revs = default_count_of("sweep", "first_settle_revs");  // the first speed starts from rest: let the free transient die
  int settle_revs = default_count_of("sweep", "settle_revs");  // each later speed starts from its neighbour's steady state
  int record_revs = default_count_of("sweep", "record_revs");  // a multiple of 6: orders 1/2 and 1/3 fall on spectral bins
  int samples_per_rev = default_count_of("sweep", "samples_per_rev");
  integration_options integration;
  bool keep_orbits = false;     // keep every recorded orbit (memory: record_revs * samples_per_rev per speed)
  // Start each speed on the periodic orbit continued from its neighbour (Newton shooting from the
  // neighbour's end state, docs/orbits.md) where that orbit is found and stable, instead of
  // settling. Where it is not (past a fold, subharmonic, non-periodic, unstable) the speed settles
  // settle_revs and shoots again from there, up to kSettleRounds times, before it is recorded.
  bool start_from_orbit = false;
};
inline constexpr int kSettleRounds = 4;

// Throws input_error naming the first bad setting.
void validate(const sweep_settings& s);

// The single-speed run a sweep makes at `rpm` (settle_revs, from rest until continued).
run_request request_at(const sweep_settings& s, double rpm);

// The speed grid from_rpm, from_rpm + step, ... up to to_rpm (ascending).
std::vector<double> sweep_speeds(const sweep_settings& s);

struct sweep_point {
  double rpm;
  orbit_summary summary;
  std::vector<orbit_sample> samples;  // only with keep_orbits
};

struct sweep_branch {
  sweep_direction direction;
  std::vector<sweep_point> points;  // in the order visited
  integration_counts counts;        // summed over the points (first_coarse_contact_t: within its point's run)
  double first_coarse_contact_rpm = 0.0;  // the point of the first under-resolved contact step (0: none)
  std::size_t orbit_starts = 0;  // points started on a shot periodic orbit (start_from_orbit)
};

// One sweep direction, sequential (continuation makes each speed depend on the previous one).
sweep_branch run_branch(const sweep_settings& s, sweep_direction d);

struct branch_task {
  sweep_settings settings;
  sweep_direction direction;
};
// Independent branches (directions, clearances, variants) on `threads` threads (0: all cores).
// The result is identical, bit for bit, for any thread count.
std::vector<sweep_branch> run_branches(const std::vector<branch_task>& tasks, unsigned threads);

using speed_ranges = std::vector<std::pair<double, double>>;  // [first, last] rpm, ascending

// Runs of consecutive grid speeds (ascending) where `holds(rpm)` is true.
speed_ranges contiguous_ranges(const std::vector<double>& ascending_rpm, const std::function<bool(double)>& holds);

// The response measure compared between branches and plotted in the jump figure.
inline double response_amplitude(const orbit_summary& s) { return s.max_radius; }

// Coexisting responses and the jumps that bound them (docs/sweeps.md, "Jumps").
struct hysteresis_band {
  double from_rpm, to_rpm;  // first and last grid speed where the two sweeps disagree
};
struct jump {
  sweep_direction sweep;    // in which sweep it happens
  double from_rpm, to_rpm;  // between these consecutive grid speeds
  double amplitude_before, amplitude_after;  // m, response_amplitude
};
struct jump_report {
  double relative_tolerance;             // disagreement threshold used
  std::vector<hysteresis_band> bands;    // contiguous runs of disagreeing speeds
  std::vector<jump> jumps;               // the up sweep leaving a band at its top, the down sweep at its bottom
  double total_width_rpm = 0.0;          // sum over bands of (to - from + step)
};

// Two responses at one speed are different attractors when their amplitudes differ by more than
// this share of the larger one plus what each varies by itself from revolution to revolution
// (radius_spread: an irregular orbit recorded twice is one attractor). 2 % is far above the
// integration error (1e-8) and below the smallest branch separation that matters on a probe.
inline constexpr double kCoexistenceTolerance = 0.02;

jump_report detect_jumps(const sweep_branch& up, const sweep_branch& down, double step_rpm,
                         double relative_tolerance = kCoexistenceTolerance);

}  // namespace rubref
