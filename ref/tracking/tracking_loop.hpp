#pragma once
// `rubref loop TABLE` on an order-tracked table (docs/real-data.md): the base fit (an isotropic
// rotor's one critical speed, the unbalance, each probe's runout; ref/tracking/response_fit.hpp),
// every combination of the effects a 1X table can show (anisotropy: two critical speeds;
// shaft_bow; cross_coupling) fitted, the one with the lowest BIC of those whose every part the
// table determines and whose every effect is needed (the waveform loop's evidence rules), the
// errors before and after, and where in speed the residual that is left lies.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "ref/format/order_table.hpp"
#include "ref/tracking/response_fit.hpp"
#include "ref/tracking/rub_fit.hpp"
#include "ref/tracking/two_x_fit.hpp"

namespace rubref {

// One combination of the effects, fitted with every coordinate free, and what the rules say of it.
struct tracked_model {
  std::vector<std::string> effects;  // in the library's order (anisotropy, shaft_bow, cross_coupling)
  double chi2 = 0.0, bic = 0.0;
  std::string undetermined;          // "" when every part is determined (the plausibility rule), else what is not
  std::string estimates;             // its effects' parameters with their 95 % intervals, one line
  // Per effect in it: the model without that effect against this one.
  struct need {
    std::string effect;
    double bic_rise = 0.0;                        // BIC without it minus with it
    std::vector<double> held_out_without, held_out_with;  // chi^2 of each fold's held-out rows
    double held_out_gain = 0.0;
    bool needed = false;
  };
  std::vector<need> needs;
  bool eligible = false;             // plausible, and every effect in it needed
  std::string verdict;               // one line
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
  std::string claim = "none";            // as tracking_result::claim, for the 2X
  double remaining_share = 0.0;
  bool unexplained = false;
  std::vector<double> noise_scatter_m, noise_residual_m;
  std::string verdict;                   // one line
  const two_x_fit& after() const { return named ? with : before; }
};

// The rub (tried when the chosen contact-free model leaves a residual that is not noise and every
// probe's angle is declared): that model with the paper's contact at the top, fitted whole
// (ref/tracking/rub_fit.hpp) and judged against it by the same rules.
struct rub_result {
  rub_fit fit;
  std::string undetermined;              // "" when its clearance and modes are determined
  tracked_model::need need;              // the rub against the chosen contact-free model
  bool named = false;
  std::string verdict;                   // one line
};

struct tracking_result {
  order_table table;
  response_fit before;                   // the base fit
  response_fit after;                    // with the contact-free effects added (the rub's fit, when named, is in `rub`)
  std::vector<std::string> effects;      // claimed: the contact-free ones in the library's order, then rub, then misalignment_2x
  std::vector<std::string> tentative;    // chosen but not claimed (the residual stays far from the noise)
  std::vector<tracked_model> models;     // every combination, the base first
  double error_before = 0.0, error_after = 0.0;  // m, RMS residual per component
  // The 1X's claim: "full" (the residual is noise), "partial" (effects named, the residual is not noise but they
  // removed 96 % of the base fit's excess: the remaining share is said), "tentative" (added, not
  // claimed, or another combination explains the table alike: `rival`), "none" (nothing added;
  // unexplained unless the base fit is noise).
  std::string claim = "none";
  double remaining_share = 0.0;          // of the base fit's chi^2 excess over its dof, left after
  std::string rival;                     // an eligible combination of other effects within 10 of the chosen one's BIC (then "tentative")
  bool unexplained = false;              // the 1X's or the 2X's residual is not noise and no claim covers it
  std::optional<rub_result> rub;         // when tried
  std::optional<two_x_result> two_x;     // when the table has a 2X column for every probe
  std::vector<residual_band> bands;      // 1X and 2X
  std::vector<double> noise_scatter_m, noise_residual_m;  // per probe: the two noise estimates; the fits use the smaller
  std::vector<std::string> cannot_see;   // what such a table cannot show
  std::vector<std::string> notes;
};

tracking_result run_tracking_loop(const order_table& table, const std::function<void(const std::string&)>& progress = {});

}  // namespace rubref
