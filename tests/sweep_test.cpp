// Quasi-static sweeps: continuation, the contact-free limit against the closed form, coexisting
// responses and the jumps between them, and determinism across thread counts.

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <numbers>
#include <set>
#include <thread>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/analysis/orbit_summary.hpp"
#include "ref/model/closed_form.hpp"
#include "ref/run/simulate.hpp"
#include "ref/sweep/sweep.hpp"
#include "ref/sweep/sweep_io.hpp"

namespace rubref {
namespace {

// Each speed settles 60 revolutions after a 10 rpm step; the free transient decays with
// 2m/c ~ 0.2 s ~ 5.3 revolutions, so e^-11 ~ 2e-5 of the step's change in the orbit remains. That
// change is below 20 % of the amplitude even at resonance: 1e-5 of the amplitude bounds it.
constexpr double kSettledRelTol = 1e-5;

sweep_settings short_sweep(double from, double to, double step) {
  sweep_settings s;
  s.from_rpm = from;
  s.to_rpm = to;
  s.step_rpm = step;
  return s;
}

TEST(sweep, grid_includes_both_ends) {
  EXPECT_EQ(sweep_speeds(short_sweep(1400, 1800, 5)).size(), 81u);
  EXPECT_EQ(sweep_speeds(short_sweep(1400, 1800, 5)).back(), 1800.0);
  EXPECT_EQ(sweep_speeds(short_sweep(1400, 1402, 5)).size(), 1u);
  EXPECT_EQ(sweep_speeds(short_sweep(1000, 1000.3, 0.1)).size(), 4u);  // rounding of 0.3 / 0.1 tolerated
}

TEST(sweep, bad_settings_are_rejected) {
  auto s = short_sweep(1500, 1400, 5);
  EXPECT_THROW(validate(s), input_error);
  s = short_sweep(1400, 1500, 0);
  EXPECT_THROW(validate(s), input_error);
  s = short_sweep(1400, 1500, 5);
  s.record_revs = 10;  // not a multiple of 6
  EXPECT_THROW(validate(s), input_error);
  s.record_revs = 12;
  s.params.k1 = -1;
  EXPECT_THROW(validate(s), input_error);
}

// A summary asked for the 1X alone (rubref orbit's and simulate's) is the full one without the
// spectrum: the same 1X bits (both from spectrum_line) and the same scalars. The full spectrum's
// own 1X lines agree with them to an FFT's round-off relative to the orbit (kLineRelTol: log2 N
// eps per operation over its N = 2560 samples, with margin).
TEST(sweep, a_summary_of_the_1x_alone_is_the_full_one_without_the_spectrum) {
  constexpr double kLineRelTol = 1e-13;
  run_request rub;  // the paper's identified law at 1600 rpm, 0.3 mm: a partial rub
  const orbit o = simulate(rub);
  const orbit_summary full = summarize(o), one_x = summarize(o, summary_spectrum::one_x);
  ASSERT_FALSE(full.spectrum.coefficient.empty());
  EXPECT_TRUE(one_x.spectrum.coefficient.empty());
  EXPECT_EQ(full.forward_1x, one_x.forward_1x);
  EXPECT_EQ(full.backward_1x, one_x.backward_1x);
  EXPECT_EQ(full.max_radius, one_x.max_radius);
  EXPECT_EQ(full.regime, one_x.regime);
  EXPECT_NE(full.regime, contact_regime::no_contact);
  EXPECT_LE(std::abs(full.spectrum.at(+1.0) - full.forward_1x), kLineRelTol * full.max_radius);
  EXPECT_LE(std::abs(full.spectrum.at(-1.0) - full.backward_1x), kLineRelTol * full.max_radius);
}

// Without contact every point of a sweep, in either direction, is the closed-form orbit: the
// continuation carries the state across speeds without disturbing the forcing phase.
TEST(sweep, contact_free_points_are_the_closed_form) {
  auto s = short_sweep(1450, 1650, 10);
  s.params.clearance = 1.0;
  for (const auto d : {sweep_direction::up, sweep_direction::down}) {
    const auto b = run_branch(s, d);
    ASSERT_EQ(b.points.size(), 21u);
    for (const auto& p : b.points) {
      const unbalance_response exact(s.params, rpm_to_rad_s(p.rpm));
      // x = Re(X e^{jwt}), y = Re(Y e^{jwt}) give x + j y = (X + jY)/2 e^{jwt} + (X* + jY*)/2 e^{-jwt}.
      const std::complex<double> j(0.0, 1.0);
      const auto fwd = (exact.x_phasor + j * exact.y_phasor) / 2.0;
      const auto bwd = (std::conj(exact.x_phasor) + j * std::conj(exact.y_phasor)) / 2.0;
      const double scale = std::abs(fwd);
      EXPECT_LE(std::abs(p.summary.forward_1x - fwd), kSettledRelTol * scale) << to_string(d) << " " << p.rpm;
      EXPECT_LE(std::abs(p.summary.backward_1x - bwd), kSettledRelTol * scale) << to_string(d) << " " << p.rpm;
      EXPECT_EQ(p.summary.regime, contact_regime::no_contact);
    }
  }
}

// Above ~1715 rpm at 0.4 mm the contact-free orbit clears the stator, yet the run-up arrives
// there rubbing: two stable responses coexist. The run-down starts contact-free, keeps that orbit
// while it clears the stator, and must jump onto the rubbing branch once it no longer does.
TEST(sweep, coexisting_responses_give_a_band_and_its_jump) {
  auto s = short_sweep(1690, 1760, 10);
  s.params.clearance = 0.4e-3;
  s.first_settle_revs = 300;
  const auto branches = run_branches({{s, sweep_direction::up}, {s, sweep_direction::down}}, 2);
  const auto& up = branches[0];
  const auto& down = branches[1];
  EXPECT_EQ(down.points.front().summary.regime, contact_regime::no_contact);  // 1760 rpm, run-down
  EXPECT_NE(up.points.back().summary.regime, contact_regime::no_contact);     // 1760 rpm, run-up

  const jump_report rep = detect_jumps(up, down, s.step_rpm);
  ASSERT_EQ(rep.bands.size(), 1u);
  EXPECT_EQ(rep.bands[0].to_rpm, 1760.0);
  // Every run-down point in the band is the closed-form, contact-free orbit.
  for (const auto& p : down.points) {
    if (p.rpm < rep.bands[0].from_rpm) continue;
    EXPECT_EQ(p.summary.regime, contact_regime::no_contact) << p.rpm;
    EXPECT_LT(std::abs(unbalance_response(s.params, rpm_to_rad_s(p.rpm)).y_phasor), s.params.clearance) << p.rpm;
  }
  // The run-down jumps up onto the rubbing branch just below the band.
  ASSERT_EQ(rep.jumps.size(), 1u);
  EXPECT_EQ(rep.jumps[0].sweep, sweep_direction::down);
  EXPECT_EQ(rep.jumps[0].from_rpm, rep.bands[0].from_rpm);
  EXPECT_EQ(rep.jumps[0].to_rpm, rep.bands[0].from_rpm - s.step_rpm);
  EXPECT_GT(rep.jumps[0].amplitude_after, rep.jumps[0].amplitude_before);
}

// A sweep that starts each speed on the orbit shot from its neighbour's state (no settling where
// that orbit is stable) reaches the responses the settling sweep does: the same jumps, and at every
// point the same amplitude, to what 60 settling revolutions leave of the step's transient
// (kSettledRelTol) plus what an irregular orbit varies by itself (its radius_spread, both sweeps).
TEST(sweep, starting_from_the_continued_orbit_reaches_the_settled_responses) {
  auto s = short_sweep(1400, 1800, 20);  // through the non-periodic band (1420-1495) and the jump
  s.params.clearance = 0.3e-3;
  auto shot = s;
  shot.start_from_orbit = true;
  const auto b = run_branches({{s, sweep_direction::up}, {s, sweep_direction::down}, {shot, sweep_direction::up}, {shot, sweep_direction::down}}, 2);
  for (int d = 0; d < 2; ++d) {
    const auto& settled = b[static_cast<std::size_t>(d)];
    const auto& from_orbit = b[static_cast<std::size_t>(d + 2)];
    EXPECT_EQ(settled.orbit_starts, 0u);
    EXPECT_GT(from_orbit.orbit_starts, from_orbit.points.size() / 2) << "most points are stable period-1 orbits";
    EXPECT_LT(from_orbit.orbit_starts, from_orbit.points.size()) << "the non-periodic band must settle";
    ASSERT_EQ(settled.points.size(), from_orbit.points.size());
    for (std::size_t i = 0; i < settled.points.size(); ++i) {
      const auto& a = settled.points[i].summary;
      const auto& o = from_orbit.points[i].summary;
      EXPECT_LE(std::abs(a.max_radius - o.max_radius), kSettledRelTol * a.max_radius + a.radius_spread + o.radius_spread)
          << to_string(settled.direction) << " " << settled.points[i].rpm;
      EXPECT_EQ(a.regime, o.regime) << to_string(settled.direction) << " " << settled.points[i].rpm;
    }
  }
  const auto bands = [](const jump_report& r) {
    std::vector<std::pair<double, double>> out;
    for (const auto& band : r.bands) out.emplace_back(band.from_rpm, band.to_rpm);
    return out;
  };
  EXPECT_EQ(bands(detect_jumps(b[0], b[1], s.step_rpm)), bands(detect_jumps(b[2], b[3], s.step_rpm)));
}

// An orbit of 12 revolutions at 64 samples each whose x carries a component of period n revs.
orbit with_period(double n, double share, double noise = 0.0) {
  orbit o;
  o.request.rpm = 1500.0;
  o.request.samples_per_rev = 64;
  o.request.record_revs = 12;
  o.request.params.clearance = 1.0;
  for (int i = 0; i < 12 * 64; ++i) {
    const double th = 2.0 * std::numbers::pi * i / 64.0;
    const double wiggle = noise * std::sin(1e3 * i * i);  // deterministic, irregular
    o.samples.push_back({th / rpm_to_rad_s(1500.0), {1e-3 * (std::cos(th) + share * std::cos(th / n) + wiggle), 1e-3 * std::sin(th), 0.0, 0.0}, 0.0});
  }
  return o;
}

// The period is the smallest whole number of revolutions after which the recorded samples repeat
// to kRepeatRelTol of the orbit's size; an incommensurate component has none.
TEST(orbit_summary, period_is_the_smallest_repetition) {
  for (const int n : {1, 2, 3, 4, 5, 6}) EXPECT_EQ(summarize(with_period(n, 0.2)).period_revs, n) << n;
  EXPECT_EQ(summarize(with_period(std::numbers::sqrt2, 0.2)).period_revs, 0) << "quasi-periodic";
  EXPECT_EQ(summarize(with_period(7, 0.2)).period_revs, 0) << "longer than half the record";
  // A settled orbit's residue (1e-5 of its size) is not a lack of period; a visible one (1e-2) is.
  EXPECT_EQ(summarize(with_period(1, 0.0, 1e-5)).period_revs, 1);
  EXPECT_EQ(summarize(with_period(1, 0.0, 1e-2)).period_revs, 0);
  orbit one_rev = with_period(1, 0.0);
  one_rev.samples.resize(64);
  one_rev.request.record_revs = 1;
  EXPECT_EQ(summarize(one_rev).period_revs, -1) << "one revolution cannot show a repetition";
}

sweep_branch synthetic(sweep_direction d, std::vector<std::pair<double, double>> rpm_amplitude, double spread = 0.0) {
  sweep_branch b{d, {}, {}};
  for (const auto& [rpm, a] : rpm_amplitude) {
    sweep_point p{rpm, {}, {}};
    p.summary.max_radius = a;
    p.summary.radius_spread = spread;
    b.points.push_back(p);
  }
  return b;
}

// A hardening resonance: the run-up rides the high branch to 1030, the run-down the low one to 1010.
TEST(jumps, band_and_jumps_of_a_hysteresis_loop) {
  const auto up = synthetic(sweep_direction::up, {{1000, 1.0}, {1010, 2.0}, {1020, 2.2}, {1030, 2.4}, {1040, 0.5}, {1050, 0.4}});
  const auto down = synthetic(sweep_direction::down, {{1050, 0.4}, {1040, 0.5}, {1030, 0.6}, {1020, 0.8}, {1010, 2.0}, {1000, 1.0}});
  const auto rep = detect_jumps(up, down, 10.0);
  ASSERT_EQ(rep.bands.size(), 1u);
  EXPECT_EQ(rep.bands[0].from_rpm, 1020.0);
  EXPECT_EQ(rep.bands[0].to_rpm, 1030.0);
  EXPECT_EQ(rep.total_width_rpm, 20.0);
  ASSERT_EQ(rep.jumps.size(), 2u);
  EXPECT_EQ(rep.jumps[0].sweep, sweep_direction::up);  // jump down at the top of the band
  EXPECT_EQ(rep.jumps[0].from_rpm, 1030.0);
  EXPECT_EQ(rep.jumps[0].to_rpm, 1040.0);
  EXPECT_EQ(rep.jumps[1].sweep, sweep_direction::down);  // jump up at its bottom
  EXPECT_EQ(rep.jumps[1].from_rpm, 1020.0);
  EXPECT_EQ(rep.jumps[1].to_rpm, 1010.0);
}

// An irregular orbit sampled twice differs by about its own revolution-to-revolution spread:
// that is one attractor, not two.
TEST(jumps, an_irregular_attractor_is_not_a_band) {
  const auto up = synthetic(sweep_direction::up, {{1000, 1.00}, {1010, 1.10}}, 0.06);
  const auto down = synthetic(sweep_direction::down, {{1010, 1.04}, {1000, 1.05}}, 0.06);
  EXPECT_TRUE(detect_jumps(up, down, 10.0).bands.empty());
  const auto steady_up = synthetic(sweep_direction::up, {{1000, 1.00}, {1010, 1.10}});
  const auto steady_down = synthetic(sweep_direction::down, {{1010, 1.04}, {1000, 1.05}});
  EXPECT_EQ(detect_jumps(steady_up, steady_down, 10.0).bands.size(), 1u);  // 5 % apart, no spread: two attractors
}

void expect_bitwise_equal(const sweep_branch& a, const sweep_branch& b) {
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    const auto& x = a.points[i].summary;
    const auto& y = b.points[i].summary;
    for (const auto& [p, q] : {std::pair{x.max_radius, y.max_radius}, std::pair{x.max_penetration, y.max_penetration},
                               std::pair{x.peak_to_peak_x, y.peak_to_peak_x}, std::pair{x.forward_1x.real(), y.forward_1x.real()},
                               std::pair{x.backward_1x.imag(), y.backward_1x.imag()}})
      ASSERT_EQ(std::memcmp(&p, &q, sizeof(double)), 0) << "speed " << a.points[i].rpm;
    ASSERT_EQ(x.spectrum.coefficient, y.spectrum.coefficient);
  }
}

TEST(sweep, same_bits_whatever_the_thread_count) {
  auto s = short_sweep(1540, 1600, 20);
  std::vector<branch_task> tasks;
  for (const double clearance : {0.2e-3, 0.3e-3})
    for (const auto d : {sweep_direction::up, sweep_direction::down}) {
      s.params.clearance = clearance;
      tasks.push_back({s, d});
    }
  const auto one = run_branches(tasks, 1);
  const auto two = run_branches(tasks, 2);
  const auto many = run_branches(tasks, 4);
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    expect_bitwise_equal(one[i], two[i]);
    expect_bitwise_equal(one[i], many[i]);
  }
}

