#pragma once
// Re-identification by output error (simulation error): the contact-law parameters of Eq. 5's
// family (k1, k3, c2, mu; optionally e and the clearance) that make simulated orbits match the
// measured ones, by the one least-squares solver (ref/inference/least_squares.hpp), after an
// optional global stage (NLopt's DIRECT-L) that only chooses its start.
//
// A raw dwell is simulated from its measured state (positions, and velocities from the
// derivative filter) at its first fully centred sample, with the model's unbalance phase, and
// compared with the measurement at every later sample. A synchronously averaged dwell (one
// periodic cycle, noise divided by sqrt(revolutions)) is compared with the model's own periodic
// orbit near it, found by Newton shooting. The objective is the mean square orbit error; its root
// (RMS) is reported.

#include <string>
#include <vector>

#include "ref/identification/contact_forces.hpp"
#include "ref/integrate/hybrid_integrator.hpp"
#include "ref/model/parameters.hpp"
#include "ref/model/settings.hpp"

namespace rubref {

struct reid_settings {
  std::vector<std::string> fit = {"k1", "k3", "c2", "mu"};  // any of k1, k3, c2, mu, e, clearance
  bool global = false;  // DIRECT-L over [0.1, 10] x start before the solver: its best point is the solver's start
  // Defaults, ranges and reasons: the settings registry (scope "reidentify").
  int max_jacobians = default_count_of("reidentify", "max_jacobians");                  // of the solver
  int global_evaluations = default_count_of("reidentify", "global_evaluations");        // of DIRECT-L
  int derivative_half_width = default_count_of("reidentify", "derivative_half_width");  // as used for the velocities of the initial states
  void validate() const;  // input_error naming the setting
};

struct reid_parameter {
  std::string name;
  double initial, value;
  double standard_error;  // from the solver's covariance at the end (docs/identification.md)
  bool identifiable;      // value > 1.96 standard errors
  bool at_bound = false;  // the solver ended on a bound (0 or 10x the start)
};

struct reid_result {
  std::string algorithm;
  int evaluations = 0;
  double initial_rms = 0.0, final_rms = 0.0;  // m, orbit error (NaN where the orbit failed)
  std::vector<reid_parameter> parameters;
  // Evaluations whose orbit could not be computed (the solver rejected them; the global stage
  // ranks them last), and whether the start or the final parameters were among them: then the
  // RMS is NaN, never a number, and identify warns.
  int failed_evaluations = 0;
  bool initial_failed = false, final_failed = false;
  std::string failure;  // the first failure's message
};

// An integration observer that keeps the positions at the grid's samples (both output-error fits).
struct position_recorder {
  std::vector<double> x, y;
  template <class System>
  void on_sample(double, const state_type& s, const System&) {
    x.push_back(s[idx::x]);
    y.push_back(s[idx::y]);
  }
  void on_event(const contact_event&) {}
};

// The smallest orbit error the identifiability judgement takes as noise: 10 nm, a decade below
// what a proximity probe resolves, so that noise-free data cannot make every parameter look
// identifiable.
inline constexpr double kOrbitNoiseFloor = 1e-8;  // m

// `start`: linear part, clearance and the law's starting values. Dwells need their forces
// computed (for the initial velocities) with the same linear part.
// input_error unless every name in `fit` is one the re-identification fits (a did-you-mean for a
// near miss): checked before any work (identify), not after the identification.
void check_reid_fit(const std::vector<std::string>& fit);

reid_result reidentify(const std::vector<dwell_forces>& dwells, const parameters& start, double unbalance_phase,
                       const reid_settings& s);

}  // namespace rubref
