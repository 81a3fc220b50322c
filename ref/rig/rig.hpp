#pragma once
// The virtual test rig (`rubref rig`, docs/loop.md): a lab rotor kit as two proximity probes see
// it. The truth is the paper's model plus any set of library effects (ref/model/effects.hpp); the
// probes sample it at a fixed rate, not synchronised with the shaft, add their runout and white
// noise, are turned by their misorientation, and quantise; a keyphasor marks each revolution.
// The record states what a lab would write down (clearance, sample rate, speeds), never the
// effects: those go to a separate truth file that only tests read.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ref/format/record.hpp"
#include "ref/integrate/hybrid_integrator.hpp"
#include "ref/model/effects.hpp"
#include "ref/model/parameters.hpp"
#include "ref/model/rotor_model.hpp"
#include "ref/rig/probes.hpp"

namespace rubref {

struct probe_settings {
  double sample_rate = default_of("rig", "sample_rate");    // Hz (ranges: ref/model/settings.hpp)
  double noise = default_of("rig", "noise");                // m, standard deviation of each probe's white noise
  double quantisation = default_of("rig", "quantisation");  // m, ADC step (16 bits over +-2 mm)
  double keyphasor_angle = 0.0;    // rad, the notch's angle from the unbalance at t = 0 (unknown to the loop)
  unsigned seed = 1;               // noise: same seed, same bits
  bool keyphasor = true;           // write the keyphasor column (without it, t_s is shaft-synchronous)
};

// What `t_s` means in the record. `acquisition`: the sampling clock, running on across dwells
// (a lab's ADC). `shaft`: the shaft angle is w t_s in every dwell (docs/data-format.md), each
// dwell's clock shifted by whole periods of its own speed so that time still increases.
enum class rig_time_base { acquisition, shaft };

struct rig_request {
  std::string variant = "identified";   // the truth's contact law (a compliant one)
  parameters params;                     // the truth rotor (the paper's by default)
  effect_parameters effects;             // the truth's effects (none by default)
  unmodelled_effects unmodelled;         // outside the library (none by default)
  // One dwell each: three below the rub (the loop fits the linear part there), six with it, all
  // with orbits that repeat every revolution under the paper's law at 0.3 mm (1425-1475 rpm do not).
  std::vector<double> speeds_rpm{1200, 1300, 1400, 1500, 1550, 1600, 1650, 1700, 1750};
  int settle_revs = default_count_of("rig", "settle_revs");  // per dwell, from rest or (carry_over) from the previous dwell
  bool carry_over = false;               // each dwell starts where the previous one ended (a run-up), not from rest
  rig_time_base time_base = rig_time_base::acquisition;
  bool minimal_header = false;           // only clearance_m, sample_rate_hz and description (as a record from elsewhere)
  int record_revs = default_count_of("rig", "record_revs");  // per dwell
  probe_settings probes;
  integration_options integration;       // of the truth (rubref's defaults; another stepper for records of "another integrator")
};

// Throws input_error naming the first bad setting.
void validate(const rig_request& req);

struct rig_output {
  record measurement;           // t_s (acquisition clock), x_m, y_m, speed_rpm, keyphasor
  nlohmann::ordered_json truth;  // the effects, parameters and probe settings
};

rig_output run_rig(const rig_request& req);

}  // namespace rubref
