#include "ref/orbit_summary.hpp"

#include <algorithm>
#include <cmath>

namespace rubref {

std::complex<double> whirl_coefficient(std::span<const orbit_sample> samples, double omega, int order) {
  std::complex<double> sum{};
  for (const auto& smp : samples) {
    const double phase = -order * omega * smp.t;
    sum += std::complex<double>(smp.s[idx::x], smp.s[idx::y]) * std::complex<double>(std::cos(phase), std::sin(phase));
  }
  return samples.empty() ? sum : sum / static_cast<double>(samples.size());
}

orbit_summary summarize(const orbit& o) {
  orbit_summary out;
  if (o.samples.empty()) return out;
  const double delta = o.request.params.delta;
  double x_lo = o.samples.front().s[idx::x], x_hi = x_lo;
  double y_lo = o.samples.front().s[idx::y], y_hi = y_lo;
  for (const auto& smp : o.samples) {
    x_lo = std::min(x_lo, smp.s[idx::x]);
    x_hi = std::max(x_hi, smp.s[idx::x]);
    y_lo = std::min(y_lo, smp.s[idx::y]);
    y_hi = std::max(y_hi, smp.s[idx::y]);
    out.max_normal_force = std::max(out.max_normal_force, smp.fn);
    out.max_penetration = std::max(out.max_penetration, smp.s[idx::y] - delta);
  }
  out.peak_to_peak_x = x_hi - x_lo;
  out.peak_to_peak_y = y_hi - y_lo;

  std::size_t episodes = 0;
  for (const auto& ev : o.events) {
    if (ev.kind == event_kind::separation) out.max_penetration = std::max(out.max_penetration, ev.max_penetration);
    if (ev.kind == event_kind::contact_onset || ev.kind == event_kind::impact || ev.kind == event_kind::stick) ++episodes;
  }
  if (o.end.phase == contact_phase::contact) out.max_penetration = std::max(out.max_penetration, o.end.episode_peak);
  out.contact_episodes_per_rev = static_cast<double>(episodes) / o.request.record_revs;

  const double omega = rpm_to_rad_s(o.request.rpm);
  out.forward_1x = whirl_coefficient(o.samples, omega, +1);
  out.backward_1x = whirl_coefficient(o.samples, omega, -1);
  return out;
}

}  // namespace rubref
