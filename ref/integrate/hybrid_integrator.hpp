#pragma once
// Event-exact integration of the rub rotor (docs/model.md, "Integration").
//
// The trajectory is a sequence of phases (free, contact, stuck), each with a smooth right-hand
// side. Every phase has an exit function h(t, s) that is >= 0 while the phase holds:
//   free:    h = -(y - delta)            (contact onset, or an impact, when y rises past delta)
//   contact: h =  (y - delta)            (separation when y falls below delta, Eq. 2)
//   stuck:   h =  free y acceleration    (release when nothing pushes the rotor up any more)
// After each step the integrator looks for h < 0 on the step's dense output: at the step end,
// or at an interior minimum of h (a grazing crossing that enters and leaves within one step).
// The crossing is bracketed by TOMS 748 to `time_tolerance`, the step is cut there, the
// transition applied (phase switch, impact map Eq. 6, sticking rule), and the stepper restarted,
// so no step ever straddles a change of force law.

#include <boost/math/tools/toms748_solve.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <variant>
#include <span>
#include <sstream>
#include <string>

#include "ref/base/cancel.hpp"
#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"
#include "ref/integrate/steppers.hpp"
#include "ref/model/free_flight.hpp"
#include "ref/model/rotor_model.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

enum class event_kind { contact_onset, separation, impact, stick, release };

inline std::string_view to_string(event_kind k) {
  switch (k) {
    case event_kind::contact_onset: return "contact_onset";
    case event_kind::separation: return "separation";
    case event_kind::impact: return "impact";
    case event_kind::stick: return "stick";
    case event_kind::release: return "release";
  }
  return "?";
}

template <class State>
struct basic_contact_event {
  event_kind kind;
  double t;                      // s, located to event_settings::time_tolerance
  State state;                   // the state the next phase starts from (after an impact map)
  double approach_velocity;      // m/s, penetration rate (y_dot) at the event before any impact map
  double max_penetration = 0.0;  // m, peak z of the episode (separation only)
};
using contact_event = basic_contact_event<state_type>;

// Where an integration stands: state, time, phase, and the running peak penetration of an open
// contact episode, so a run can be continued (settle, then record; or a speed sweep).
template <class State>
struct basic_hybrid_state {
  State s{};
  double t = 0.0;
  contact_phase phase = contact_phase::free;
  double episode_peak = 0.0;  // m
};
using hybrid_state = basic_hybrid_state<state_type>;

// What the hybrid integrator needs of a model (docs/concepts.md, "ContactSystem"): an odeint
// System that holds its contact phase, with a penetration z (> 0 inside) and its rate. A model
// whose contact is not `compliant` (an impact map) also gives the stuck phase's exit function
// (the free normal acceleration and its rate) and its law's rebound.
template <class S>
concept contact_system = odeint_system<S> && requires(const S sys, const state_of<S>& x, double t, contact_phase ph) {
  { S::compliant } -> std::convertible_to<bool>;
  { sys.phase() } -> std::same_as<contact_phase>;
  { sys.with_phase(ph) } -> std::same_as<S>;
  { sys.penetration(x) } -> std::same_as<double>;
  { sys.penetration_rate(x) } -> std::same_as<double>;
  { sys.period() } -> std::same_as<double>;
  { sys.clearance() } -> std::same_as<double>;
};

// A model whose free flight is linear says so (ref/model/free_flight.hpp): its dynamics, or
// nothing when a nonlinear term acts out of contact too.
template <class S>
concept linear_free_flight = requires(const S sys) {
  { sys.free_dynamics() } -> std::same_as<std::optional<linear_dynamics<std::tuple_size_v<state_of<S>>>>>;
};

struct event_settings {
  double time_tolerance = default_of("integration", "event_tol");  // s, width of the bracket around each event (<= 1e-12 s)
  // An exact free-flight arc passes over no contact episode deeper than this fraction of the
  // clearance (ref/model/free_flight.hpp): 3e-16 m at the paper's 0.3 mm.
  double min_depth_fraction = 1e-12;
  // Chatter rule (docs/model.md, "Chatter"): an impact ends the accumulation in a stuck phase
  // when its remaining impacts, 2 |v+| / (a (1 - rho)) of time at the free acceleration a and
  // the law's rebound ratio rho, would all fit in this fraction of a revolution.
  double stick_time = default_of("integration", "stick_time");                  // revolutions
  double max_events_per_rev = default_of("integration", "max_events_per_rev");  // more: an accumulation that does not end, an error
};