// Calls nested in a parallel_for's tasks share its threads (ref/base/parallel.hpp): together they
// never run more than the outermost call was given, and a thread out of tasks is taken by a
// nested call still running (the loop's check gets its fit's thread when the fit is done).
TEST(sweep, nested_parallel_calls_share_the_outer_threads) {
  // Never more threads than given: both outer tasks run a nested call of many tasks at once.
  for (const unsigned outer : {1u, 2u, 3u}) {
    std::atomic<int> running{0}, most{0};
    parallel_for(2, outer, [&](std::size_t) {
      parallel_for(16, 0, [&](std::size_t) {
        const int now = ++running;
        for (int seen = most.load(); now > seen && !most.compare_exchange_weak(seen, now);) {
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        --running;
      });
    });
    EXPECT_LE(most.load(), static_cast<int>(outer)) << outer << " threads";
  }
  // The finished task's thread helps the other's nested call: task 0 ends at once; task 1 waits
  // (up to kPatience, far beyond any scheduling delay: the wait is for the other thread to leave
  // its loop, not a speed) until its team has a free thread, then its nested tasks must run on
  // two threads.
  constexpr auto kPatience = std::chrono::seconds(20);
  std::set<std::thread::id> ran_on;
  std::mutex ids;
  unsigned free_seen = 0;
  parallel_for(2, 2, [&](std::size_t i) {
    if (i == 0) return;
    const auto until = std::chrono::steady_clock::now() + kPatience;
    while (thread_count(0, 100) < 2 && std::chrono::steady_clock::now() < until) std::this_thread::yield();
    free_seen = thread_count(0, 100);
    std::atomic<int> arrived{0};
    parallel_for(2, 0, [&](std::size_t) {
      {
        const std::lock_guard lock(ids);
        ran_on.insert(std::this_thread::get_id());
      }
      ++arrived;  // each waits for the other, so the two cannot run on one thread in turn
      while (arrived.load() < 2 && std::chrono::steady_clock::now() < until) std::this_thread::yield();
    });
  });
  EXPECT_EQ(free_seen, 2u);
  EXPECT_EQ(ran_on.size(), 2u);
  // Outside any call the count is the caller's again.
  EXPECT_EQ(thread_count(3, 100), 3u);
  EXPECT_EQ(current_team(), nullptr);
}

TEST(sweep_io, tables_have_a_row_per_speed_and_the_reported_orders) {
  auto s = short_sweep(1590, 1610, 10);
  const auto branches = run_branches({{s, sweep_direction::up}, {s, sweep_direction::down}}, 2);
  const table t = sweep_table(s, branches);
  EXPECT_EQ(t.rows.size(), 6u);
  EXPECT_EQ(t.columns.size(), 14u + reported_orders().size());
  const table w = waterfall_table(s, branches[0]);
  // record_revs = 12: order bins of 1/12 from -5 to +5 inclusive, per speed.
  EXPECT_EQ(w.rows.size(), 3u * 121u);
  const auto j = sweep_summary_json(s, branches);
  EXPECT_TRUE(j.contains("jumps"));
  EXPECT_EQ(j["branches"].size(), 2u);
}

}  // namespace
}  // namespace rubref
