#include "ref/tracking/tracking_loop.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <optional>

#include <boost/math/distributions/chi_squared.hpp>

#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"

namespace rubref {

namespace {

// The evidence rules of the waveform loop (docs/loop.md, "Adds"), in the same numbers: an effect
// is needed when BIC without it is higher by more than 10 (very strong evidence, Kass & Raftery
// 1995) and its out-of-sample gain over two folds exceeds 10 and a third of its gain on every
// row; a claim needs the residual at the noise ("full") or 96 % of the base fit's excess removed
// ("partial").
constexpr double kBicDrop = 10.0;
constexpr double kHoldoutGain = 10.0;
constexpr double kHoldoutShare = 1.0 / 3.0;
constexpr double kClaimShare = 0.96;
// Residual bands: the speed range cut into this many stretches, each judged by its chi^2 at a
// 0.1 % false-alarm rate.
constexpr int kBandCount = 50;
// A model whose parts (unbalance response, bow response, runout) are together more than ten
// times what they add up to explains the table by their small differences: a bow and runout are
// both 1X fixed to the shaft and a bow's response is the unbalance's near a critical speed, so
// such terms can cancel almost exactly, and the table cannot pin them (on the RK-4 run-up a
// 110 µm bow against 110 µm of runout and as much unbalance, to read a few µm).
constexpr double kMaxCancellation = 10.0;

// chi^2 of the rows `rows` of a fit's residual (per probe and row), with its noise per probe.
double chi2_of(const std::vector<std::vector<std::complex<double>>>& residual, const std::vector<double>& noise, const std::vector<std::size_t>& rows) {
  double s = 0.0;
  for (std::size_t p = 0; p < residual.size(); ++p)
    for (const std::size_t i : rows) s += std::norm(residual[p][i]) / (noise[p] * noise[p]);
  return s;
}

// BIC with the real coordinates a fit spent (its free nonlinear ones and 2 per amplitude).
double bic(double chi2, std::size_t parameters, std::size_t observations) {
  return chi2 + static_cast<double>(parameters) * std::log(static_cast<double>(observations));
}

std::vector<residual_band> bands_of(const order_table& t, const std::vector<std::vector<std::complex<double>>>& residual, const std::vector<double>& noise,
                                    const std::vector<std::string>& probes, int order) {
  std::vector<residual_band> out;
  const double lo = t.rpm.front(), hi = t.rpm.back(), width = (hi - lo) / kBandCount;
  if (!(width > 0.0)) return out;
  for (std::size_t p = 0; p < residual.size(); ++p) {
    residual_band open;
    bool is_open = false;
    double open_sum = 0.0;
    for (int b = 0; b < kBandCount; ++b) {
      double s = 0.0;
      std::size_t n = 0;
      for (std::size_t i = 0; i < t.rows(); ++i)
        if (t.rpm[i] >= lo + b * width && (t.rpm[i] < lo + (b + 1) * width || (b + 1 == kBandCount && t.rpm[i] <= hi)))
          s += std::norm(residual[p][i]) / (noise[p] * noise[p]), ++n;
      const double dof = 2.0 * static_cast<double>(n);
      const bool high = n > 0 && s > boost::math::quantile(boost::math::chi_squared(dof), 0.999);
      if (high && !is_open) open = {probes[p], order, lo + b * width, lo + (b + 1) * width, 0, 0.0}, open_sum = 0.0, is_open = true;
      if (high) open.to_rpm = lo + (b + 1) * width, open.rows += n, open_sum += s;
      if ((!high || b + 1 == kBandCount) && is_open) {
        open.rms_over_noise = std::sqrt(open_sum / (2.0 * static_cast<double>(open.rows)));
        out.push_back(open), is_open = false;
      }
    }
  }
  return out;
}

// A plausible model (the waveform loop's second rule, in a table's terms): every part it carries
// determined by the table (every mode inside the table's speeds with its 95 % interval within 4x,
// a bow's and a cross-coupling's away from 0). "" when so, else what is not. An effect whose fit
// leaves a part undetermined explains by a combination the table cannot pin (on the RK-4 run-up,
// a "mode" pushed to the top speed at a damping ratio of 0.6 took 53 µm of unbalance against as
// much runout and bow).
std::string undetermined_part(const response_fit& f) {
  if (f.cancellation > kMaxCancellation)
    return "its parts cancel: together they are " + format_digits(f.cancellation, 3) + " times what they add up to";
  for (const auto& m : f.modes)
    if (!(m.critical_speed_rpm.determined && m.damping_ratio.determined))
      return "mode " + m.axis + (m.at_edge ? " sits at an edge of the table's speeds" : " is not determined (its 95 % interval spans more than 4x)");
  if (f.parts.shaft_bow && !f.bow_m.determined) return "the bow's 95 % interval reaches 0";
  if (f.parts.cross_coupling && f.cross_coupling_at_bound) return "a cross-coupling term reached the bound of its range (w_x w_y / 2)";
  if (f.parts.cross_coupling && !f.k_xy_over_m.determined && !f.k_yx_over_m.determined) return "both cross-coupling terms' 95 % intervals reach 0";
  return {};
}

std::string interval_text(const estimate& e, double scale, const std::string& unit) {
  return format_digits(e.value * scale, 3) + " [" + format_digits(e.lo * scale, 3) + ", " + format_digits(e.hi * scale, 3) + "]" + unit;
}

// An effect's fitted parameters with their 95 % intervals, one line.
std::string estimates_of(const std::string& name, const response_fit& f) {
  if (name == "anisotropy") {
    std::string s;
    for (const auto& m : f.modes)
      s += (s.empty() ? "" : "; ") + std::string("mode ") + m.axis + " " + interval_text(m.critical_speed_rpm, 1.0, " rpm") + ", damping ratio " +
           interval_text(m.damping_ratio, 1.0, "");
    return s;
  }
  if (name == "shaft_bow") return "bow " + interval_text(f.bow_m, 1e6, " µm") + " at " + interval_text(f.bow_phase_deg, 1.0, " deg");
  return "k_xy/m " + interval_text(f.k_xy_over_m, 1.0, " 1/s^2") + ", k_yx/m " + interval_text(f.k_yx_over_m, 1.0, " 1/s^2");
}

// A rub fit's plausibility, as a contact-free fit's: its clearance determined (some speed's orbit
// touches, its 95 % interval within 4x), its modes determined, a bow's interval away from 0, a
// cross-coupling term away from 0.
std::string undetermined_rub(const rub_fit& f) {
  if (f.rows_in_contact == 0) return "no speed's orbit touches";
  if (!f.clearance_m.determined) return "the clearance's 95 % interval spans more than 4x";
  for (const auto& m : f.modes)
    if (!(m.critical_speed_rpm.determined && m.damping_ratio.determined))
      return "mode " + m.axis + (m.at_edge ? " sits at an edge of the table's speeds" : " is not determined (its 95 % interval spans more than 4x)");
  if (f.parts.shaft_bow && !f.bow_m.determined) return "the bow's 95 % interval reaches 0";
  if (f.parts.cross_coupling && !f.k_xy_over_m.determined && !f.k_yx_over_m.determined) return "both cross-coupling terms' 95 % intervals reach 0";
  return {};
}

std::string rub_estimates(const rub_fit& f) {
  return "rub: clearance " + interval_text(f.clearance_m, 1e6, " µm") + ", k1/m " + interval_text(f.contact_stiffness_over_m, 1.0, " 1/s^2") + ", mu " +
         interval_text(f.friction, 1.0, "") + ", " + std::to_string(f.rows_in_contact) + " rows touch" +
         (f.rows_in_contact ? " (" + format_fixed(f.contact_from_rpm, 0) + "–" + format_fixed(f.contact_to_rpm, 0) + " rpm)" : "") + ", " +
         std::to_string(f.shots) + " orbits shot";
}

// The 2X: each probe's runout alone, then with a misalignment's forced response through the
// chosen modes, the noise as for the 1X (the smaller of the rows' scatter and a plausible fit's
// residual scatter), and the misalignment named on the 1X's rules: plausible (its force's
// interval away from 0, its parts not cancelling), BIC rise above 10, and out of sample on the
// same folds a gain above 10 and a third of its gain on every row.
two_x_result judge_two_x(const order_table& table, const response_fit& modes, const std::vector<std::vector<std::complex<double>>>* known,
                         const std::vector<std::size_t> (&fold)[2], const std::function<void(const std::string&)>& say) {
  two_x_result t;
  say("2X: runout" + std::string(known ? " and the rub's own 2X" : "") + " alone, and with a misalignment's forced response through the chosen modes ...");
  std::vector<double> noise = two_x_scatter_noise(table, modes);
  t.noise_scatter_m = noise;
  std::vector<double> error(noise.size(), 1.166 * std::sqrt(1.94 / std::max(1.0, 2.0 * (static_cast<double>(table.rows()) - 2.0))));
  const double residual_error = 1.166 / std::sqrt(2.0 * static_cast<double>(table.rows()));
  const auto options = [&](std::vector<std::size_t> rows = {}) {
    two_x_options o;
    o.rows = std::move(rows), o.noise_m = noise, o.noise_relative_error = *std::max_element(error.begin(), error.end());
    o.known = known;
    return o;
  };
  const auto lower_noise = [&](const two_x_fit& f) {
    const std::vector<double> now = two_x_residual_noise(f);
    for (std::size_t p = 0; p < noise.size(); ++p)
      if (now[p] < noise[p]) noise[p] = now[p], error[p] = residual_error;
  };
  const auto plausibility = [](const two_x_fit& f) -> std::string {
    if (f.cancellation > kMaxCancellation) return "its parts cancel: together they are " + format_digits(f.cancellation, 3) + " times what they add up to";
    if (!f.force_over_m.determined) return "the misalignment force's 95 % interval reaches 0";
    return {};
  };
  t.noise_residual_m = two_x_residual_noise(fit_two_x(table, modes, false, options()));
  lower_noise(fit_two_x(table, modes, false, options()));
  if (plausibility(fit_two_x(table, modes, true, options())).empty()) lower_noise(fit_two_x(table, modes, true, options()));
  t.before = fit_two_x(table, modes, false, options());
  t.with = fit_two_x(table, modes, true, options());
  t.undetermined = plausibility(t.with);
  const double observations = static_cast<double>(2 * table.rows() * t.before.residual.size());
  const double bic_before = t.before.chi2 + static_cast<double>(t.before.parameters) * std::log(observations);
  const double bic_with = t.with.chi2 + static_cast<double>(t.with.parameters) * std::log(observations);
  tracked_model::need& n = t.need;
  n.effect = "misalignment_2x";
  n.bic_rise = bic_before - bic_with;
  if (n.bic_rise > kBicDrop && t.undetermined.empty() && fold[0].size() >= 8 && fold[1].size() >= 8) {
    for (int k = 0; k < 2; ++k) {
      const auto chi2_on = [&](const two_x_fit& f) {
        double s = 0.0;
        for (std::size_t p = 0; p < f.residual.size(); ++p)
          for (const std::size_t i : fold[1 - k]) s += std::norm(f.residual[p][i]) / (noise[p] * noise[p]);
        return s;
      };
      n.held_out_without.push_back(chi2_on(fit_two_x(table, modes, false, options(fold[k]))));
      n.held_out_with.push_back(chi2_on(fit_two_x(table, modes, true, options(fold[k]))));
      n.held_out_gain += n.held_out_without.back() - n.held_out_with.back();
    }
    n.needed = n.held_out_gain > kHoldoutGain && n.held_out_gain > kHoldoutShare * (t.before.chi2 - t.with.chi2);
  }
  t.named = n.needed;
  const two_x_fit& after = t.after();
  const double excess_before = t.before.chi2 - static_cast<double>(t.before.dof), excess_after = after.chi2 - static_cast<double>(after.dof);
  t.remaining_share = excess_before > 0.0 ? std::clamp(excess_after / excess_before, 0.0, 1.0) : 0.0;
  if (after.consistent_with_noise) t.claim = t.named ? "full" : "none";
  else if (t.named) t.claim = 1.0 - t.remaining_share >= kClaimShare ? "partial" : "tentative";
  t.unexplained = !after.consistent_with_noise && t.claim != "partial";
  t.verdict = !t.undetermined.empty() ? "misalignment_2x not plausible: " + t.undetermined
              : "misalignment_2x " + std::string(n.needed ? "needed" : "not needed") + " (without it BIC rises by " + format_digits(n.bic_rise, 3) +
                    (n.held_out_with.empty() ? "" : ", out of sample it gains " + format_digits(n.held_out_gain, 3)) + ")";
  t.verdict += "; 2X chi^2/dof " + format_digits(t.before.chi2 / static_cast<double>(t.before.dof), 3) + " -> " +
               format_digits(after.chi2 / static_cast<double>(after.dof), 3) + (after.consistent_with_noise ? " (noise)" : " (not noise)");
  say("  " + t.verdict);
  return t;
}

}  // namespace

tracking_result run_tracking_loop(const order_table& table, const std::function<void(const std::string&)>& progress) {
  const auto say = [&](const std::string& s) {
    if (progress) progress(s);
  };
  check_fittable(table);  // before the first progress line: a table it cannot fit writes nothing
  tracking_result r;
  r.table = table;
  r.notes = table.notes;
  for (const auto& o : table.orders)
    if (o.order > 2) {
      r.notes.push_back("the " + std::to_string(o.order) + "X columns are read but not fitted: the fits read the 1X and the 2X");
      break;
    }
  say("base fit: one critical speed (isotropic), unbalance, runout, from " + std::to_string(table.rows()) + " rows ...");
  // The noise: the smaller of two estimates, each of which only signal can inflate (a sharp
  // critical speed the rows' scatter, a misfit the residual's), with the relative standard error
  // of the one taken (a median-based scale of N Gaussian values: 1.166 / sqrt(N); second
  // differences are correlated, which counts them as N / 1.94).
  std::vector<double> noise = row_scatter_noise(table);
  std::vector<double> noise_error(noise.size(), 1.166 * std::sqrt(1.94 / std::max(1.0, 2.0 * (static_cast<double>(table.rows()) - 2.0))));
  const double residual_error = 1.166 / std::sqrt(2.0 * static_cast<double>(table.rows()));
  const auto options = [&noise, &noise_error](const response_fit* start, std::vector<std::size_t> rows = {}, fit_starts how = fit_starts::grid) {
    response_fit_options o;
    o.rows = std::move(rows), o.start = start, o.starts = how, o.noise_m = noise;
    o.noise_relative_error = *std::max_element(noise_error.begin(), noise_error.end());
    return o;
  };
  // The noise again from a model's residual: a model closer to the table leaves a residual
  // scatter closer to the noise (an isotropic fit of an anisotropic rotor's table inflates it
  // 3-4 times); true when it came down.
  const auto lower_noise = [&](const response_fit& model) {
    const std::vector<double> now = residual_noise(model);
    bool lower = false;
    for (std::size_t p = 0; p < noise.size(); ++p)
      if (now[p] < noise[p]) noise[p] = now[p], noise_error[p] = residual_error, lower = true;
    return lower;
  };
  r.noise_scatter_m = noise;
  const response_fit first = fit_response(table, {}, options(nullptr));
  r.noise_residual_m = residual_noise(first);
  lower_noise(first);

  // Every combination of the contact-free effects (bit k: kNames[k], below), fewer effects first, each from the
  // grid and from the fit of every combination with one effect fewer (the better one kept).
  const auto parts_of = [](unsigned mask) {
    response_parts p;
    p.anisotropy = mask & 1u, p.shaft_bow = mask & 2u, p.cross_coupling = mask & 4u;
    return p;
  };
  std::vector<unsigned> masks{0u, 1u, 2u, 4u, 3u, 5u, 6u, 7u};
  std::vector<response_fit> fits(8);
  const auto fit_all = [&](bool again) {
    for (const unsigned mask : masks) {
      if (again) {  // the noise came down: the same fits, weighed again
        const response_fit same = fits[mask];
        fits[mask] = fit_response(table, parts_of(mask), options(&same, {}, fit_starts::given_only));
        continue;
      }
      if (mask == 0u) {
        fits[0] = fit_response(table, {}, options(&first));
        continue;
      }
      say("  " + std::string(mask & 1u ? "anisotropy " : "") + (mask & 2u ? "shaft_bow " : "") + (mask & 4u ? "cross_coupling " : "") + "...");
      std::optional<response_fit> best;
      for (unsigned k = 0; k < 3; ++k) {
        if (!(mask & (1u << k))) continue;
        response_fit f = fit_response(table, parts_of(mask), options(&fits[mask & ~(1u << k)]));
        if (!best || f.chi2 < best->chi2) best = std::move(f);
      }
      fits[mask] = std::move(*best);
    }
  };
  fit_all(false);
  // The noise from the best-fitting plausible model's residual, when that is lower.
  {
    std::size_t lowest = 0;
    for (const unsigned mask : masks)
      if (undetermined_part(fits[mask]).empty() && fits[mask].chi2 < fits[lowest].chi2) lowest = mask;
    if (lower_noise(fits[lowest])) {
      say("  noise now " + format_digits(noise.front()) + " m (the residual scatter of the best plausible model)");
      fit_all(true);
    }
  }
  r.before = fits[0];
  say("  base: chi^2/dof " + format_digits(r.before.chi2 / static_cast<double>(r.before.dof)) + ", RMS residual " + format_digits(r.before.rms_residual_m) +
      " m (noise " + format_digits(r.before.noise_m.front()) + " m)");
  const std::size_t observations = 2 * table.rows() * r.before.residual.size();

  // The folds: alternate rows in speed order, as the waveform loop alternates dwells (a row is
  // one speed's measurement, as a dwell is); each model refitted on one fold from its fit on
  // every row, judged on the other.
  std::vector<std::size_t> fold[2];
  for (std::size_t i = 0; i < table.rows(); ++i) fold[i % 2].push_back(i);
  std::vector<std::optional<std::vector<double>>> held(8);
  const auto held_out = [&](unsigned mask) {
    if (!held[mask]) {
      std::vector<double> out;
      for (int k = 0; k < 2 && fold[0].size() >= 8 && fold[1].size() >= 8; ++k) {
        const response_fit part = fit_response(table, parts_of(mask), options(&fits[mask], fold[k], fit_starts::given_only));
        out.push_back(chi2_of(part.residual, part.noise_m, fold[1 - k]));
      }
      held[mask] = out;
    }
    return *held[mask];
  };

  constexpr std::array<const char*, 4> kNames{"anisotropy", "shaft_bow", "cross_coupling", "rub"};
  // The rub (bit 3), where no plausible contact-free combination leaves a residual within the
  // noise and the stator's direction against the probes is known: every combination again with
  // the paper's contact at the top, each rub fit started from the contact-free fit of its parts
  // and from the rub fits of one effect fewer.
  const bool declared = std::all_of(table.orders.begin(), table.orders.end(), [](const tracked_order& o) { return o.order != 1 || o.probe_angle.has_value(); });
  bool any_noise = false;
  for (const unsigned mask : masks) any_noise = any_noise || (undetermined_part(fits[mask]).empty() && fits[mask].consistent_with_noise);
  std::vector<std::optional<rub_fit>> rubs(16);
  const auto rub_options = [&](std::vector<std::size_t> rows = {}, const rub_fit* start = nullptr) {
    rub_fit_options o;
    o.rows = std::move(rows), o.noise_m = noise, o.start = start;
    o.noise_relative_error = *std::max_element(noise_error.begin(), noise_error.end());
    return o;
  };
  if (declared && !any_noise) {
    say("rub: every combination with the paper's contact at the top, its orbits shot at every speed ...");
    for (const unsigned mask : {0u, 1u, 2u, 4u, 3u, 5u, 6u, 7u}) {
      rub_fit_options o = rub_options();
      for (unsigned k = 0; k < 3; ++k)
        if ((mask & (1u << k)) && rubs[(mask & ~(1u << k)) | 8u]) o.also_from.push_back(&*rubs[(mask & ~(1u << k)) | 8u]);
      // A combination whose orbits cannot be computed from any start is left out, and said so
      // (its parts are then judged without contact only).
      try {
        rubs[mask | 8u] = fit_rub(table, fits[mask], o);
        masks.push_back(mask | 8u);
      } catch (const numerical_error& e) {
        rubs[mask | 8u].reset();
        std::string parts;
        for (unsigned k = 0; k < 3; ++k)
          if (mask & (1u << k)) parts += (parts.empty() ? "" : ", ") + std::string(kNames[k]);
        r.notes.push_back("the rub fit with " + (parts.empty() ? std::string("the base") : parts) + " found no point whose orbits could all be computed: " + e.what());
      }
    }
  }
  // Then each again from the rub fits of one effect more (their extra part dropped), kept where
  // that fits better: a fit of fewer parts can miss the contact that one of more found.
  if (declared && !any_noise)
    for (const unsigned mask : {7u, 6u, 5u, 3u, 4u, 2u, 1u, 0u}) {
      rub_fit_options o = rub_options();
      o.grid = false;
      for (unsigned k = 0; k < 3; ++k)
        if (!(mask & (1u << k)) && rubs[mask | (1u << k) | 8u]) o.also_from.push_back(&*rubs[mask | (1u << k) | 8u]);
      if (o.also_from.empty()) continue;
      try {
        rub_fit again = fit_rub(table, fits[mask], o);
        if (!rubs[mask | 8u]) masks.push_back(mask | 8u);
        if (!rubs[mask | 8u] || again.chi2 < rubs[mask | 8u]->chi2) rubs[mask | 8u] = std::move(again);
      } catch (const numerical_error&) {
        // no better start: the fit from the grid stands (or the combination stays left out)
      }
    }
  const auto chi2_all = [&](unsigned mask) { return mask & 8u ? rubs[mask]->chi2 : fits[mask].chi2; };
  const auto parameters_of = [&](unsigned mask) { return mask & 8u ? rubs[mask]->parameters : fits[mask].parameters; };
  const auto bic_of = [&](unsigned mask) { return bic(chi2_all(mask), parameters_of(mask), observations); };
  // Held out: each combination refitted on one fold from its fit on every row, judged on the other.
  std::vector<std::optional<std::vector<double>>> held_rub(16);
  const auto held_out_any = [&](unsigned mask) {
    if (!(mask & 8u)) return held_out(mask);
    if (!held_rub[mask]) {
      std::vector<double> out;
      try {
        for (int k = 0; k < 2 && fold[0].size() >= 8 && fold[1].size() >= 8; ++k) {
          const rub_fit part = fit_rub(table, fits[mask & 7u], rub_options(fold[k], &*rubs[mask]));
          out.push_back(chi2_of(part.residual, part.noise_m, fold[1 - k]));
        }
      } catch (const numerical_error&) {
        out.clear();  // a fold whose orbits cannot be computed: no out-of-sample evidence, so not needed
      }
      held_rub[mask] = out;
    }
    return *held_rub[mask];
  };

  // Each combination judged: plausible (every part determined), and every effect in it needed
  // against the combination without it: BIC rises by more than 10 without it, and out of sample
  // it gains more than 10 and a third of its gain on every row.
  std::size_t chosen = 0;
  for (const unsigned mask : masks) {
    tracked_model m;
    for (unsigned k = 0; k < 4; ++k)
      if (mask & (1u << k)) m.effects.push_back(kNames[k]);
    m.chi2 = chi2_all(mask), m.bic = bic_of(mask);
    if (mask & 8u) {
      m.undetermined = undetermined_rub(*rubs[mask]);
      m.estimates = rub_estimates(*rubs[mask]);
    } else {
      m.undetermined = undetermined_part(fits[mask]);
      for (const auto& e : m.effects) m.estimates += (m.estimates.empty() ? "" : "; ") + estimates_of(e, fits[mask]);
    }
    bool all_needed = true;
    for (unsigned k = 0; k < 4; ++k) {
      if (!(mask & (1u << k))) continue;
      tracked_model::need n;
      n.effect = kNames[k];
      const unsigned without = mask & ~(1u << k);
      // (A rub combination whose fit could not be computed gives its supersets no comparison:
      // their extra effect is then not shown needed.)
      if ((without & 8u) && !rubs[without]) {
        n.bic_rise = std::numeric_limits<double>::quiet_NaN();
        all_needed = false;
        m.needs.push_back(n);
        continue;
      }
      n.bic_rise = bic_of(without) - m.bic;
      if (n.bic_rise > kBicDrop && m.undetermined.empty()) {
        n.held_out_without = held_out_any(without), n.held_out_with = held_out_any(mask);
        for (std::size_t i = 0; i < n.held_out_with.size() && i < n.held_out_without.size(); ++i) n.held_out_gain += n.held_out_without[i] - n.held_out_with[i];
        const double full_gain = chi2_all(without) - m.chi2;
        n.needed = n.held_out_with.size() == 2 && n.held_out_gain > kHoldoutGain && n.held_out_gain > kHoldoutShare * full_gain;
      }
      all_needed = all_needed && n.needed;
      m.needs.push_back(n);
    }
    m.eligible = m.undetermined.empty() && all_needed;
    if (!m.undetermined.empty()) {
      m.verdict = "not plausible: " + m.undetermined;
    } else {
      m.verdict = "BIC " + format_digits(m.bic - bic_of(0u), 4) + " against the base";
      for (const auto& n : m.needs)
        m.verdict += "; " + n.effect +
                     (std::isnan(n.bic_rise) ? " not shown needed (the rub fit without it could not be computed)"
                                             : (n.needed ? " needed" : " not needed") + std::string(" (without it BIC rises by ") + format_digits(n.bic_rise, 3) +
                                                   (n.held_out_with.empty() ? "" : ", out of sample it gains " + format_digits(n.held_out_gain, 3)) + ")");
    }
    say("    " + (m.effects.empty() ? std::string("base") : m.estimates) + ": " + m.verdict);
    r.models.push_back(m);
    if (m.eligible && (r.models[chosen].eligible ? m.bic < r.models[chosen].bic : true)) chosen = r.models.size() - 1;
  }
  const unsigned chosen_mask = masks[chosen];
  r.models[chosen].verdict = "chosen: " + r.models[chosen].verdict;
  r.effects = r.models[chosen].effects;
  r.after = fits[chosen_mask & 7u];
  // The rub's result: the chosen rub model, or (tried, not chosen) the one on the chosen
  // contact-free model's parts. Chosen, its residual gives the noise again where that is lower
  // (as a plausible contact-free model's does), and it is refitted with it.
  if (rubs[chosen_mask | 8u]) {
    rub_result t;
    const std::size_t at = static_cast<std::size_t>(std::find(masks.begin(), masks.end(), chosen_mask | 8u) - masks.begin());
    t.fit = *rubs[chosen_mask | 8u];
    t.undetermined = r.models[at].undetermined;
    for (const auto& n : r.models[at].needs)
      if (n.effect == "rub") t.need = n;
    t.named = (chosen_mask & 8u) != 0;
    t.verdict = r.models[at].estimates + "; " + r.models[at].verdict;
    if (t.named) {
      const std::vector<double> now = residual_noise(t.fit.residual, t.fit.rows, t.fit.parameters);
      bool lower = false;
      for (std::size_t p = 0; p < noise.size(); ++p)
        if (now[p] < noise[p]) noise[p] = now[p], noise_error[p] = residual_error, lower = true;
      if (lower) {
        const rub_fit same = t.fit;
        t.fit = fit_rub(table, r.after, rub_options({}, &same));
      }
    }
    r.rub = std::move(t);
  }
  const bool rub_named = r.rub && r.rub->named;
  const double chi2_after = rub_named ? r.rub->fit.chi2 : r.after.chi2;
  const double dof_after = static_cast<double>(rub_named ? r.rub->fit.dof : r.after.dof);
  const bool noise_after = rub_named ? r.rub->fit.consistent_with_noise : r.after.consistent_with_noise;
  r.error_before = r.before.rms_residual_m, r.error_after = rub_named ? r.rub->fit.rms_residual_m : r.after.rms_residual_m;
  const double excess_before = r.before.chi2 - static_cast<double>(r.before.dof), excess_after = chi2_after - dof_after;
  r.remaining_share = excess_before > 0.0 ? std::clamp(excess_after / excess_before, 0.0, 1.0) : 0.0;
  if (noise_after) r.claim = r.effects.empty() ? "none" : "full";
  else if (!r.effects.empty()) r.claim = 1.0 - r.remaining_share >= kClaimShare ? "partial" : "tentative";
  r.unexplained = !noise_after && r.claim != "partial";
  // A choice is decisive only when no eligible combination of other effects comes within the
  // same 10 of its BIC: two such explain the table alike, and neither is claimed.
  for (std::size_t i = 0; i < r.models.size(); ++i)
    if (i != chosen && r.models[i].eligible && r.models[i].effects != r.models[chosen].effects && r.models[i].bic - r.models[chosen].bic <= kBicDrop &&
        !r.effects.empty()) {
      std::string names;
      for (const auto& e : r.models[i].effects) names += (names.empty() ? "" : ", ") + e;
      r.rival = names.empty() ? "base" : names;
      r.claim = "tentative";
      r.unexplained = !noise_after;  // the residual is what it is; which effects explain it is not decided
      r.models[chosen].verdict += "; not decisive: " + r.rival + " comes within " + format_digits(r.models[i].bic - r.models[chosen].bic, 3) + " of its BIC";
      break;
    }
  if (r.claim == "tentative") std::swap(r.effects, r.tentative);  // chosen by the rules, not claimed
  if (rub_named) r.bands = bands_of(table, r.rub->fit.residual, r.rub->fit.noise_m, r.rub->fit.probes, 1);
  else r.bands = bands_of(table, r.after.residual, r.after.noise_m, r.after.probes, 1);
  if (!two_x_columns(table, r.after).empty()) {
    const response_fit modes = rub_named ? linear_part(r.after, r.rub->fit) : r.after;
    r.two_x = judge_two_x(table, modes, rub_named ? &r.rub->fit.model_2x : nullptr, fold, say);
    const two_x_result& t2 = *r.two_x;
    if (t2.named) (t2.claim == "tentative" ? r.tentative : r.effects).push_back("misalignment_2x");
    r.unexplained = r.unexplained || t2.unexplained;
    const auto more = bands_of(table, t2.after().residual, t2.after().noise_m, t2.after().probes, 2);
    r.bands.insert(r.bands.end(), more.begin(), more.end());
  }
  r.cannot_see = {
      "a static offset such as a preload's deflection: an order-tracked table holds no DC, and AC-coupled probes lose it anyway",
      "the rotor's mass: every force scales with it, so stiffness, damping and cross-coupling are per unit mass",
      "where the keyphasor's notch sits on the shaft: the unbalance phase is measured from it",
      "the contact law's form: the rub fit takes the piecewise-linear law k1 z, whose clearance, stiffness and friction a 1X table can show; a cubic "
      "or velocity-squared term shows, if at all, as a residual the rub fit leaves",
      "anything that shows only in orders above the 2X, sub-harmonics or the waveform (a rub's half-order whirl, chatter): the fits read the 1X and 2X",
      "slow-roll runout against a shaft bow away from the critical speeds: both are 1X and turn with the shaft; a bow is amplified near a critical speed and "
      "runout is not",
      "a seal's follower cross-coupling (k_xy = -k_yx) on a rotor whose supports are alike: its unbalance response is a forward whirl, on which the "
      "cross-coupling acts as less damping, which the damping ratio takes (on an anisotropic rotor it shows)",
      "a run-up's transients: the model is the steady response at each speed; a sweep through a lightly damped critical speed leaves ringing just above it, "
      "which shows in the residual bands",
  };
  if (!declared)
    r.cannot_see.push_back("a rub, with a probe whose angle is not declared: the stator's direction against the probe is unknown, so the rub fit is not tried");
  if (r.before.probe_angle_fitted.front() && r.before.probes.size() == 1)
    r.cannot_see.push_back("with one probe, the support axes' directions only through how the two modes mix in its reading: a probe along one axis sees one "
                           "mode, and the other mode's interval says so");
  return r;
}

}  // namespace rubref
