#pragma once
// A parameter study (docs/studies.md): a grid and/or a seeded random sample over the model's
// parameters, the speed and the initial state, and one job per point. Every point is a pure
// function of (SPEC, index): its values (random draws come from a stream keyed by the seed and
// the index alone) and its result row. That is what makes a study's files the same, byte for
// byte, from one thread, many threads, MPI ranks or job-array shards merged.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ref/model/effects.hpp"
#include "ref/model/parameters.hpp"
#include "ref/model/settings.hpp"
#include "ref/model/state.hpp"
#include "ref/rig/rig.hpp"

namespace rubref::study {

// The built-in kinds: what the points mean, the summary and the figures (docs/studies.md).
enum class study_kind {
  regime_map,   // clearance x speed: the steady response's regime per point, with fold lines
  basins,       // an initial-state (or unbalance-phase) plane: which attractor each start reaches
  monte_carlo,  // random tolerances: the run-up's rub onset, jump and peak force, as histograms
  grid,         // any grid or sample and any job, a table and a summary, no figure
};
enum class job_kind {
  orbit,     // the steady orbit by shooting (stable, its period, its Floquet multipliers)
  simulate,  // a transient from the point's initial state, then recorded revolutions
  run_up,    // the period-1 branch by continuation over a speed range: onset, jump, peak force
  loop,      // a virtual rig's records of the point's model and effects, then `rubref loop` on them:
             // which effects it names against the truth, the error before and after (a campaign)
};

// What a study can vary: a parameter-file key (e_m, clearance_m, mu, k1_N_m, ...), the speed,
// a component of the initial state at t = 0, and, for the loop job, an effect's parameter
// ("effect.<effect>.<key>", e.g. effect.preload.F_y, keys of `rubref effects`) and the probes'
// noise.
inline constexpr const char* kSpeed = "speed_rpm";
inline constexpr const char* kInitialState[4] = {"x0_m", "y0_m", "vx0_m_s", "vy0_m_s"};
inline constexpr const char* kEffectPrefix = "effect.";
inline constexpr const char* kNoise = "noise_m";
std::vector<std::string> variable_names();  // without the effects' (every library parameter's name is one)

struct axis {  // a grid axis: its values, in order
  std::string name;
  std::vector<double> values;
};
enum class distribution { uniform, normal, log_uniform };
struct random_variable {
  std::string name;
  distribution law = distribution::uniform;
  double a = 0.0, b = 0.0;  // uniform/log-uniform: [a, b]; normal: mean a, standard deviation b
};

struct job_settings {
  job_kind kind = job_kind::orbit;
  // orbit and simulate: where each point starts. "contact_free" (the closed-form response at
  // t = 0; orbit shoots from it first), "state" (x0_m, y0_m, vx0_m_s, vy0_m_s: the point's
  // values, else 0), "rest".
  std::string start = "contact_free";
  // The counts' meanings and ranges: the registry's "study" rows (ref/model/settings.hpp).
  int settle_revs = default_count_of("study", "settle_revs");
  int settle_rounds = default_count_of("study", "settle_rounds");
  int max_period = default_count_of("study", "max_period");
  int record_revs = default_count_of("study", "record_revs");
  int samples_per_rev = default_count_of("study", "samples_per_rev");
  double from_rpm = 0.0, to_rpm = 0.0;  // run_up: the speed range traced (from < to)
  // loop: the rig's dwells (default: the rig's, three below the rub and six with it), its
  // revolutions per dwell, the probes' noise and whether a keyphasor is recorded. The noise's
  // seed is the point's own (uniform_draw of the study's seed and the index).
  std::vector<double> speeds_rpm;
  double noise = 0.5e-6;
  bool keyphasor = true;
};

struct spec {
  study_kind kind = study_kind::grid;
  std::string name;                 // free text, for the reader
  std::string variant = "identified";
  parameters base;                  // the paper's values with the SPEC's "parameters" applied
  effect_parameters effects;        // the loop job's truth effects ("effects": ["name:key=value", ...])
  std::vector<std::string> effect_texts;  // as given, for the canonical text
  double rpm = 1600.0;              // when the speed is not varied
  state_type initial{};             // when the initial state is not varied ("state" start)
  std::vector<axis> grid;           // Cartesian product, the last axis fastest
  std::size_t samples = 1;          // random draws per grid point (1 when there is no "sample")
  std::uint64_t seed = 0;
  std::vector<random_variable> random;
  job_settings job;
};

// The SPEC's JSON text -> spec; input_error "SPEC <source>: `<key path>`: <problem>" naming the
// first bad key (unknown keys included, with a did-you-mean).
spec parse_spec(const std::string& text, const std::string& source);
// The spec with every default filled in, as JSON text: what a study folder keeps (spec.json)
// and compares to resume or merge.
std::string canonical_text(const spec& s);

std::size_t point_count(const spec& s);
// The varied names, grid axes first, then the random variables.
std::vector<std::string> varied_names(const spec& s);

struct point {
  std::size_t index = 0;
  std::vector<double> values;  // per varied_names
  parameters params;
  double rpm = 0.0;
  state_type initial{};
  effect_parameters effects;
  double noise = 0.0;  // m, the loop job's probe noise
};
point point_at(const spec& s, std::size_t index);

// Uniform double in (0, 1) from the k-th draw of point `index`'s stream (keyed_uniform: SplitMix64
// of the seed, the index and k; independent of which process computes the point, and of every
// other point; the same bits on any toolchain).
double uniform_draw(std::uint64_t seed, std::size_t index, std::size_t k);

// The result table's columns: index, the varied names, then the job's outputs.
std::vector<std::string> columns(const spec& s);
// One point's row (its cells, per columns). A numerical failure is a row with status "failed"
// and the reason, never a number; invalid drawn parameters are status "invalid".
std::vector<std::string> evaluate(const spec& s, std::size_t index);

// The loop job's virtual rig at point p: the point's model, effects and probe noise, the job's
// dwells, and a noise seed from the point's stream.
rig_request rig_request_for(const spec& s, const point& p);

std::string_view to_string(study_kind k);
std::string_view to_string(job_kind k);

}  // namespace rubref::study
