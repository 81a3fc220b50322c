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

  friend bool operator==(const model_point&, const model_point&) = default;
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
//
// The same comparison is also made in harmonics (docs/loop.md, "Comparing in harmonics"): a dwell's
// model orbit repeats every period T, so its readings are a Fourier series in the harmonics of
// 2 pi / T. Up to the band's last harmonic H, |d - B a|^2 = |d - B a_d|^2 + |L^T (a - a_d)|^2 exactly,
// where B holds the harmonics at the sample times, G = B^T B = L L^T their Gram matrix and
// a_d = G^-1 B^T d the data's own least-squares harmonics: the first term is the data's alone, and
// the second needs the model's harmonics only, read from M readings on a uniform grid of one period.
// A fit's search runs on these few rows; every statistic is taken on the samples.
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
  // The comparison in harmonics: rows L^T (a - a_d) per dwell (x then y, each 2 H + 1 rows),
  // then the same prior rows as residuals(). Their |.|^2 plus harmonic_offset() is |residuals()|^2
  // for a model without readings above the band (the band ends at a quarter of a dwell's sampling
  // rate: the Gram matrix of one revolution's samples alone is then well conditioned).
  std::optional<Eigen::VectorXd> harmonic_residuals(const model_point& m);
  // The same with each dwell whose kind in `as` is the transient taking the transient again,
  // without a shot: for a finite difference about a point whose kinds are `as` (kinds()), which
  // must compare like with like (an orbit that converges on one side only is a jump, not a slope)
  // and need not repeat the shots that failed there.
  std::optional<Eigen::VectorXd> harmonic_residuals_as(const model_point& m, const std::vector<orbit_kind>& as);
  std::size_t harmonic_rows();
  // Sum over dwells of |d - B a_d|^2 (m^2): what no model within the band can fit.
  double harmonic_offset();
  // The derivative of harmonic_residuals() with respect to each dwell's shift (columns by dwell):
  // a shift turns harmonic h by h w_T s, exactly. Uses the harmonics of the last harmonic_residuals() call.
  Eigen::MatrixXd harmonic_shift_columns(const model_point& m);
  // The derivative of harmonic_residuals() at m in each of several coordinates, from the orbits'
  // exact sensitivities (ref/integrate/parameter_columns.hpp: one flow per dwell for every column,
  // in place of a shooting per column): up[j] and down[j] are m with coordinate j moved to either
  // side (or one of them m), span[j] apart in that coordinate; the model's and the probes'
  // differences between them at the same states are the sensitivities' sources.
  // Needs the last harmonic_residuals() call at m with every dwell's orbit periodic (harmonics_are_of);
  // a column that cannot be had so in some dwell (the move changes which states move: a stator
  // switched on; a flow that does not close on its orbit; a multiplier at 1) is nothing, and its
  // caller differences it instead.
  std::vector<std::optional<Eigen::VectorXd>> harmonic_columns(const model_point& m, const std::vector<model_point>& up,
                                                               const std::vector<model_point>& down, const std::vector<double>& span);
  // Whether the last harmonic_residuals() call since the last anchor was at m and could be
  // computed: the band's harmonics (harmonic_shift_columns) are then m's, with no new evaluation
  // (an evaluation depends on the anchor and the point alone, so a new one would give the same bits).
  bool harmonics_are_of(const model_point& m) const { return harmonics_of_ && *harmonics_of_ == m; }
  // Harmonics H of dwell k's band (of its motion's frequency w / periods).
  int band_harmonics(std::size_t k);
  // The model's reading (x, y) in dwell k at time t and timing shift s, summed from the band's
  // harmonics of the last harmonic_residuals() call: what the comparison in harmonics sees.
  std::array<double, 2> band_reading(std::size_t k, double t, double shift) const;

  // How many residuals() calls this predictor has made (the loop's cost: each shoots every dwell).
  std::size_t evaluations() const { return evaluations_; }
  // How many harmonic_columns() calls gave a column (each one flow of every dwell's sensitivities).
  std::size_t sensitivity_evaluations() const { return sensitivity_evaluations_; }
  // Per dwell, how the last residuals() or harmonic_residuals() call got its orbit.
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
  // Dwell k's harmonic band: the data's side, computed once, and the model's last harmonics.
  struct band {
    int harmonics = 0;                  // H
    double spacing = 0.0;               // T / M
    std::vector<double> grid;           // the M reading phases j T / M (j spacing: sample_grid's uniform times)
    std::vector<std::size_t> identity;  // grid point j is reading j
    Eigen::MatrixXd Lt;                 // G = Lt^T Lt (upper triangular)
    Eigen::VectorXd target_x, target_y; // Lt a_d, per channel
    double offset = 0.0;                // |d - B a_d|^2, both channels
    std::vector<std::array<double, 6>> states;  // the model's state at each grid point
    Eigen::VectorXd ax, ay;             // the model's harmonics at the last call, shift 0
  };
  // The data's side of dwell d's band (the grid's phases for a motion of `periods` revolutions).
  static band harmonic_band(const dwell& d, int periods);
  const std::array<double, 4>& data_state(std::size_t k);
  band& band_of(std::size_t k);
  void prepare_bands();  // every dwell's band and the harmonic rows' layout
  void sort_phases(std::size_t k, double shift, double period);
  std::optional<Eigen::VectorXd> harmonic_residuals(const model_point& m, const std::vector<orbit_kind>* as);
  template <class Fill>
  std::optional<Eigen::VectorXd> evaluate(const model_point& m, bool harmonics, std::size_t rows, Fill&& fill,
                                          const std::vector<orbit_kind>* as = nullptr);
  // The model's orbit in dwell k sampled at the record's phases (harmonics false) or on the band's
  // grid; `transient`: the transient without a shot (harmonic_residuals_as).
  orbit_kind predict(std::size_t k, const model_point& m, bool harmonics, bool transient = false);
  enum class shot { converged, failed };
  // The data's guess after `revolutions` of settling, where a shot started from the data.
  struct settled_guess {
    std::array<double, 6> state;
    int revolutions;
  };
  // Dwell k's guess from its data after the first settle (kFirstSettleRevs, whole periods): where
  // a shot from the data starts, and the transient too.
  settled_guess first_settle(std::size_t k, const model_point& m, const rotor_with_effects<identified>& sys, double period);
  shot shoot(std::size_t k, const model_point& m, const rotor_with_effects<identified>& sys, double period, const sample_grid& grid,
             const std::vector<std::size_t>& order, std::vector<std::array<double, 6>>& states, std::optional<settled_guess>& from_data);

  const std::vector<loop_dwell>& dwells_;
  double noise_;
  fit_orbit_options orbits_;
  std::vector<cache> caches_;
  std::vector<orbit_kind> kinds_;
  std::vector<std::size_t> offsets_;
  std::size_t rows_ = 0, orbit_rows_ = 0;
  std::size_t evaluations_ = 0;
  std::size_t sensitivity_evaluations_ = 0;
  std::vector<std::optional<band>> bands_;
  std::vector<std::size_t> harmonic_offsets_;
  std::size_t harmonic_rows_ = 0;
  std::optional<model_point> harmonics_of_;  // the last harmonic_residuals() call's point (harmonics_are_of)
};

}  // namespace rubref