struct integration_options {
  stepper_settings stepper;
  event_settings events;
  // Free flight in closed form where the model's is linear (ref/model/free_flight.hpp); else,
  // and with false, the stepper integrates it too.
  bool exact_free_flight = true;
  std::size_t max_steps = 0;  // accepted steps per call before a numerical_error (0: no limit);
                              // a fit's trial point with a runaway law fails fast instead of crawling
  // A rotor displaced further than this (|x| or |y|, m) has diverged: a numerical_error naming
  // where, on every path that integrates (simulate, rig, shooting, loop, study, Python). Checked
  // at every step's end, every event and every free arc's end.
  double runaway_displacement = default_of("integration", "runaway_displacement");  // m
};

// Output times: uniform, t0 + k dt for k < count, or the ascending `times` given (`at`).
struct sample_grid {
  double t0 = 0.0;
  double dt = 0.0;
  std::size_t count = 0;
  std::span<const double> times;  // when set, the output times (count = times.size())

  sample_grid() = default;
  sample_grid(double first, double spacing, std::size_t n) : t0(first), dt(spacing), count(n) {}
  static sample_grid at(std::span<const double> ascending) {
    sample_grid g;
    g.count = ascending.size();
    g.times = ascending;
    return g;
  }
  double time(std::size_t k) const { return times.empty() ? t0 + static_cast<double>(k) * dt : times[k]; }
};

// A chatter hop lower than this many resolutions of z cannot be located: the impact before it
// ends the accumulation in sticking (event_settings::stick_time, docs/model.md "Chatter").
inline constexpr double kUnlocatableHop = 8.0;

// A fixed step over a contact whose rate (rotor_system::contact_rate) times dt exceeds this
// resolves it poorly: RK4's relative error per step grows as (rate dt)^5 / 120 (~3e-4 here) and
// it goes unstable at 2.8. Such steps are counted and the commands warn (docs/robustness.md).
inline constexpr double kCoarseContactStep = 0.5;

struct integration_counts {
  std::size_t steps = 0;   // accepted steps
  std::size_t events = 0;  // located events
  std::size_t free_arcs = 0;        // free flights taken in closed form
  std::size_t free_arc_points = 0;  // points of their onset searches
  // Fixed-step runs (rk4) with a compliant law: the steps in contact with rate * dt above
  // kCoarseContactStep, the first one's time, and the largest rate * dt met in contact.
  std::size_t coarse_contact_steps = 0;
  double first_coarse_contact_t = 0.0;  // s
  double max_contact_rate_dt = 0.0;
  double fixed_dt = 0.0;                // s, the rk4 step those were measured with
};

// An observer that wants nothing.
struct null_observer {
  template <class State, class System>
  void on_sample(double, const State&, const System&) {}
  template <class State>
  void on_event(const basic_contact_event<State>&) {}
};

