#pragma once
// `rubref identify`: the paper's §4 from measurement records (docs/identification.md).
//  1. split records into dwells; a dwell is in contact if any sample has y > clearance
//  2. the linear part of Eq. 1: given (--linear), or fitted on the dwells without contact
//  3. contact forces at every sample (Eq. 1 inverted), friction mu per speed (Fig. 5)
//  4. FROLS on f_N with the candidate library (Eq. 3-4, Tables 1-2): on the contact samples
//     (the paper's route: standard errors, an episode bootstrap, residual correlation tests) or
//     on the weak form's integrals (no acceleration from the data; for noisy records), chosen
//     from the probe noise the data show
//  5. on the weak route, the law refined by the averaged cycles' periodic orbits (orbit_fit.hpp)
//  6. optionally, output-error re-identification with NLopt

#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ref/identification/contact_forces.hpp"
#include "ref/identification/dwells.hpp"
#include "ref/identification/frols.hpp"
#include "ref/identification/orbit_fit.hpp"
#include "ref/identification/output_error.hpp"
#include "ref/identification/validity.hpp"
#include "ref/identification/weak_form.hpp"
#include "ref/inference/verdict.hpp"
#include "ref/model/parameters.hpp"

namespace rubref {

// How the contact law is regressed (docs/identification.md §5).
//  - samples: f_N at every contact sample from Savitzky-Golay second derivatives (the paper's).
//  - weak_form: Eq. 1 integrated against test functions around each contact episode
//    (ref/identification/weak_form.hpp): no second derivative of data.
//  - automatic: samples when the probe noise's share of f_N's variance on the samples route is
//    below 0.1 %, a tenth of the paper's rho (the noise cannot pass for a term), else the weak form.
enum class law_method { automatic, samples, weak_form };
std::string_view to_string(law_method m);
law_method parse_law_method(const std::string& name);  // input_error if unknown

// Synchronous averaging of the dwells that touch (docs/identification.md, "Averaging"):
//  - automatic: every steady dwell (2 or more whole revolutions that differ from their mean by at
//    most twice the dwell's own noise), each decision and its reason reported per dwell
//  - always: every dwell with a whole revolution, steady or not
//  - never: none
enum class averaging { automatic, always, never };
std::string_view to_string(averaging a);
averaging parse_averaging(const std::string& name);  // input_error if unknown

struct identify_settings {
  std::optional<parameters> linear;      // the linear part (m, c, k, e, unbalance phase) if known; else fitted
  // Numeric settings: defaults, ranges and reasons in the settings registry (scopes "identify",
  // "derivatives", "weak_form", "frols", "orbit_fit", "reidentify").
  double mass = default_of("identify", "mass");            // kg, when the linear part is fitted (m is not identifiable)
  double clearance = default_of("identify", "clearance");  // m, for records without clearance_m metadata (0: required there)
  linear_method linear_route = linear_method::harmonic;  // how a fitted linear part is found
  derivative_settings derivative;
  averaging average = averaging::automatic;  // synchronous averaging of the dwells that touch
  law_method law_route = law_method::automatic;
  weak_form_settings weak;
  // The weak form's law refined by the averaged cycles' periodic orbits (orbit_fit.hpp), when it
  // lies in Eq. 5's family (k1 z, k3 z^3, c2 z_dot^2): on by default, off for the weak form alone.
  bool orbit_fit = true;
  // The law's structure chosen by the orbit fit among Eq. 5's family (refine_by_orbits, §5
  // "Structure"); off: the weak form's own selection is refined.
  bool compare_structures = true;
  orbit_fit_settings orbit;
  std::string library = "z1..4,zd1..4";  // Eq. 4, L = 4
  frols_settings frols;
  int bootstrap = default_count_of("identify", "bootstrap");  // resamples of whole contact episodes (0: none)
  unsigned seed = static_cast<unsigned>(default_of("identify", "seed"));  // for the bootstrap: same inputs, same intervals
  int correlation_lags = default_count_of("identify", "correlation_lags");
  parameters reference;                  // the law whose term shares are reported (Table 2)
  bool reidentify = false;
  reid_settings reid;
  // input_error naming the first setting out of its range (and an unknown --reid-fit name), before
  // any work.
  void validate() const;
};

struct term_estimate {
  std::string name, pretty;
  double value, standard_error;  // in N per unit of the term (k1: N/m, c2: kg/m, ...)
  double ci_low, ci_high;        // 95 % interval: episode bootstrap (samples route; NaN without),
                                 // Student t on the whitened rows (weak form)
};

struct term_share {
  std::string term;
  double peak_share;  // max over samples of |term contribution| / max f_N
};

struct dwell_report {
  double rpm, clearance;
  dwell_noise noise;                       // this dwell's own (estimate_dwell_noise)
  int averaged_revolutions = 0;            // 0: not averaged
  double average_spread = 0.0;             // m, RMS deviation of the revolutions from their mean (also when not averaged)
  std::string averaging;                   // the decision and the reason tested for it
  std::size_t samples, contact_samples, episodes;
  double max_penetration;                  // m
  std::optional<friction_estimate> friction;
  std::vector<term_share> reference_shares;   // the reference law on these z, z_dot
  std::vector<term_share> identified_shares;  // the identified law on these z, z_dot
};

// The weak form's fit (law_method::weak_form).
struct weak_form_report {
  std::size_t rows = 0, episodes = 0;
  double noise = 0.0;           // m, the whitened rows' noise standard deviation (sample noise)
  double residual_rms = 0.0;    // m, of the whitened rows after the kept terms
  double chi2_per_dof = 0.0;    // residual variance per dof over what the noise leaves (the rows' noise, or
                                // more where the regressors' noise adds): ~1 if only noise is left
  double chi2_limit = 0.0;      // its 99.9 % quantile under noise alone
};

// One law structure within Eq. 5's family, fitted to the averaged cycles' orbits (§5, "Structure").
struct structure_candidate {
  std::vector<std::string> terms;  // library names, e.g. {"z1", "zd2"}
  bool fitted = false;             // the orbit fit ran (a start from the weak form > 0 for every term)
  bool converged = false;
  double chi2_per_dof = std::numeric_limits<double>::quiet_NaN();
  double bic = std::numeric_limits<double>::quiet_NaN();  // chi^2 + unknowns ln(residuals)
  std::string status;              // the fit's, or why it did not run
};

struct identification {
  linear_part linear;
  std::string linear_source;             // "given" or "fitted"
  std::optional<linear_fit> linear_fitted;
  std::vector<dwell_report> dwells;
  double mu_mean = 0.0, mu_spread = 0.0;  // mean and standard deviation of the per-speed means
  double mu_slope = 0.0;                  // pooled least squares f_x = mu f_N
  double mu = 0.0;                        // the estimate: mu_mean (samples, the paper's Fig. 5) or mu_slope (weak form)
  double mu_standard_error = std::numeric_limits<double>::quiet_NaN();
  law_method law_route = law_method::samples;  // the route taken
  std::string law_route_reason;
  std::optional<weak_form_report> weak;
  // The orbit fit, when it ran; the estimates and mu above are its values when it converged, and
  // the weak form's (kept here as its start) otherwise.
  std::optional<orbit_fit_result> orbit;
  // The structures the orbit fit compared, lowest BIC first, and what chose the one reported.
  std::vector<structure_candidate> structures;
  // The verdict on the structure chosen (ref/inference/verdict.hpp: the terms named, the claim,
  // the rival within min_criterion_rise, the reason), when the orbit fit compared structures.
  std::optional<verdict> structure;
  bool phases_searched = false;     // the orbit fit found the touching dwells' forcing phases by search (not the linear part's)
  std::vector<term_estimate> weak_estimates;
  double weak_mu = std::numeric_limits<double>::quiet_NaN(), weak_mu_standard_error = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::string> notes;         // what was done to the data (keyphasor timing, averaging)
  std::vector<std::string> candidates, candidates_pretty;
  std::vector<double> first_step_err;     // each candidate alone: (p'y)^2 / (p'p y'y)
  std::vector<double> paper_order_err;    // ERR in the order of the paper's Table 1 ranking, when
                                          // the library is Eq. 4's (z^3, z, z_dot^2, z^2, z_dot, z_dot^3, z^4, z_dot^4); else empty
  frols_stop stop = frols_stop::err_sum;  // the stopping rule used (the weak form's: significance)
  frols_result frols;
  std::vector<term_estimate> estimates;   // the kept terms
  double residual_rms = 0.0;              // N
  double force_rms = 0.0;                 // N, of f_N over the contact samples
  std::size_t contact_samples = 0, episodes = 0;
  std::vector<correlation_test> validity;
  std::optional<reid_result> reid;
  double probe_noise = 0.0;               // m, RMS over the touching dwells of their own noise (dwell_report::noise)
  std::vector<dwell_noise> free_noise;    // the contact-free dwells' own noise, in linear_fitted's order
  // Every estimate that is unphysical, undetermined or failed a check, one line each; the CLI
  // prints them as `warning:` lines and identification.json lists them. Never silent.
  std::vector<std::string> warnings;
};

// Records with their names (for messages). Throws input_error on anything unusable.
identification identify(const std::vector<std::pair<record, std::string>>& records, const identify_settings& s);
// The same on dwells already split (each with its clearance), e.g. re-timed by a keyphasor.
identification identify(const std::vector<dwell>& dwells, const identify_settings& s);

}  // namespace rubref
