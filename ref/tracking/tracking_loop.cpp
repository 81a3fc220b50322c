#include "ref/tracking/tracking_loop.hpp"

#include <algorithm>
#include <cmath>

#include <boost/math/distributions/chi_squared.hpp>

#include "ref/base/number_text.hpp"

namespace rubref {

namespace {

// The evidence rules of the waveform loop (docs/loop.md, "Adds"), in the same numbers: BIC must
// fall by more than 10 (very strong evidence, Kass & Raftery 1995); the out-of-sample gain over
// two folds must exceed 10 and a third of the gain on every row; a claim needs the residual at
// the noise ("full") or 96 % of the base fit's excess removed ("partial").
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

// chi^2 of the rows `rows` of a fit's residual (every probe), with the fit's noise.
double chi2_of(const response_fit& f, const std::vector<std::size_t>& rows) {
  double s = 0.0;
  for (std::size_t p = 0; p < f.residual.size(); ++p)
    for (const std::size_t i : rows) s += std::norm(f.residual[p][i]) / (f.noise_m[p] * f.noise_m[p]);
  return s;
}

double bic(const response_fit& f, std::size_t observations) {
  const std::size_t k = f.theta.size() + 2 * f.amplitudes.size();
  return f.chi2 + static_cast<double>(k) * std::log(static_cast<double>(observations));
}

std::vector<residual_band> bands_of(const order_table& t, const response_fit& f) {
  std::vector<residual_band> out;
  const double lo = t.rpm.front(), hi = t.rpm.back(), width = (hi - lo) / kBandCount;
  if (!(width > 0.0)) return out;
  for (std::size_t p = 0; p < f.residual.size(); ++p) {
    residual_band open;
    bool is_open = false;
    double open_sum = 0.0;
    for (int b = 0; b < kBandCount; ++b) {
      double s = 0.0;
      std::size_t n = 0;
      for (std::size_t i = 0; i < t.rows(); ++i)
        if (t.rpm[i] >= lo + b * width && (t.rpm[i] < lo + (b + 1) * width || (b + 1 == kBandCount && t.rpm[i] <= hi)))
          s += std::norm(f.residual[p][i]) / (f.noise_m[p] * f.noise_m[p]), ++n;
      const double dof = 2.0 * static_cast<double>(n);
      const bool high = n > 0 && s > boost::math::quantile(boost::math::chi_squared(dof), 0.999);
      if (high && !is_open) open = {f.probes[p], lo + b * width, lo + (b + 1) * width, 0, 0.0}, open_sum = 0.0, is_open = true;
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

}  // namespace

tracking_result run_tracking_loop(const order_table& table, const std::function<void(const std::string&)>& progress) {
  const auto say = [&](const std::string& s) {
    if (progress) progress(s);
  };
  tracking_result r;
  r.table = table;
  r.notes = table.notes;
  for (const auto& o : table.orders)
    if (o.order != 1) {
      r.notes.push_back("the " + std::to_string(o.order) + "X columns are read but not fitted: the response fit and its effects read the 1X");
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
    const std::vector<double> now = residual_noise(table, model);
    bool lower = false;
    for (std::size_t p = 0; p < noise.size(); ++p)
      if (now[p] < noise[p]) noise[p] = now[p], noise_error[p] = residual_error, lower = true;
    return lower;
  };
  r.noise_scatter_m = noise;
  {
    const response_fit first = fit_response(table, {}, options(nullptr));
    r.noise_residual_m = residual_noise(table, first);
    lower_noise(first);
    r.before = fit_response(table, {}, options(&first));
  }
  say("  chi^2/dof " + format_digits(r.before.chi2 / static_cast<double>(r.before.dof)) + ", RMS residual " + format_digits(r.before.rms_residual_m) + " m (noise " +
      format_digits(r.before.noise_m.front()) + " m)");
  const std::size_t observations = 2 * table.rows() * r.before.residual.size();

  // The folds: alternate rows in speed order, as the waveform loop alternates dwells (a row is
  // one speed's measurement, as a dwell is).
  std::vector<std::size_t> fold[2];
  for (std::size_t i = 0; i < table.rows(); ++i) fold[i % 2].push_back(i);
  const auto held_out_chi2 = [&](const response_parts& parts, const response_fit& from) {
    std::vector<double> out;
    for (int k = 0; k < 2; ++k) {
      if (fold[k].size() < 8 || fold[1 - k].size() < 8) return std::vector<double>{};
      const response_fit f = fit_response(table, parts, options(&from, fold[k], fit_starts::given_only));
      out.push_back(chi2_of(f, fold[1 - k]));
    }
    return out;
  };

  // Rounds while a candidate passes, whether or not the residual is already within the noise
  // bound: that bound is an omnibus test, weaker against one effect than the effect's own
  // BIC and out-of-sample tests, and a table's noise is known to a few per cent only.
  response_fit current = r.before;
  response_parts parts;
  bool more = true;
  while (more) {
    more = false;
    if (lower_noise(current)) {
      const response_fit same = current;
      current = fit_response(table, parts, options(&same, {}, fit_starts::given_only));
      say("  noise now " + format_digits(noise.front()) + " m (the current model's residual scatter)");
    }
    std::vector<std::pair<tracked_candidate, response_fit>> round;
    for (const std::string name : {"anisotropy", "shaft_bow", "cross_coupling"}) {
      if (std::find(r.effects.begin(), r.effects.end(), name) != r.effects.end()) continue;
      response_parts with = parts;
      (name == "anisotropy" ? with.anisotropy : name == "shaft_bow" ? with.shaft_bow : with.cross_coupling) = true;
      say("  " + name + ": refit with every coordinate free ...");
      const response_fit f = fit_response(table, with, options(&current));
      tracked_candidate c;
      c.effect = name;
      c.parameters = name == "anisotropy" ? (f.probe_angle_fitted.front() ? 3 : 2) : 2;
      c.chi2_before = current.chi2, c.chi2_after = f.chi2;
      const double drop = bic(current, observations) - bic(f, observations);
      c.bic_drop = drop;
      const std::string undetermined = undetermined_part(f);
      c.estimates = estimates_of(name, f);
      if (!(drop > kBicDrop)) {
        c.verdict = "BIC falls by " + format_digits(drop, 3) + ", not more than " + format_digits(kBicDrop, 2);
      } else if (!undetermined.empty()) {
        c.verdict = "BIC falls by " + format_digits(drop, 3) + ", but " + undetermined;
      } else {
        const std::vector<double> without_held = held_out_chi2(parts, current), with_held = held_out_chi2(with, f);
        c.held_out_before = without_held, c.held_out_after = with_held;
        double gain = 0.0;
        for (std::size_t k = 0; k < without_held.size() && k < with_held.size(); ++k) gain += without_held[k] - with_held[k];
        const double full_gain = current.chi2 - f.chi2;
        if (without_held.empty() || with_held.empty()) c.verdict = "too few rows for the out-of-sample test";
        else if (!(gain > kHoldoutGain && gain > kHoldoutShare * full_gain))
          c.verdict = "out of sample it gains " + format_digits(gain, 3) + " in chi^2 (needs more than " + format_digits(kHoldoutGain, 2) + " and a third of its " +
                      format_digits(full_gain, 3) + " on every row)";
        else
          c.added = true, c.verdict = "BIC falls by " + format_digits(drop, 3) + "; out of sample it gains " + format_digits(gain, 3) + " in chi^2";
      }
      say("    " + c.estimates + ": " + c.verdict);
      round.emplace_back(c, f);
    }
    // The passing candidate with the largest BIC drop is added; the others are tried again next round.
    std::size_t best = round.size();
    for (std::size_t i = 0; i < round.size(); ++i)
      if (round[i].first.added && (best == round.size() || round[i].first.bic_drop > round[best].first.bic_drop)) best = i;
    for (std::size_t i = 0; i < round.size(); ++i) {
      if (i != best) round[i].first.added = false;
      if (i != best && round[i].first.verdict.rfind("BIC falls", 0) == 0 && round[i].first.held_out_after.size() == 2 && best != round.size())
        round[i].first.verdict += "; a stronger effect was added first";
      r.candidates.push_back(round[i].first);
    }
    if (best != round.size()) {
      r.effects.push_back(round[best].first.effect);
      parts = round[best].second.parts;
      current = round[best].second;
      more = true;
    }
  }
  r.after = current;
  r.error_before = r.before.rms_residual_m, r.error_after = r.after.rms_residual_m;
  const double excess_before = r.before.chi2 - static_cast<double>(r.before.dof), excess_after = r.after.chi2 - static_cast<double>(r.after.dof);
  r.remaining_share = excess_before > 0.0 ? std::clamp(excess_after / excess_before, 0.0, 1.0) : 0.0;
  if (r.after.consistent_with_noise) r.claim = r.effects.empty() ? "none" : "full";
  else if (!r.effects.empty()) r.claim = 1.0 - r.remaining_share >= kClaimShare ? "partial" : "tentative";
  r.unexplained = !r.after.consistent_with_noise && r.claim != "partial";
  if (r.claim == "tentative") std::swap(r.effects, r.tentative);  // added by the trace, not claimed
  r.bands = bands_of(table, r.after);
  r.cannot_see = {
      "a static offset such as a preload's deflection: an order-tracked table holds no DC, and AC-coupled probes lose it anyway",
      "the rotor's mass: every force scales with it, so stiffness, damping and cross-coupling are per unit mass",
      "where the keyphasor's notch sits on the shaft: the unbalance phase is measured from it",
      "contact, friction and anything else that shows only in other orders, sub-harmonics or the waveform: this fit reads the 1X",
      "slow-roll runout against a shaft bow away from the critical speeds: both are 1X and turn with the shaft; a bow is amplified near a critical speed and "
      "runout is not",
      "a seal's follower cross-coupling (k_xy = -k_yx) on a rotor whose supports are alike: its unbalance response is a forward whirl, on which the "
      "cross-coupling acts as less damping, which the damping ratio takes (on an anisotropic rotor it shows)",
      "a run-up's transients: the model is the steady response at each speed; a sweep through a lightly damped critical speed leaves ringing just above it, "
      "which shows in the residual bands",
  };
  if (r.before.probe_angle_fitted.front() && r.before.probes.size() == 1)
    r.cannot_see.push_back("with one probe, the support axes' directions only through how the two modes mix in its reading: a probe along one axis sees one "
                           "mode, and the other mode's interval says so");
  return r;
}

}  // namespace rubref
