#pragma once
// `rubref loop` (docs/loop.md): from measured records to the effects the paper's model lacks.
// run_loop is the sequence of the stages, each in its own file:
//   1. preprocess.hpp  the dwells: timed, noise estimated, screened, contact marked
//   2. paper_fit.hpp   the paper's model: staged start, then every coordinate on every dwell's
//                      orbit (predictor.hpp: the model's periodic orbits; fit.hpp: the fits)
//   3. trace.hpp       the residual traced to library effects (search.hpp: profiles, dip search)
//   4. residuals.hpp   errors, spectrum and validity before and after; report.hpp: the report

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "ref/format/record.hpp"
#include "ref/inference/verdict.hpp"
#include "ref/loop/fit.hpp"
#include "ref/loop/preprocess.hpp"
#include "ref/loop/residuals.hpp"
#include "ref/loop/trace.hpp"

namespace rubref {

struct loop_settings : trace_settings {
  double mass = default_of("loop", "mass");            // kg; 0: the records' m_kg metadata, else the paper's
  double clearance = default_of("loop", "clearance");  // m, for records without clearance_m (0: the records' own)
  // The verdict's check (docs/loop.md, "The verdict's check"): the whole loop again with every orbit tolerance
  // this many times the fit's; an effect the two do not both name is tentative (0: no check).
  double check_tolerance_scale = default_of("loop", "check_tolerance_scale");
  // input_error naming the setting, its range and its reason (the trace's too).
  void validate() const;
};

struct dwell_error {
  std::string record;
  double rpm = 0.0;
  bool contact = false;
  std::size_t samples = 0;
  std::string orbit;                             // how the final model's orbit was found: periodic or transient
  int periods = 1;                               // revolutions after which the dwell repeats
  double rms_before = 0.0, rms_after = 0.0;      // m
  double nrmse_before = 0.0, nrmse_after = 0.0;  // rms / rms of the measured orbit about its mean
};

struct spectrum_by_order {
  std::vector<int> orders;            // -H..H (negative: backward whirl)
  std::vector<double> before, after;  // m, RMS over contact dwells of |c_k|
};

struct loop_result {
  std::vector<loop_dwell> dwells;
  double noise = 0.0;
  std::string mass_source;
  model_point initial, before, after;       // staged fit, paper model refined, final
  std::optional<parameters> initial_weak_form;  // the staged fit with the weak form's own law (staged_start)
  std::vector<start_outcome> starts;        // the before-fit's starts
  std::string start_winner;                 // the one its best fit came from
  bool start_tie = false;                   // fits alike within their uncertainty: the first start in order won
  std::vector<std::string> notes;
  std::vector<std::string> warnings;        // estimates that are unphysical or outside the library's ranges (also on stderr)
  double error_before = 0.0, error_after = 0.0;
  std::vector<loop_step> effects;            // in the final model, in the order added: claimed or tentative as `decision` says
  // What is claimed, by the evidence rules' claim rule (ref/inference/evidence.hpp): the effects
  // named ("full": the residual is noise; "partial": they remove claim_share of the before-fit's
  // synchronous excess, the rest unexplained), tentative, or none; explained_share is of that excess.
  verdict decision;
  std::vector<removed_effect> removed;
  std::vector<effect_candidate> last_round;  // the round that added nothing (if any)
  double explained_share_uncertainty = 0.0;  // decision.explained_share's numerical uncertainty
  std::vector<std::string> on_margin;        // effects decided within their statistics' numerical uncertainty (trace_result::on_margin)
  std::optional<verdict_check> check;        // none when check_tolerance_scale is 0
  std::size_t model_evaluations = 0;          // of every dwell's orbits on all dwells (the loop's cost; out-of-sample ones apart)
  std::size_t sensitivity_evaluations = 0;    // of every dwell's orbit sensitivities (a Jacobian's, orbit_predictor::harmonic_columns)
  validity_report validity_before, validity_after;
  std::vector<dwell_error> errors;
  std::vector<excluded_dwell> excluded;     // left out of the fit, with the reason
  spectrum_by_order spectrum;
  // For the report's plots: the contact dwell with the largest error before, as model and data.
  std::size_t plot_dwell = 0;
  std::vector<double> plot_phase, plot_x, plot_y, plot_x_before, plot_y_before, plot_x_after, plot_y_after;
};

// Records with their names. input_error for unusable data (e.g. fewer than two speeds without
// contact). Every dwell left out is in `excluded` with its reason, and reported on `progress`.
loop_result run_loop(const std::vector<std::pair<record, std::string>>& records, const loop_settings& s);

// The verdict's check applied to the loop's result `out`: its verdict `check` (nullopt: it failed,
// `failure` says how). Where the two name other effects, nothing is claimed and the effects either
// chose are tentative, with the reason. run_loop calls it; it is here for its tests.
void apply_check(loop_result& out, std::optional<verdict> check, const std::string& failure, const loop_settings& s);

}  // namespace rubref