namespace detail {

template <std::size_t N>
std::string describe_state(double t, const std::array<double, N>& s) {
  std::string out = "t = " + format_digits(t, 17) + " s, state (x, y, vx, vy" + (N > 4 ? ", ..." : "") + ") = (";
  for (std::size_t i = 0; i < N; ++i) out += (i ? ", " : "") + format_digits(s[i], 17);
  return out + ")";
}

template <contact_system System>
double exit_value(const System& sys, const state_of<System>& s, double t) {
  switch (sys.phase()) {
    case contact_phase::contact: return sys.penetration(s);
    case contact_phase::stuck:
      if constexpr (!System::compliant) return sys.free_vertical_acceleration(s, t);
      [[fallthrough]];
    default: return -sys.penetration(s);
  }
}

template <contact_system System>
double exit_rate(const System& sys, const state_of<System>& s, double t) {
  switch (sys.phase()) {
    case contact_phase::contact: return sys.penetration_rate(s);
    case contact_phase::stuck:
      if constexpr (!System::compliant) return sys.free_vertical_jerk_stuck(t);
      [[fallthrough]];
    default: return -sys.penetration_rate(s);
  }
}

// Root of f on [a, b] with f(a) and f(b) of opposite signs (or f(a) == 0): returns the bracket.
template <class F>
std::pair<double, double> bracket_root(F&& f, double a, double b, double fa, double fb, double tol) {
  if (fa == 0.0) return {a, a};
  if (fb == 0.0) return {b, b};
  std::uintmax_t max_iter = 200;
  const auto done = [tol](double lo, double hi) {
    return hi - lo <= std::max(tol, 4.0 * std::numeric_limits<double>::epsilon() * std::abs(hi));
  };
  return boost::math::tools::toms748_solve(f, a, b, fa, fb, done, max_iter);
}

// The closed-form free flight of a model whose free flight is linear (empty if not wanted or not
// linear); a model that carries more than its state (the monodromy's) gives its own propagator.
struct no_free_flight {};
template <contact_system System>
auto exact_free_flight_of(const System& sys, bool wanted) {
  if constexpr (requires { sys.free_flight_propagator(); }) {
    return wanted ? sys.free_flight_propagator() : decltype(sys.free_flight_propagator()){};
  } else if constexpr (linear_free_flight<System>) {
    std::optional<free_flight<static_cast<int>(std::tuple_size_v<state_of<System>>)>> out;
    if (wanted)
      if (auto d = sys.free_dynamics()) out.emplace(*d);
    return out;
  } else {
    return std::optional<no_free_flight>{};
  }
}

// What a free flight's arcs turn by along a uniform grid (free_flight::arc::walk); nothing for
// propagators that do not walk.
template <class FreeFlight>
struct walk_step_of {
  using type = std::monostate;
};
template <int N>
struct walk_step_of<free_flight<N>> {
  using type = typename free_flight<N>::arc::phasors;
};

// A System that carries more than its model's state (ref/integrate/shooting.hpp): its events are
// its model's, read from the model's part of the state (`head`).
template <class S>
concept augmented_system = requires(const S sys, const state_of<S>& a) {
  sys.model();
  { S::head(a) } -> std::same_as<state_of<std::remove_cvref_t<decltype(sys.model())>>>;
};

template <class System>
decltype(auto) probe_system(const System& sys) {
  if constexpr (augmented_system<System>) {
    return sys.model();
  } else {
    return (sys);
  }
}

template <class System>
using head_state_t = state_of<std::remove_cvref_t<decltype(probe_system(std::declval<const System&>()))>>;

// function-length: one pass over the steps. Stepping, exit location, sampling and the event
// transitions share the stepper, the phase's system, the hybrid state and the sample cursor; as
// closures over them in one template body, every call in the hot loop is a direct one the
// compiler can inline (no std::function, no state object handed between functions).
template <contact_system System, class Stepper, class Observer>
  requires dense_stepper<Stepper, System>
basic_hybrid_state<state_of<System>> hybrid_loop(const System& base, Stepper& st, basic_hybrid_state<state_of<System>> hs,
                                                 double t_end, const integration_options& opt, const sample_grid& grid,
                                                 Observer& obs, integration_counts& counts) {
  using system = System;
  using state_type = state_of<System>;
  const double tol = opt.events.time_tolerance;
  const double period = base.period();
  const double max_events = opt.events.max_events_per_rev * std::max(1.0, (t_end - hs.t) / period);
  const double t_start = hs.t;
  std::size_t events_here = 0;
  int stalled_events = 0;
  double last_event_t = -std::numeric_limits<double>::infinity();

  system sys = base.with_phase(hs.phase);
  const double first_dt = opt.stepper.kind == stepper_kind::rk4 ? opt.stepper.dt : std::min(opt.stepper.max_dt, period / 1000.0);
  st.initialize(hs.s, hs.t, first_dt);

  // A phase that starts on its own boundary (after every event) is being entered, not left.
  // Free and contact phases start on y = delta; below this, h < 0 is dense-output noise there
  // (Bulirsch-Stoer's reaches ~1e-16 m), above it a real exit. A stuck phase never starts on its
  // boundary (it needs a free acceleration > 0).
  const double boundary_noise = 1e-10 * base.clearance();  // m
  bool entering = exit_value(sys, hs.s, hs.t) <= 0.0;
  std::size_t next_sample = 0;
  while (next_sample < grid.count && grid.time(next_sample) < t_start) ++next_sample;

  state_type tmp{};
  const auto state_at = [&](double t) -> state_type {
    // The step's end is the stepper's own result: exact, and no interpolation to pay for (the
    // checks below ask for it at every step; dense output was ~1/5 of a dopri5 run).
    if (t == st.current_time()) {
      tmp = st.current_state();  // (callers also read tmp)
    } else {
      st.calc_state(t, tmp);
    }
    return tmp;
  };
  // What the exit functions read. A System that carries more than its model's state (the
  // monodromy's 16 entries, ref/integrate/shooting.hpp) is probed on its model alone, and a
  // stepper whose dense output is a step (rkf78) steps only that part for it.
  head_state_t<System> head_tmp{};
  const auto probe_at = [&](double t) -> head_state_t<System> {
    if constexpr (augmented_system<System>) {
      if constexpr (requires { st.calc_head_state(t, head_tmp); }) {
        st.calc_head_state(t, head_tmp);
        return head_tmp;
      } else {
        return System::head(state_at(t));
      }
    } else {
      return state_at(t);
    }
  };
  const auto h_at = [&](double t) { return exit_value(probe_system(sys), probe_at(t), t); };
  const auto hdot_at = [&](double t) { return exit_rate(probe_system(sys), probe_at(t), t); };

  // One accepted step. odeint's controllers accept a trial whose error estimate is NaN, so a
  // step that overflowed (a stiff contact law's stages can, for a step sized in free flight:
  // c2 z_dot^2 has a finite-time blow-up on the way out) comes back non-finite. An adaptive
  // stepper retakes it from its start with an 8 times smaller step; rk4's step is the user's, so
  // there it is an error. odeint's own give-up (step adjustment) is a numerical_error too.
  constexpr int kMaxOverflowRetries = 30;  // 8^-30: far below any useful step
  const bool adaptive = opt.stepper.kind != stepper_kind::rk4;
  const auto accepted_step = [&]() -> std::pair<double, double> {
    for (int retry = 0;; ++retry) {
      std::pair<double, double> span;
      try {
        span = st.do_step(sys);
      } catch (const boost::numeric::odeint::odeint_error& e) {
        throw numerical_error(std::string("stepper gave up (") + e.what() + ") at " + describe_state(hs.t, hs.s));
      }
      if (is_finite(st.current_state())) return span;
      if (!adaptive || retry == kMaxOverflowRetries)
        throw numerical_error("non-finite state after a step from " + describe_state(span.first, hs.s));
      st.initialize(hs.s, hs.t, (span.second - span.first) / 8.0);
    }
  };

  // The runaway guard (integration_options::runaway_displacement).
  const auto require_bounded = [&](double t, const auto& s) {
    const auto& head = [&]() -> decltype(auto) {
      if constexpr (augmented_system<System>) return System::head(s); else return (s);
    }();
    if (!(std::abs(head[idx::x]) <= opt.runaway_displacement && std::abs(head[idx::y]) <= opt.runaway_displacement))
      throw numerical_error("runaway state at " + describe_state(t, head) + ": beyond " + format_digits(opt.runaway_displacement, 3) +
                            " m, the integration diverged");
  };
  // What a stepper's solution knows z and z' to: its error tolerance at the state, and never
  // less than the boundary's dense-output noise.
  const auto stepper_resolution = [&](const head_state_t<System>& s) -> std::pair<double, double> {
    const auto& model = probe_system(sys);
    return {std::max(opt.stepper.rtol * std::abs(s[idx::y]) + opt.stepper.atol, boundary_noise),
            opt.stepper.rtol * std::abs(model.penetration_rate(s)) + opt.stepper.atol};
  };

  // A stepped free flight of an impact law. A step's ends and one interior extremum of h miss an
  // excursion when the step holds more extrema (a chatter hop far shorter than the step, or a
  // slow rotor whose natural period is shorter than the step). The closed-form flight's safe
  // march (ref/model/free_flight.hpp) on the dense output, with the model's bound M on |y''|
  // over the step, does not: from a point with h >= 0 the next is the root of h + h' tau -
  // M tau^2 / 2, so no excursion deeper than the resolution is passed over.
  constexpr bool steps_free_flight_safely =
      !System::compliant && requires(const head_state_t<System>& x) { probe_system(std::declval<const System&>()).free_vertical_acceleration_bound(x, 1.0); };
  const auto march_free = [&](double from, double to) -> std::optional<std::pair<double, double>> {
    if constexpr (steps_free_flight_safely) {
      const auto& model = probe_system(sys);
      const auto s0 = probe_at(from);
      const double M = model.free_vertical_acceleration_bound(s0, to - from);
      const double res = stepper_resolution(s0).first;
      const double min_tau = std::sqrt(2.0 * res / M);
      double a = from, ha = -model.penetration(s0), ra = -model.penetration_rate(s0);
      double t_out = from, h_out = std::max(ha, 0.0);  // the last point seen outside (h >= 0)
      while (a < to) {
        // Largest tau with ha + ra tau - M tau^2 / 2 >= 0, in a cancellation-free form.
        const double h0 = std::max(ha, 0.0), disc = std::sqrt(ra * ra + 2.0 * M * h0);
        const double tau = std::max(ra < 0.0 ? 2.0 * h0 / (disc - ra) : (ra + disc) / M, min_tau);
        const double b = std::min(a + tau, to);
        const auto sb = probe_at(b);
        const double hb = -model.penetration(sb);
        if (hb < -res) return bracket_root(h_at, t_out, b, h_out, hb, tol);
        if (hb >= 0.0) {
          t_out = b;
          h_out = hb;
        }
        a = b;
        ha = hb;
        ra = -model.penetration_rate(sb);
      }
    }
    return std::nullopt;
  };

  // Exact free flight (ref/model/free_flight.hpp) where the model's is linear.
  auto exact = exact_free_flight_of(base, opt.exact_free_flight);
  // A uniform grid's step, as free arcs walk along it (made at the first arc that needs it).
  std::optional<typename walk_step_of<typename decltype(exact)::value_type>::type> grid_step;
  const double min_depth = opt.events.min_depth_fraction * base.clearance();
  double step_hint = first_dt;  // the next numeric step's size

  // The transition at a located exit [inside, outside] of the current phase, the state read from
  // state_of_t, known to res = (z, z') resolution; then the next phase starts (at the same time)
  // from the state it returns.
  const auto transit = [&](const std::pair<double, double>& bracket, const auto& state_of_t, std::pair<double, double> res) {
    // Transition at the located event. Onset, separation and release start the next phase from
    // the bracket end already inside it (so its exit function starts >= 0); an impact maps the
    // velocity at the bracket end still outside the stator.
    basic_contact_event<state_type> ev{};
    const system before = sys;
    state_type pre{};  // the state before a reset (an impact's or a stick's)
    if constexpr (System::compliant) {
      ev.t = bracket.second;
      ev.state = state_of_t(ev.t);
      ev.approach_velocity = sys.penetration_rate(ev.state);
      if (sys.phase() == contact_phase::free) {
        ev.kind = event_kind::contact_onset;
        hs.phase = contact_phase::contact;
        hs.episode_peak = std::max(0.0, sys.penetration(ev.state));
      } else {
        ev.kind = event_kind::separation;
        ev.max_penetration = hs.episode_peak;
        hs.phase = contact_phase::free;
        hs.episode_peak = 0.0;
      }
    } else if (sys.phase() == contact_phase::free) {
      // Chatter rule (docs/model.md, "Chatter"). An impact only for an approaching velocity,
      // beyond what the flight knows it to (res.second); then y is put on the face. A rotor
      // that arrives at rest to that resolution sticks if pressed on the face beyond the free
      // acceleration's rounding, and else only touches it (an impact at zero speed). An impact
      // whose remaining chatter would fit in stick_time, or whose next hop would be too small
      // to locate, ends the accumulation in a stuck phase.
      ev.t = bracket.first;
      ev.state = state_of_t(ev.t);
      pre = ev.state;
      const double v = ev.state[idx::vy];
      ev.approach_velocity = v;
      state_type at_stator = ev.state;
      at_stator[idx::y] = base.clearance();
      at_stator[idx::vy] = 0.0;
      const double a = sys.free_vertical_acceleration(at_stator, ev.t);
      const bool pressed = a > sys.free_vertical_acceleration_rounding(at_stator, ev.t);
      const bool approaching = v > res.second;
      const double rebound = base.law().rebound_velocity(approaching ? v : std::max(v, 0.0));
      bool sticks = pressed && !approaching;
      if (pressed && approaching) {
        const double rho = std::abs(rebound) / v;  // the law's rebound ratio (r)
        const double remaining = rho < 1.0 ? 2.0 * std::abs(rebound) / (a * (1.0 - rho)) : std::numeric_limits<double>::infinity();
        sticks = remaining <= opt.events.stick_time * period || rebound * rebound <= 2.0 * a * kUnlocatableHop * res.first;
      }
      if (sticks) {
        ev.kind = event_kind::stick;
        ev.state = at_stator;
        hs.phase = contact_phase::stuck;
      } else {
        ev.kind = event_kind::impact;
        ev.state[idx::y] = base.clearance();
        ev.state[idx::vy] = rebound;
      }
    } else {  // stuck -> free
      ev.t = bracket.second;
      ev.state = state_of_t(ev.t);
      ev.approach_velocity = 0.0;
      ev.kind = event_kind::release;
      hs.phase = contact_phase::free;
    }

    require_bounded(ev.t, ev.state);
    ++counts.events;
    if (++events_here > max_events)
      throw numerical_error("more than " + std::to_string(static_cast<long long>(max_events)) +
                            " contact events: an accumulation of impacts that does not terminate, at " +
                            describe_state(ev.t, ev.state));
    stalled_events = ev.t > last_event_t ? 0 : stalled_events + 1;
    constexpr int kMaxEventsWithoutProgress = 64;
    if (stalled_events > kMaxEventsWithoutProgress)
      throw numerical_error("events do not advance in time at " + describe_state(ev.t, ev.state));
    last_event_t = ev.t;

    sys = base.with_phase(hs.phase);
    // A model that carries its sensitivity maps it across the event (ref/integrate/shooting.hpp).
    if constexpr (requires { sys.after_event(before, ev.kind, ev.t, pre, ev.state); })
      ev.state = sys.after_event(before, ev.kind, ev.t, System::compliant || ev.kind == event_kind::release ? ev.state : pre, ev.state);
    obs.on_event(ev);
    // Free and contact phases start on y = delta. A stuck phase starts where the free
    // acceleration is > 0, not on its boundary: its exit may come within the first step.
    entering = hs.phase != contact_phase::stuck;
    hs.s = ev.state;
    hs.t = ev.t;
    st.initialize(hs.s, hs.t, step_hint);
  };

  while (hs.t < t_end) {
    throw_if_stop_requested();  // a front end's interrupt (ref/base/cancel.hpp), once per step or arc
    if constexpr (!std::is_same_v<decltype(exact), std::optional<no_free_flight>>) {
    if (exact && sys.phase() == contact_phase::free) {
      // A whole free flight at once: to the first onset (or impact), or to t_end.
      const auto arc = exact->from(hs.t, hs.s);
      ++counts.free_arcs;
      std::optional<std::pair<double, double>> onset;
      try {
        onset = arc.first_onset(hs.t, t_end, min_depth, tol, period / 8.0, &counts.free_arc_points);
      } catch (const numerical_error& e) {
        throw numerical_error(std::string(e.what()) + " on the free flight from " + describe_state(hs.t, hs.s));
      }
      const double t_stop = onset ? onset->first : t_end;
      if constexpr (requires { exact->step_phasors(1.0); }) {
        if (grid.times.empty() && next_sample < grid.count && grid.time(next_sample) <= t_stop) {
          // A uniform grid: the arc walked along it (free_flight::arc::walk), its step's phasors
          // made once per integration.
          if (!grid_step) grid_step = exact->step_phasors(grid.dt);
          auto walk = arc.walk_by(*grid_step);
          while (next_sample < grid.count && grid.time(next_sample) <= t_stop) {
            const double ts = grid.time(next_sample++);
            obs.on_sample(ts, walk.next(ts), sys);
          }
        }
      }
      while (next_sample < grid.count && grid.time(next_sample) <= t_stop) {
        const double ts = grid.time(next_sample++);
        obs.on_sample(ts, arc.at(ts), sys);
      }
      if (!onset) {
        const auto end = arc.at(t_end);
        if (!std::all_of(end.begin(), end.end(), [](double v) { return std::isfinite(v); }))
          throw numerical_error("non-finite state at the end of the free flight from " + describe_state(hs.t, hs.s));
        require_bounded(t_end, end);
        hs.s = end;
        hs.t = t_end;
        break;
      }
      const auto round = arc.rounding(onset->first);
      transit(*onset, [&](double t) { return arc.at(t); }, {std::max(round.first, min_depth), round.second});
      continue;
    }
    }
    const auto [ta, tb] = accepted_step();
    ++counts.steps;
    if (opt.max_steps > 0 && counts.steps > opt.max_steps)
      throw numerical_error("more than " + std::to_string(opt.max_steps) + " steps at " + describe_state(tb, st.current_state()));
    const double next_dt = st.current_time_step();
    if (!(next_dt > 16.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(tb))))
      throw numerical_error("step size underflow (dt = " + format_digits(next_dt) + " s) at " +
                            describe_state(tb, st.current_state()));

    if constexpr (requires { sys.contact_rate(st.current_state()); }) {
      if (!adaptive && sys.phase() == contact_phase::contact) {
        const double rate_dt = sys.contact_rate(st.current_state()) * (tb - ta);
        counts.max_contact_rate_dt = std::max(counts.max_contact_rate_dt, rate_dt);
        counts.fixed_dt = tb - ta;
        if (rate_dt > kCoarseContactStep && counts.coarse_contact_steps++ == 0) counts.first_coarse_contact_t = tb;
      }
    }

    const double t_hi = std::min(tb, t_end);
    const double h_lo = exit_value(sys, hs.s, ta), r_lo = exit_rate(sys, hs.s, ta);
    const double h_hi = h_at(t_hi), r_hi = hdot_at(t_hi);
    std::optional<std::pair<double, double>> bracket;  // [inside, outside] around the first exit
    if (entering) {
      // The phase began on its boundary (h ~ 0) moving inwards. Within a few ulps of ta a dense
      // output may read h slightly negative (Bulirsch-Stoer's does, by ~1e-16 m); that is not an
      // exit. An exit in this step must come after h's first maximum.
      if (h_hi > 0.0) {
        entering = false;
      } else if (r_hi < 0.0) {
        if (r_lo > 0.0) {
          const auto [m_lo, m_hi] = bracket_root(hdot_at, ta, t_hi, r_lo, r_hi, tol);
          const double t_max = 0.5 * (m_lo + m_hi), h_max = h_at(t_max);
          bracket = h_max > 0.0 ? bracket_root(h_at, t_max, t_hi, h_max, h_hi, tol) : std::pair{t_max, t_max};
        } else {
          bracket = std::pair{ta, ta};  // it never moved inside: a zero-depth touch
        }
      } else if (h_hi < -boundary_noise) {
        // Well outside at the step end and turning back: a whole excursion (a chatter hop, which
        // can be far shorter than any step cap) went in and out within this step, and h has two
        // extrema here. h > 0 from ta to the exit and < 0 after it, so the largest
        // ta + (t_hi - ta) / 2^k with h > 0 brackets the exit with t_hi. In contact that is a
        // whole episode inside one step: an adaptive step is accurate through it by its error
        // control, a fixed rk4 step has not resolved it and its result cannot be trusted.
        if (!adaptive && sys.phase() == contact_phase::contact)
          throw numerical_error("the fixed rk4 step (dt = " + format_digits(opt.stepper.dt) +
                                " s) does not resolve a contact episode: it began and ended within one step from " +
                                describe_state(ta, hs.s) + "; use a smaller dt or an adaptive stepper");
        double t_in = ta, h_in = 0.0;
        for (double span = 0.5 * (t_hi - ta); span > tol; span *= 0.5) {
          h_in = h_at(ta + span);
          if (h_in > 0.0) {
            t_in = ta + span;
            break;
          }
        }
        bracket = t_in > ta ? bracket_root(h_at, t_in, t_hi, h_in, h_hi, tol) : std::pair{ta, ta};
      }  // else: still on the boundary (to dense-output noise), still moving in
    } else if (h_hi < 0.0) {
      bracket = bracket_root(h_at, ta, t_hi, std::max(0.0, h_lo), h_hi, tol);
    } else if (r_lo < 0.0 && r_hi > 0.0) {
      // h has an interior minimum: does a grazing exit hide between the step ends?
      const auto [m_lo, m_hi] = bracket_root(hdot_at, ta, t_hi, r_lo, r_hi, tol);
      const double t_min = 0.5 * (m_lo + m_hi), h_min = h_at(t_min);
      if (h_min < 0.0) bracket = bracket_root(h_at, ta, t_min, std::max(0.0, h_lo), h_min, tol);
    }
    if constexpr (steps_free_flight_safely) {
      if (!bracket && sys.phase() == contact_phase::free) bracket = march_free(ta, t_hi);
    }
    const bool crossed = bracket.has_value();
    const double t_stop = crossed ? bracket->first : t_hi;
    // After the step's own checks, which say more about what went wrong.
    require_bounded(tb, st.current_state());

    // Peak penetration of an open contact episode: step end, and an interior maximum of z.
    if (sys.phase() == contact_phase::contact) {
      const auto& model = probe_system(sys);
      const auto lo = probe_at(ta), hi = probe_at(t_stop);
      const double v_lo = model.penetration_rate(lo), v_hi = model.penetration_rate(hi);
      hs.episode_peak = std::max({hs.episode_peak, model.penetration(lo), model.penetration(hi)});
      if (v_lo > 0.0 && v_hi < 0.0) {
        const auto rate_at = [&](double t) { return model.penetration_rate(probe_at(t)); };
        const auto [p_lo, p_hi] = bracket_root(rate_at, ta, t_stop, v_lo, v_hi, tol);
        hs.episode_peak = std::max(hs.episode_peak, model.penetration(probe_at(0.5 * (p_lo + p_hi))));
      }
    }

    // Samples up to the stop (at an event time they still belong to the phase that ends there).
    while (next_sample < grid.count && grid.time(next_sample) <= t_stop) {
      const double ts = grid.time(next_sample++);
      obs.on_sample(ts, state_at(std::max(ts, ta)), sys);  // ts < ta only inside an event bracket
    }

    if (!crossed) {
      if (tb >= t_end) {
        hs.s = state_at(t_end);
        hs.t = t_end;
      } else {
        hs.s = st.current_state();
        hs.t = tb;
      }
      continue;
    }

    step_hint = std::min(next_dt, tb - ta);
    transit(*bracket, state_at, stepper_resolution(probe_at(bracket->first)));
  }
  return hs;
}

}  // namespace detail

