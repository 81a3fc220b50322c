#pragma once
// `rubref loop TABLE` on an order-tracked table (docs/real-data.md): the base fit (an isotropic
// rotor's one critical speed, the unbalance, each probe's runout; ref/tracking/response_fit.hpp),
// every combination of the effects a 1X table can show (anisotropy: two critical speeds;
// shaft_bow; cross_coupling; a rub) fitted, the one with the lowest information criterion of
// those whose every part the table determines and whose every effect is needed, by the evidence
// rules every wing uses (ref/inference/evidence.hpp), the verdict, the errors before and after,
// and where in speed the residual that is left lies.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "ref/format/order_table.hpp"
#include "ref/inference/verdict.hpp"
#include "ref/tracking/response_fit.hpp"
#include "ref/tracking/rub_fit.hpp"
#include "ref/tracking/two_x_fit.hpp"

namespace rubref {

// One combination of the effects, fitted with every coordinate free, and what the rules say of it.
struct tracked_model {
  std::vector<std::string> effects;  // anisotropy, then the effect library's (shaft_bow, cross_coupling), then rub
  double chi2 = 0.0, bic = 0.0;      // bic: the information criterion (ref/inference/evidence.hpp)
  double chi2_uncertainty = 0.0;     // chi2's numerical uncertainty (the fit's unfinished descent, its orbits' error)
  std::string undetermined;          // "" when every part is determined (the plausibility rule), else what is not
  std::string estimates;             // its effects' parameters with their 95 % intervals, one line
  // Per effect in it: the model without that effect against this one.
  struct need {
    std::string effect;
    double bic_rise = 0.0;                        // the criterion without it minus with it
    double excess_share = 0.0;                    // of the chi^2 excess without it that it removes
    std::vector<double> held_out_without, held_out_with;  // chi^2 of each fold's held-out rows
    double held_out_gain = 0.0;
    bool needed = false;
    bool on_margin = false;                       // decided within its statistics' numerical uncertainty (ref/inference/evidence.hpp)
    std::string reason;                           // the evidence rule's words
  };
  std::vector<need> needs;
  bool eligible = false;             // plausible, and every effect in it needed
  std::string summary;               // one line: its fit against the rules
};

// A stretch of speed where the final residual is not noise.
struct residual_band {
  std::string probe;
  int order = 1;
  double from_rpm = 0.0, to_rpm = 0.0;
  std::size_t rows = 0;
  double rms_over_noise = 0.0;
};

// The 2X columns (a table with one for every probe): each probe's 2X runout alone, against it
// with a misalignment's forced 2X through the chosen 1X modes, judged by the same rules.
struct two_x_result {
  two_x_fit before;                      // runout only
  two_x_fit with;                        // with the misalignment
  std::string undetermined;              // "" when the misalignment fit's every part is determined
  tracked_model::need need;              // the misalignment against the runout alone
  bool named = false;                    // needed and plausible: the 2X model is `with`
  verdict decision;                      // the 2X's, by the claim rule (misalignment_2x named, tentative or none)
  std::vector<double> noise_scatter_m, noise_residual_m;
  std::string summary;                   // one line
  const two_x_fit& after() const { return named ? with : before; }
};

// The rub (tried when the chosen contact-free model leaves a residual that is not noise and every
// probe's angle is declared): that model with the paper's contact at the top, fitted whole
// (ref/tracking/rub_fit.hpp) and judged against it by the same rules.
struct rub_result {
  rub_fit fit;
  std::string undetermined;              // "" when its clearance and modes are determined
  tracked_model::need need;              // the rub against the chosen contact-free model
  std::vector<tracked_model::need> form_needs;  // the rub's form's terms tried (law's k3, c2, the stator's direction), each against the form without it
  bool named = false;
  std::string summary;                   // one line
};

struct tracking_result {
  order_table table;
  response_fit before;                   // the base fit
  response_fit after;                    // with the contact-free effects added (the rub's fit, when named, is in `rub`)
  std::optional<response_fit> steady;    // where `after` is swept: the steady fit of the same effects (its bias, the figure)
  std::vector<tracked_model> models;     // every combination, the base first
  double error_before = 0.0, error_after = 0.0;  // m, RMS residual per component
  // The 1X's verdict (the claim rule, ref/inference/evidence.hpp): the effects chosen among the
  // combinations, claimed "full" (the residual is noise) or "partial" (not noise, but they remove
  // claim_share of the base fit's chi^2 excess), or "tentative" (too little removed, or another
  // eligible combination within min_criterion_rise of the chosen one's criterion: the rival), or
  // "none". The 2X's is two_x->decision: the columns are fitted apart.
  verdict decision;
  std::optional<verdict_check> check;    // the verdict's check, when the rub was tried (and the check is on)
  std::optional<rub_result> rub;         // when tried
  std::optional<two_x_result> two_x;     // when the table has a 2X column for every probe
  std::vector<residual_band> bands;      // 1X and 2X
  std::vector<double> noise_scatter_m, noise_residual_m;  // per probe: the two noise estimates; the fits use the smaller
  std::vector<std::string> cannot_see;   // what such a table cannot show
  std::vector<std::string> notes;

  // The 1X's and the 2X's verdicts side by side: every effect claimed, every one tentative, and
  // whether either leaves something unexplained.
  std::vector<std::string> named() const;
  std::vector<std::string> tentative() const;
  bool unexplained() const;
};

// The loop's settings: the rub fits' orbits, and the verdict's check (docs/loop.md, "The verdict's
// check"): where the rub is tried, its fits again with every orbit tolerance check_tolerance_scale
// times these (0: no check), an effect the two do not both name tentative.
struct tracking_settings {
  fit_orbit_options orbits = {};
  double check_tolerance_scale = default_of("loop", "check_tolerance_scale");
  // The revolutions each row's 1X was read over (the sweep_transient's block), where the table's
  // maker says; 0: fitted among kSweepRevolutions.
  double revolutions_per_row = 0.0;
  // The sweep's rate (rpm/s) where the table's maker says; 0: from the table's time_s column where
  // it has one (sweep_of_times), else fitted.
  double sweep_rate_rpm_per_s = 0.0;
};

tracking_result run_tracking_loop(const order_table& table, const std::function<void(const std::string&)>& progress = {},
                                  const tracking_settings& settings = {});

}  // namespace rubref
