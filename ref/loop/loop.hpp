#pragma once
// `rubref loop` (docs/loop.md): from measured records to the effects the paper's model lacks.
//  1. fit the paper's model: linear part on the dwells without contact, the identified law's
//     terms by FROLS, then every coordinate together by output error (Levenberg-Marquardt on the
//     orbits of all dwells): the "before" model
//  2. residuals: orbit error per dwell, its full spectrum by shaft order, its dependence on the
//     state, and validity tests (noise level, synchronous part, whiteness)
//  3. trace: score every library effect by the error reduction ratio of its linearised regressors
//     on the residual; refit the best few with the effect; keep the one that lowers BIC most if it
//     passes the significance rule; repeat until the residual is noise or nothing passes
//  4. report: error before and after, the effects in order, `unexplained`

#include <algorithm>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "ref/loop/fit_model.hpp"
#include "ref/record.hpp"

namespace rubref {

struct loop_settings {
  double mass = 0.0;             // kg; 0: the records' m_kg metadata, else the paper's
  double clearance = 0.0;        // m, for records without clearance_m
  int max_effects = 4;           // trace rounds
  int refit_candidates = 3;      // effects refitted per round (best linearised scores)
  // Significance rule: BIC must fall by more than this (Kass & Raftery 1995: > 10 is very strong
  // evidence) and the effect must remove at least this share of the synchronous excess: the energy
  // of the residual's shaft orders -orders..orders above what noise alone puts there.
  double min_bic_drop = 10.0;
  double min_excess_share = 1.0 / 3.0;
  int orders = 20;               // shaft orders of the residual spectrum and the synchronous test
  int whiteness_lags = 20;
  int max_fit_evaluations = 60;  // per Levenberg-Marquardt fit
  std::function<void(const std::string&)> progress = [](const std::string&) {};
};

struct correlation_check {
  std::string name;
  double value = 0.0, limit = 0.0;
  bool pass = false;
};

// Is the residual noise? Each check is a statistic against its limit at a 0.1 % false-alarm rate.
struct validity_report {
  double noise = 0.0;                  // m, probe noise estimated from the data (4th differences, MAD)
  double rms = 0.0;                    // m, residual RMS over all samples
  correlation_check noise_level;       // rms / noise
  correlation_check synchronous;       // chi^2 / dof of shaft orders -H..H of the residual
  correlation_check whiteness;         // Box-Pierce Q / dof over lags 1..L
  std::vector<correlation_check> state;  // correlation of the residual with z+, z_dot, x, cos, sin of the shaft angle
  bool pass = false;
};

struct dwell_error {
  std::string record;
  double rpm = 0.0;
  bool contact = false;
  std::size_t samples = 0;
  double rms_before = 0.0, rms_after = 0.0;      // m
  double nrmse_before = 0.0, nrmse_after = 0.0;  // rms / rms of the measured orbit about its mean
};

struct excluded_dwell {
  std::string record;
  double rpm = 0.0;
  bool contact = false;
  double spread = 0.0;  // m, RMS deviation of its revolutions from their mean
};

struct effect_candidate {
  std::string name;
  double score = 0.0;        // ERR on the residual of its linearised regressors (or secants to trial values)
  bool refitted = false;
  double bic_drop = 0.0;     // BIC before - BIC after the refit (positive: better)
  double excess_share = 0.0; // of the synchronous excess (shaft orders above their noise energy), removed by the refit
  double error_after = 0.0;  // NRMSE over contact dwells after the refit
};

struct loop_step {
  std::string effect;
  std::vector<std::pair<std::string, double>> params;  // the library's keys and SI values
  std::vector<std::string> held;                       // shape parameters held at the library's values
  double error_after_adding = 0.0;
  double bic_drop = 0.0, excess_share = 0.0;
  std::vector<effect_candidate> candidates;            // the round's scores, best first
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
  std::vector<std::string> notes;
  double error_before = 0.0, error_after = 0.0;
  std::vector<loop_step> effects;
  std::vector<effect_candidate> last_round;  // the round that added nothing (if any)
  bool unexplained = false;
  validity_report validity_before, validity_after;
  std::vector<dwell_error> errors;
  std::vector<excluded_dwell> excluded;     // not synchronous: left out of the fit
  spectrum_by_order spectrum;
  // For the report's plots: the contact dwell with the largest error before, as model and data.
  std::size_t plot_dwell = 0;
  std::vector<double> plot_phase, plot_x, plot_y, plot_x_before, plot_y_before, plot_x_after, plot_y_after;
};

// The steps, for tests and for other front ends.
// Probe noise (m) from the data: median absolute 4th difference, scaled for Gaussian noise.
double estimate_noise(const std::vector<loop_dwell>& dwells);
// Re-bases a dwell's times on its keyphasor (t = 0 at a notch passage) and sets its timing
// uncertainty; notes what it cannot do.
void align_by_keyphasor(loop_dwell& d, std::vector<std::string>& notes);
// The linear part of Eq. 1 from the dwells without contact (harmonic balance on their 1X).
parameters fit_linear_harmonic(const std::vector<loop_dwell>& dwells, double mass);
// RMS per probe of orders |k| >= 3 of one averaged revolution (contact's fingerprint).
double high_order_content(const dwell& cycle);
// Energy of a residual's shaft orders -orders..orders, sum over dwells of n |c_k|^2 (m^2) with
// c_k the mean of (r_x + i r_y) e^{-i k psi}, and its expectation under noise alone, sigma^2 dof
// (n |c_k|^2 / sigma^2 ~ chi^2(2) per order and dwell): the synchronous check and the trace's
// share rule measure this.
struct synchronous_energy {
  double energy = 0.0, dof = 0.0;
  double excess(double noise) const { return std::max(energy - noise * noise * dof, 0.0); }
};
synchronous_energy synchronous_part(const std::vector<loop_dwell>& dwells, const orbit_predictor& pr, const model_point& m,
                                    const Eigen::VectorXd& r, int orders);

// Records with their names. input_error for unusable data (e.g. fewer than two speeds without contact).
loop_result run_loop(const std::vector<std::pair<record, std::string>>& records, const loop_settings& s);

nlohmann::ordered_json to_json(const loop_result& r);
std::string to_markdown(const loop_result& r);
// Data for scripts/plot_loop.py.
nlohmann::ordered_json plot_data(const loop_result& r);

}  // namespace rubref