// The phase a trajectory starting at s is in. An impact law cannot start inside the stator.
template <contact_system System>
basic_hybrid_state<state_of<System>> start_state(const System& sys, const state_of<System>& s, double t) {
  basic_hybrid_state<state_of<System>> hs{s, t, contact_phase::free, 0.0};
  const double z = sys.penetration(s);
  if (z > 0.0) {
    if constexpr (!System::compliant) {
      throw input_error("initial state is inside the stator (y > clearance), impossible for an impact law");
    } else {
      hs.phase = contact_phase::contact;
      hs.episode_peak = z;
    }
  }
  return hs;
}

// Any observer behind one type per system, so the integrator is compiled once per system (in
// ref/integrate/instances_*.cpp, for every variant) instead of once per observer in every file
// that integrates. One indirect call per sample or event: nothing beside a step.
template <class System>
class observer_ref {
 public:
  using state = state_of<System>;
  template <class Observer>
    requires(!std::same_as<Observer, observer_ref>)
  explicit observer_ref(Observer& obs) noexcept
      : obs_(&obs),
        sample_([](void* o, double t, const state& s, const System& sys) { static_cast<Observer*>(o)->on_sample(t, s, sys); }),
        event_([](void* o, const basic_contact_event<state>& e) { static_cast<Observer*>(o)->on_event(e); }) {}
  void on_sample(double t, const state& s, const System& sys) { sample_(obs_, t, s, sys); }
  void on_event(const basic_contact_event<state>& e) { event_(obs_, e); }

