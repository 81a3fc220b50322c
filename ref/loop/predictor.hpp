#pragma once
// Stage 2 of `rubref loop` (docs/loop.md): what the model predicts the probes read. The model is
// the paper's rotor with the identified law (Eq. 1, 2, 5) plus any set of the library's effects
// (`rotor_with_effects`, ref/model/rotor_model.hpp), seen through probes that may be turned and read a
// runout (ref/rig/probes.hpp).
//
// Every dwell is taken as steady and synchronous: its orbit repeats each revolution. The model's
// orbit is therefore its periodic orbit (Newton shooting on one revolution), read at each sample's
// shaft phase. Phases come from the keyphasor: a dwell's times are re-based so that t = 0 is a
// notch passage, and a small per-dwell timing correction (`shift`, one of the fit's coordinates,
// held near 0 by the keyphasor's own resolution) takes up what the pulses cannot resolve.
//
// Where Newton finds no periodic orbit the model runs a transient from the measured state
// instead; where that fails too, the prediction fails, and says so: a failed dwell never becomes
// a number inside a residual (the fit rejects such a point, the loop leaves such a dwell out).

#include <Eigen/Dense>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "ref/integrate/hybrid_integrator.hpp"
#include "ref/loop/preprocess.hpp"
#include "ref/model/effects.hpp"
#include "ref/model/parameters.hpp"
#include "ref/model/rotor_model.hpp"
#include "ref/orbits/fit_orbits.hpp"
#include "ref/rig/probes.hpp"
#include "variants/identified.hpp"

namespace rubref {

// One point of the fit: the rotor, the effects, and each dwell's timing correction.
struct model_point {
  parameters p;                  // delta is taken per dwell from its record
  effect_parameters fx;
  std::vector<double> shift;     // s, per dwell
};

// Time within the revolution, in [0, period): where a sample at time tau falls on the periodic orbit.
double phase_in_period(double tau, double period);

// The periodic orbits an evaluation found, as each dwell's state at t = 0 (none where the dwell
// took a transient or failed): where the next evaluations start their Newton iterations.
using orbit_anchors = std::vector<std::optional<std::array<double, 6>>>;

// How the model's orbit in a dwell was obtained.
enum class orbit_kind { periodic, transient, failed };
std::string_view to_string(orbit_kind k);

// Model probe readings against the dwells. Residuals are laid out dwell after dwell, x then y per
// sample, followed by one prior row per dwell with a keyphasor: noise * shift / timing_sigma.
class orbit_predictor {
 public:
  orbit_predictor(const std::vector<loop_dwell>& dwells, double noise, const fit_orbit_options& orbits = {});
  // How its orbits are shot and sampled (ref/orbits/fit_orbits.hpp).
  const fit_orbit_options& orbit_options() const { return orbits_; }

  std::size_t rows() const { return rows_; }
  std::size_t orbit_rows() const { return orbit_rows_; }
  // Row offset of dwell k's samples.
  std::size_t offset(std::size_t k) const { return offsets_[k]; }

  // Model minus measured at every sample (rubref's sign), or nothing if the model's orbit could
  // not be computed in some dwell (then kinds() names them).
  std::optional<Eigen::VectorXd> residuals(const model_point& m);
  // How many residuals() calls this predictor has made (the loop's cost: each shoots every dwell).
  std::size_t evaluations() const { return evaluations_; }
  // Per dwell, how the last residuals() call got its orbit.
  const std::vector<orbit_kind>& kinds() const { return kinds_; }
  // The derivative of every residual with respect to each dwell's shift (columns by dwell).
  Eigen::MatrixXd shift_columns(const model_point& m);
  // The model's state at each sample of dwell k (after a successful residuals() call at m).
  const std::vector<std::array<double, 6>>& states(std::size_t k) const { return caches_[k].states; }

  // Every evaluation shoots from the anchor: the periodic orbits found at one point (from the
  // data's states), so that the residual is a function of the parameters alone, not of the order
  // in which a fit visits them. anchor(m) evaluates m from the data and keeps its orbits.
  void anchor(const model_point& m);
  // The same from given orbits (from the data where there is none): where several orbits coexist,
  // the one a fit has followed.
  void anchor(const model_point& m, const orbit_anchors& from);
  void reset();  // no anchor: every dwell from its data
  // The orbits the last residuals() call found.
  orbit_anchors last_orbits() const;

 private:
  struct cache {
    bool started = false;
    std::array<double, 6> start{};      // the anchor: a periodic orbit's state at t = 0
    std::vector<double> phase;          // sorted sample phases (s in [0, T)) for the current shift
    std::vector<std::size_t> order;     // sample index of each sorted phase
    bool sorted = false;                // phase and order hold the samples for sorted_shift
    double sorted_shift = 0.0, sorted_period = 0.0;
    std::vector<std::array<double, 6>> states;  // model state at each sample (sample order)
    std::array<double, 6> last{};       // the last converged orbit's state at t = 0
    bool last_ok = false;
    std::optional<std::array<double, 4>> in_data;  // the data's state at t = 0 (x, y, vx, vy), once fitted
  };
  const std::array<double, 4>& data_state(std::size_t k);
  orbit_kind predict(std::size_t k, const model_point& m);
  enum class shot { converged, failed };
  shot shoot(std::size_t k, const model_point& m, const rotor_with_effects<identified>& sys, double period, const sample_grid& grid);

  const std::vector<loop_dwell>& dwells_;
  double noise_;
  fit_orbit_options orbits_;
  std::vector<cache> caches_;
  std::vector<orbit_kind> kinds_;
  std::vector<std::size_t> offsets_;
  std::size_t rows_ = 0, orbit_rows_ = 0;
  std::size_t evaluations_ = 0;
};

}  // namespace rubref
