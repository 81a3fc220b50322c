#pragma once
// The model the loop fits (docs/loop.md): the paper's rotor with the identified law (Eq. 1, 2, 5)
// plus any set of the library's effects (ref/rig/rig_system.hpp), seen through probes that may be
// turned and read a runout, compared with measured dwells sample by sample.
//
// Every dwell is taken as steady and synchronous: its orbit repeats each revolution. The model's
// orbit is therefore its periodic orbit (Newton shooting on one revolution), read at each sample's
// shaft phase. Phases come from the keyphasor: a dwell's times are re-based so that t = 0 is a
// notch passage, and a small per-dwell timing correction (`shift`, one of the fit's coordinates,
// held near 0 by the keyphasor's own resolution) takes up what the pulses cannot resolve.

#include <Eigen/Dense>
#include <array>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ref/hybrid_integrator.hpp"
#include "ref/identification/dwells.hpp"
#include "ref/parameters.hpp"
#include "ref/rig/effects.hpp"
#include "ref/rig/rig_system.hpp"
#include "variants/identified.hpp"

namespace rubref {

// A measured dwell as the loop uses it.
struct loop_dwell {
  dwell data;                    // t re-based: t = 0 at a notch passage (or as recorded, without keyphasor)
  std::string record;            // the file it came from
  double timing_sigma = std::numeric_limits<double>::infinity();  // s, keyphasor timing uncertainty (inf: none)
  bool contact = false;          // decided from the data: its synchronous average reaches the clearance
};

// One point of the fit: the rotor, the effects, and each dwell's timing correction.
struct model_point {
  parameters p;                  // delta is taken per dwell from its record
  effect_parameters fx;
  std::vector<double> shift;     // s, per dwell
};

// One scalar coordinate of the fit, with the scale it is searched in (value = scale * u).
struct fit_coordinate {
  std::string name;              // e.g. "k1", "hertz_contact.k_h", "shaft_bow.b_cos"
  double scale;
  std::function<double(const model_point&)> get;
  std::function<void(model_point&, double)> set;
  // When the effect enters the orbit so nonlinearly that its linearisation where it is off
  // misleads (the contact's angle, the probes' orientation), the trace also tries it at these values
  // of a trial variable (0: off). `apply` sets the model there; it may also move base
  // coordinates so that the trial keeps what the data already pin.
  struct trial_grid {
    std::vector<double> values;
    std::function<void(model_point&, double)> apply;
  };
  std::optional<trial_grid> trials = {};
  // When the effect adds a lightly damped resonance that still rings when the rotor comes back
  // (a compliant stator), the residual along its coordinate is a comb of narrow dips: the phase of
  // that ringing at the next impact turns with the coordinate. A local fit stays in the dip it
  // starts in (docs/loop.md, stator), so the effect's refit searches instead: a profile over
  // `envelope` values on the staged model with the coordinates named in `profiled` refitted at
  // each, a fit from its best, then hops: the residual along the coordinate within `factor` of
  // the fit's value either way, in relative steps of `step`, with `move` setting each value, and
  // a fit from the lowest other dip while that lands clearly lower (ref/loop/loop.cpp).
  struct dip_search {
    std::vector<double> envelope;
    std::vector<std::string> profiled;
    // Sets the coordinate to a value and keeps what the data already pin (false: it cannot there).
    std::function<bool(model_point&, double)> move;
    double factor = 1.0;
    double step = 0.0;
  };
  std::optional<dip_search> search = {};
};

// Time within the revolution, in [0, period): where a sample at time tau falls on the periodic orbit.
double phase_in_period(double tau, double period);

// The paper's model's coordinates: the linear part (c_x, c_y, k_x, k_y, e, unbalance angle), the
// identified law (k1, k3, c2) and friction (mu), all but the angle as logarithms (they are
// positive). m is given (Eq. 1 scales with it).
std::vector<fit_coordinate> paper_coordinates(const model_point& start);

// The coordinates an effect adds (its switch parameters, amplitude-phase pairs as their two
// Cartesian components so that the fit is smooth through zero; shape parameters are held at the
// library's values) and the point where the effect is off.
std::vector<fit_coordinate> effect_coordinates(const effect_info& e);

// Model probe readings against the dwells. Residuals are laid out dwell after dwell, x then y per
// sample, followed by one prior row per dwell with a keyphasor: noise * shift / timing_sigma.
class orbit_predictor {
 public:
  orbit_predictor(const std::vector<loop_dwell>& dwells, double noise);

  std::size_t rows() const { return rows_; }
  std::size_t orbit_rows() const { return orbit_rows_; }
  // Row offset of dwell k's samples.
  std::size_t offset(std::size_t k) const { return offsets_[k]; }

  // Measured minus model would be the residual's usual sign; rubref uses model minus measured.
  // A point the integrator cannot follow gives residuals of kFailed for its dwells.
  Eigen::VectorXd residuals(const model_point& m);
  // The derivative of every residual with respect to each dwell's shift (columns by dwell).
  Eigen::MatrixXd shift_columns(const model_point& m);
  // The model's readings (x, y) and state at each sample of dwell k (after a residuals() call at m).
  const std::vector<std::array<double, 6>>& states(std::size_t k) const { return caches_[k].states; }

  // Every evaluation shoots from the anchor: the periodic orbits found at one point (from the
  // data's states), so that the residual is a function of the parameters alone, not of the order
  // in which a fit visits them. anchor(m) evaluates m from the data and keeps its orbits.
  void anchor(const model_point& m);
  void reset();  // no anchor: every dwell from its data

  static constexpr double kFailed = 1e-2;  // m: far off any orbit of a 0.3 mm clearance, finite for the fit

 private:
  struct cache {
    bool started = false;
    std::array<double, 6> start{};      // the anchor: a periodic orbit's state at t = 0
    Eigen::MatrixXd inverse_jacobian;   // of the shooting map, reused while it converges (chord Newton)
    std::vector<double> phase;          // sorted sample phases (s in [0, T)) for the current shift
    std::vector<std::size_t> order;     // sample index of each sorted phase
    std::vector<std::array<double, 6>> states;  // model state at each sample (sample order)
    std::array<double, 6> last{};       // the last converged orbit's state at t = 0
    bool last_ok = false;
  };
  bool predict(std::size_t k, const model_point& m);  // false: the integrator failed
  enum class shot { converged, failed };
  shot shoot(std::size_t k, const model_point& m, const rig_system<identified>& sys, double period, const sample_grid& grid, int n);

  const std::vector<loop_dwell>& dwells_;
  double noise_;
  std::vector<cache> caches_;
  std::vector<std::size_t> offsets_;
  std::size_t rows_ = 0, orbit_rows_ = 0;
};

}  // namespace rubref