 private:
  void* obs_;
  void (*sample_)(void*, double, const state&, const System&);
  void (*event_)(void*, const basic_contact_event<state>&);
};

namespace detail {
template <contact_system System>
basic_hybrid_state<state_of<System>> integrate_erased(const System& model, const basic_hybrid_state<state_of<System>>& start, double t_end,
                                                      const integration_options& opt, const sample_grid& grid, observer_ref<System> obs,
                                                      integration_counts* counts) {
  integration_counts local;
  integration_counts& c = counts ? *counts : local;
  integration_options resolved = opt;
  resolved.stepper = with_default_steps(opt.stepper, model.period());
  return with_stepper<System>(resolved.stepper, [&](auto& st) { return hybrid_loop(model, st, start, t_end, resolved, grid, obs, c); });
}
}  // namespace detail

// Integrates from `start` to t_end, reporting samples on `grid` and every located event.
template <contact_system System, class Observer = null_observer>
basic_hybrid_state<state_of<System>> integrate_hybrid(const System& model, const basic_hybrid_state<state_of<System>>& start,
                                                      double t_end, const integration_options& opt, const sample_grid& grid,
                                                      Observer& obs, integration_counts* counts = nullptr) {
  return detail::integrate_erased<System>(model, start, t_end, opt, grid, observer_ref<System>(obs), counts);
}

