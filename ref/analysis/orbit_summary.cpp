#include "ref/analysis/orbit_summary.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace rubref {

std::string_view to_string(contact_regime r) {
  switch (r) {
    case contact_regime::no_contact: return "no_contact";
    case contact_regime::partial_rub: return "partial_rub";
    case contact_regime::full_annular: return "full_annular";
  }
  return "?";
}

orbit_summary summarize(const orbit& o, summary_spectrum spectrum) {
  orbit_summary out;
  if (o.samples.empty()) return out;
  const double clearance = o.request.params.clearance;
  double x_lo = o.samples.front().s[idx::x], x_hi = x_lo;
  double y_lo = o.samples.front().s[idx::y], y_hi = y_lo;
  std::size_t in_contact = 0;
  std::vector<double> x, y;
  x.reserve(o.samples.size());
  y.reserve(o.samples.size());
  for (const auto& smp : o.samples) {
    x_lo = std::min(x_lo, smp.s[idx::x]);
    x_hi = std::max(x_hi, smp.s[idx::x]);
    y_lo = std::min(y_lo, smp.s[idx::y]);
    y_hi = std::max(y_hi, smp.s[idx::y]);
    out.max_radius = std::max(out.max_radius, std::hypot(smp.s[idx::x], smp.s[idx::y]));
    out.max_normal_force = std::max(out.max_normal_force, smp.fn);
    out.max_penetration = std::max(out.max_penetration, smp.s[idx::y] - clearance);
    if (smp.fn > 0.0) ++in_contact;
    x.push_back(smp.s[idx::x]);
    y.push_back(smp.s[idx::y]);
  }
  const std::size_t per_rev = static_cast<std::size_t>(o.request.samples_per_rev);
  double rev_lo = std::numeric_limits<double>::infinity(), rev_hi = 0.0;
  for (std::size_t start = 0; start + per_rev <= o.samples.size(); start += per_rev) {
    double r = 0.0;
    for (std::size_t i = start; i < start + per_rev; ++i) r = std::max(r, std::hypot(x[i], y[i]));
    rev_lo = std::min(rev_lo, r);
    rev_hi = std::max(rev_hi, r);
  }
  out.radius_spread = rev_hi >= rev_lo ? rev_hi - rev_lo : 0.0;
  const std::size_t revs = per_rev == 0 ? 0 : o.samples.size() / per_rev;
  if (revs >= 2) {
    out.period_revs = 0;
    const double tol = kRepeatRelTol * out.max_radius;
    for (std::size_t n = 1; n <= revs / 2 && out.period_revs == 0; ++n) {
      bool repeats = true;
      for (std::size_t i = 0; i + n * per_rev < revs * per_rev && repeats; ++i)
        repeats = std::abs(x[i + n * per_rev] - x[i]) <= tol && std::abs(y[i + n * per_rev] - y[i]) <= tol;
      if (repeats) out.period_revs = static_cast<int>(n);
    }
  }
  out.peak_to_peak_x = x_hi - x_lo;
  out.peak_to_peak_y = y_hi - y_lo;
  out.max_y = y_hi;
  out.contact_fraction = static_cast<double>(in_contact) / static_cast<double>(o.samples.size());

  std::size_t episodes = 0, endings = 0;
  for (const auto& ev : o.events) {
    if (ev.kind == event_kind::separation) out.max_penetration = std::max(out.max_penetration, ev.max_penetration);
    if (ev.kind == event_kind::contact_onset || ev.kind == event_kind::impact || ev.kind == event_kind::stick) ++episodes;
    if (ev.kind == event_kind::separation || ev.kind == event_kind::release) ++endings;
  }
  if (o.end.phase == contact_phase::contact) out.max_penetration = std::max(out.max_penetration, o.end.episode_peak);
  out.contact_episodes_per_rev = static_cast<double>(episodes) / o.request.record_revs;
  if (in_contact == o.samples.size() && endings == 0) {
    out.regime = contact_regime::full_annular;
  } else if (in_contact > 0 || !o.events.empty()) {
    out.regime = contact_regime::partial_rub;
  }

  // Sample spacing and start in revolutions: the spectrum comes out in orders.
  const double revs_per_second = o.request.rpm / 60.0;
  const double dt = 1.0 / o.request.samples_per_rev, t0 = o.samples.front().t * revs_per_second;
  if (spectrum == summary_spectrum::full) out.spectrum = full_spectrum(x, y, dt, t0);
  out.forward_1x = spectrum_line(x, y, dt, t0, +1.0);
  out.backward_1x = spectrum_line(x, y, dt, t0, -1.0);
  return out;
}

}  // namespace rubref
