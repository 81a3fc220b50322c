#pragma once
// Stage 1 of `rubref loop` (docs/loop.md): measured records to the dwells the loop fits. Each
// dwell is timed by its keyphasor (or taken as shaft-synchronous without one), the probe noise is
// estimated from the data, dwells whose revolutions do not repeat are left out with their reason,
// and each kept dwell is marked as in contact or not from its own orbit.

#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "ref/format/record.hpp"
#include "ref/identification/dwells.hpp"

namespace rubref {

// A measured dwell as the loop uses it.
struct loop_dwell {
  dwell data;                    // t re-based: t = 0 at a notch passage (or as recorded, without keyphasor)
  std::string record;            // the file it came from
  double timing_sigma = std::numeric_limits<double>::infinity();  // s, keyphasor timing uncertainty (inf: none)
  bool contact = false;          // decided from the data: its synchronous average reaches the clearance
  // Revolutions after which the motion repeats (1: every revolution). A dwell that repeats every n
  // revolutions (a subharmonic rub orbit, one of the coexisting period-n orbits) is fitted on the
  // model's period-n orbit, the fixed point of its n-revolution map.
  int periods = 1;
  double cycle() const { return periods * 60.0 / data.rpm; }  // s, the motion's period
};

// A dwell the loop does not fit, and why (report.json `excluded`, and a line on stderr).
struct excluded_dwell {
  std::string record;
  double rpm = 0.0;
  bool contact = false;
  double spread = 0.0;  // m, RMS deviation of its revolutions from their mean
  std::string reason;
};

struct prepared_dwells {
  std::vector<loop_dwell> dwells;  // synchronous, in file order
  std::vector<excluded_dwell> excluded;
  std::vector<std::string> notes;
  double noise = 0.0;              // m, estimated from every dwell
  double mass = 0.0;               // kg
  std::string mass_source;
};

// Probe noise (m) from the data: estimate_probe_noise (ref/identification/dwells.hpp) over every dwell.
double estimate_noise(const std::vector<loop_dwell>& dwells);
// Re-bases a dwell's times on its keyphasor (t = 0 at a notch passage) and sets its timing
// uncertainty; notes what it cannot do.
void align_by_keyphasor(loop_dwell& d, std::vector<std::string>& notes);
// RMS per probe of orders |k| >= 3 of one averaged revolution (contact's fingerprint).
double high_order_content(const dwell& cycle);

// Every record's dwells, timed, classified and screened. `mass` 0: the records' m_kg, else the
// paper's; `clearance` for records without clearance_m. input_error for unusable records.
prepared_dwells prepare_dwells(const std::vector<std::pair<record, std::string>>& records, double mass, double clearance);

}  // namespace rubref