// The rotor models of every variant are integrated by the instances compiled once in
// ref/integrate/instances_models.cpp; other systems (tests' own) instantiate here as usual.
#define RUBREF_INTEGRATOR_INSTANCE(PREFIX, SYSTEM)                                                                                 \
  PREFIX template basic_hybrid_state<state_of<SYSTEM>> detail::integrate_erased<SYSTEM>(                                            \
      const SYSTEM&, const basic_hybrid_state<state_of<SYSTEM>>&, double, const integration_options&, const sample_grid&,        \
      observer_ref<SYSTEM>, integration_counts*);
#define RUBREF_EXTERN_MODEL_INTEGRATOR(LAW) RUBREF_INTEGRATOR_INSTANCE(extern, rotor_system<LAW>)
#define RUBREF_EXTERN_EFFECTS_INTEGRATOR(LAW) RUBREF_INTEGRATOR_INSTANCE(extern, rotor_with_effects<LAW>)
RUBREF_FOR_EACH_VARIANT(RUBREF_EXTERN_MODEL_INTEGRATOR)
RUBREF_FOR_EACH_COMPLIANT_VARIANT(RUBREF_EXTERN_EFFECTS_INTEGRATOR)
#undef RUBREF_EXTERN_MODEL_INTEGRATOR
#undef RUBREF_EXTERN_EFFECTS_INTEGRATOR

}  // namespace rubref
