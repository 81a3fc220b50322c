#include "ref/sweep/sweep.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/model/closed_form.hpp"
#include "ref/orbits/periodic_orbit.hpp"

namespace rubref {

std::string_view to_string(sweep_direction d) { return d == sweep_direction::up ? "up" : "down"; }

void validate(const sweep_settings& s) {
  const auto require = [](bool ok, const std::string& what) {
    if (!ok) throw input_error(what);
  };
  check({"sweep", "from_rpm"}, s.from_rpm);
  check({"sweep", "to_rpm"}, s.to_rpm);
  require(s.to_rpm >= s.from_rpm, "sweep " + setting("to_rpm") + " must be >= " + setting("from_rpm"));
  check({"sweep", "step_rpm"}, s.step_rpm);
  require((s.to_rpm - s.from_rpm) / s.step_rpm <= 1e5, "sweep has more than 1e5 speeds");
  check({"sweep", "first_settle_revs"}, s.first_settle_revs);
  check({"sweep", "settle_revs"}, s.settle_revs);
  check({"sweep", "record_revs"}, s.record_revs);
  require(s.record_revs % 6 == 0,
          "sweep " + setting("record_revs") + " must be a positive multiple of 6 (so orders 1/2 and 1/3 fall on spectral bins)");
  validate(request_at(s, s.from_rpm));
}

run_request request_at(const sweep_settings& s, double rpm) {
  run_request req;
  req.variant = s.variant;
  req.params = s.params;
  req.rpm = rpm;
  req.settle_revs = s.settle_revs;
  req.record_revs = s.record_revs;
  req.samples_per_rev = s.samples_per_rev;
  req.integration = s.integration;
  return req;
}

std::vector<double> sweep_speeds(const sweep_settings& s) {
  std::vector<double> out;
  // Tolerate the rounding of (to - from) / step so that a grid ending on `to` includes it.
  const auto n = static_cast<std::size_t>(std::floor((s.to_rpm - s.from_rpm) / s.step_rpm + 1e-9));
  for (std::size_t k = 0; k <= n; ++k) out.push_back(s.from_rpm + static_cast<double>(k) * s.step_rpm);
  return out;
}

sweep_branch run_branch(const sweep_settings& s, sweep_direction d) {
  validate(s);
  std::vector<double> speeds = sweep_speeds(s);
  if (d == sweep_direction::down) std::reverse(speeds.begin(), speeds.end());

  sweep_branch branch{d, {}, {}, 0.0};
  run_request req = request_at(s, speeds.front());
  // A quasi-static sweep arrives at its first speed slowly: on the contact-free steady state when
  // that orbit clears the stator, else from rest (docs/sweeps.md).
  const unbalance_response free_orbit(s.params, rpm_to_rad_s(speeds.front()));
  req.initial_state = std::abs(free_orbit.y_phasor) < s.params.clearance ? free_orbit.at(0.0) : state_type{};
  for (std::size_t i = 0; i < speeds.size(); ++i) {
    req.rpm = speeds[i];
    req.settle_revs = i == 0 ? s.first_settle_revs : s.settle_revs;
    if (s.start_from_orbit) {
      // No stable period-1 orbit next to the neighbour's (past a fold, or none at all): settle, and
      // look again from where the transient went, up to kSettleRounds times. A jump lands near the
      // other branch within a round, but its last approach, or the slow passage past a fold, can
      // take longer than one; a subharmonic, torus or chaotic response is recorded after them all.
      for (int round = 0; round <= kSettleRounds; ++round) {
        if (round > 0) {
          run_request settle = req;
          settle.record_revs = 1;
          req.initial_state = simulate(settle).end.s;  // after settle_revs + 1 revolutions: w t is a multiple of 2 pi
        }
        const periodic_orbit_result shot = shoot_from(req, req.initial_state, 1);
        if (shot.stable) {  // (converged and every multiplier inside the unit circle)
          req.initial_state = shot.samples.request.initial_state;
          req.settle_revs = 0;
          ++branch.orbit_starts;
          break;
        }
      }
    }
    orbit o = simulate(req);
    if (o.counts.coarse_contact_steps > 0 && branch.counts.coarse_contact_steps == 0) branch.first_coarse_contact_rpm = speeds[i];
    accumulate(branch.counts, o.counts);
    sweep_point pt{speeds[i], summarize(o), {}};
    if (s.keep_orbits) pt.samples = std::move(o.samples);
    branch.points.push_back(std::move(pt));
    req.initial_state = o.end.s;  // continuation; w t_end is a multiple of 2 pi
  }
  return branch;
}

speed_ranges contiguous_ranges(const std::vector<double>& ascending_rpm, const std::function<bool(double)>& holds) {
  speed_ranges out;
  for (std::size_t i = 0; i < ascending_rpm.size();) {
    if (!holds(ascending_rpm[i])) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j + 1 < ascending_rpm.size() && holds(ascending_rpm[j + 1])) ++j;
    out.emplace_back(ascending_rpm[i], ascending_rpm[j]);
    i = j + 1;
  }
  return out;
}

std::vector<sweep_branch> run_branches(const std::vector<branch_task>& tasks, unsigned threads) {
  for (const auto& t : tasks) validate(t.settings);
  std::vector<sweep_branch> out(tasks.size());
  parallel_for(tasks.size(), threads, [&](std::size_t i) { out[i] = run_branch(tasks[i].settings, tasks[i].direction); });
  return out;
}

jump_report detect_jumps(const sweep_branch& up, const sweep_branch& down, double step_rpm, double relative_tolerance) {
  jump_report rep;
  rep.relative_tolerance = relative_tolerance;
  std::map<double, double> a_up, a_down, spread_up, spread_down;
  for (const auto& p : up.points) {
    a_up[p.rpm] = response_amplitude(p.summary);
    spread_up[p.rpm] = p.summary.radius_spread;
  }
  for (const auto& p : down.points) {
    a_down[p.rpm] = response_amplitude(p.summary);
    spread_down[p.rpm] = p.summary.radius_spread;
  }

  // Speeds (ascending) where both sweeps ran; bands where they reached different attractors.
  std::vector<double> speeds;
  for (const auto& [rpm, au] : a_up)
    if (a_down.count(rpm)) speeds.push_back(rpm);
  const auto differ = [&](double rpm) {
    const double au = a_up[rpm], ad = a_down[rpm];
    return std::abs(au - ad) > relative_tolerance * std::max(au, ad) + spread_up[rpm] + spread_down[rpm];
  };
  for (const auto& [lo, hi] : contiguous_ranges(speeds, differ)) {
    rep.bands.push_back({lo, hi});
    rep.total_width_rpm += hi - lo + step_rpm;
    // The up sweep leaves the band at its top (onto the other branch), the down sweep at its bottom.
    const auto top = std::find(speeds.begin(), speeds.end(), hi);
    const auto bottom = std::find(speeds.begin(), speeds.end(), lo);
    if (top + 1 != speeds.end()) rep.jumps.push_back({sweep_direction::up, hi, *(top + 1), a_up[hi], a_up[*(top + 1)]});
    if (bottom != speeds.begin()) rep.jumps.push_back({sweep_direction::down, lo, *(bottom - 1), a_down[lo], a_down[*(bottom - 1)]});
  }
  return rep;
}

}  // namespace rubref
