#pragma once
// Boost.Odeint steppers behind one dense-output interface, so the hybrid integrator can locate
// events on any of them (docs/concepts.md, "DenseStepper"):
//
//   initialize(s, t, dt0)     restart at (s, t), e.g. after an event
//   do_step(system) -> (ta,tb) one accepted step
//   calc_state(t, s)          the solution at any t in [ta, tb]
//   current_state(), current_time(), current_time_step()
//
// dopri5 and Bulirsch-Stoer use odeint's own dense output. rk4 (fixed step) and rkf78 have none;
// for them calc_state re-takes one step of the same method from ta to t, which is the method's own
// continuous extension: the event found is where the discrete solution crosses, at full order.

#include "ref/integrate/odeint.hpp"

#include <cmath>
#include <concepts>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>

#include "ref/base/errors.hpp"
#include "ref/model/settings.hpp"
#include "ref/model/state.hpp"

namespace rubref {

// The state a System integrates: its own `state_type` (a fixed-size std::array; the rotor's is
// rubref::state_type, the virtual rig's carries the stator too).
template <class System>
using state_of = typename System::state_type;

// An odeint System (Boost.Odeint doc/concepts/system.qbk) over its own state type.
template <class S>
concept odeint_system = std::copy_constructible<S> && requires(const S sys, const state_of<S>& x, state_of<S>& dxdt, double t) {
  sys(x, dxdt, t);
};

// What the hybrid integrator needs of a stepper (docs/concepts.md, "DenseStepper").
template <class S, class System>
concept dense_stepper = requires(S st, const S cst, const System& sys, const state_of<System>& x, state_of<System>& out, double t) {
  st.initialize(x, t, t);
  { st.do_step(sys) } -> std::convertible_to<std::pair<double, double>>;
  cst.calc_state(t, out);
  { cst.current_state() } -> std::convertible_to<const state_of<System>&>;
  { cst.current_time() } -> std::convertible_to<double>;
  { cst.current_time_step() } -> std::convertible_to<double>;
};

enum class stepper_kind { rk4, dopri5, rkf78, bulirsch_stoer };

inline constexpr std::array<std::pair<stepper_kind, std::string_view>, 4> stepper_names{{
    {stepper_kind::rk4, "rk4"},
    {stepper_kind::dopri5, "dopri5"},
    {stepper_kind::rkf78, "rkf78"},
    {stepper_kind::bulirsch_stoer, "bulirsch-stoer"},
}};

inline std::string_view to_string(stepper_kind k) {
  for (const auto& [kind, name] : stepper_names)
    if (kind == k) return name;
  return "?";
}

inline stepper_kind parse_stepper(std::string_view name) {
  for (const auto& [kind, n] : stepper_names)
    if (n == name) return kind;
  std::vector<std::string> names;
  for (const auto& [kind, n] : stepper_names) names.emplace_back(n);
  throw input_error("unknown stepper '" + std::string(name) + "'" + did_you_mean(name, names) + " (rk4, dopri5, rkf78, bulirsch-stoer)");
}

// A System that takes the unbalance direction instead of t (rotor_system does; the rig's does not).
template <class S>
concept phasor_system = requires(const S sys, const state_of<S>& x, state_of<S>& dxdt, double t) {
  sys(x, dxdt, forcing_phasor{1.0, 0.0});
  { sys.forcing_angle(t) } -> std::convertible_to<double>;
  { sys.omega() } -> std::convertible_to<double>;
};

// Fixed-step classical RK4. For a phasor_system the hand-written step below: the same method as
// odeint's runge_kutta4, with the forcing's (cos, sin) turned by w dt/2 between stages (one
// complex multiply) instead of evaluated (docs/performance.md), re-synchronised with the angle
// every kPhasorResync steps (rotation rounding grows ~1 ulp per step). Other Systems go through
// odeint's runge_kutta4.
template <class System>
class rk4_dense {
  using state_type = state_of<System>;
  static constexpr int kPhasorResync = 64;

 public:
  explicit rk4_dense(double dt) : dt_(dt) {}

  void initialize(const state_type& s, double t, double /*dt0*/) {
    cur_ = prev_ = s;
    t_ = t_prev_ = t;
    since_sync_ = kPhasorResync;  // the next step starts from the exact angle
  }
  std::pair<double, double> do_step(const System& sys) {
    sys_.emplace(sys);
    prev_ = cur_;
    t_prev_ = t_;
    if constexpr (phasor_system<System>) {
      if (half_turn_omega_ != sys.omega()) {
        half_turn_omega_ = sys.omega();
        half_turn_ = phasor_of(0.5 * sys.omega() * dt_);
      }
      if (since_sync_ >= kPhasorResync) {
        phasor_ = phasor_of(sys.forcing_angle(t_prev_));  // (ref/model/state.hpp)
        since_sync_ = 0;
      }
      phasor_prev_ = phasor_;
      phasor_ = step(*sys_, prev_, cur_, dt_, phasor_, half_turn_);
      ++since_sync_;
    } else {
      stepper_.do_step(*sys_, prev_, t_prev_, cur_, dt_);
    }
    t_ = t_prev_ + dt_;
    return {t_prev_, t_};
  }
  void calc_state(double t, state_type& out) const {
    if (t == t_) {
      out = cur_;
    } else if (t == t_prev_) {
      out = prev_;
    } else if constexpr (phasor_system<System>) {
      const double h = t - t_prev_;
      step(*sys_, prev_, out, h, phasor_prev_, phasor_of(0.5 * sys_->omega() * h));
    } else {
      stepper_.do_step(*sys_, prev_, t_prev_, out, t - t_prev_);
    }
  }
  const state_type& current_state() const { return cur_; }
  double current_time() const { return t_; }
  double current_time_step() const { return dt_; }

  // One classical RK4 step of size h from x (forcing p0 at its start; half_turn = w h / 2) into
  // out; returns the forcing at its end.
  static forcing_phasor step(const System& sys, const state_type& x, state_type& out, double h, forcing_phasor p0,
                             forcing_phasor half_turn) {
    const forcing_phasor p1 = rotated(p0, half_turn), p2 = rotated(p1, half_turn);
    state_type k1, k2, k3, k4, xs;
    const std::size_t n = x.size();
    sys(x, k1, p0);
    for (std::size_t i = 0; i < n; ++i) xs[i] = x[i] + 0.5 * h * k1[i];
    sys(xs, k2, p1);
    for (std::size_t i = 0; i < n; ++i) xs[i] = x[i] + 0.5 * h * k2[i];
    sys(xs, k3, p1);
    for (std::size_t i = 0; i < n; ++i) xs[i] = x[i] + h * k3[i];
    sys(xs, k4, p2);
    for (std::size_t i = 0; i < n; ++i) out[i] = x[i] + (h / 6.0) * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    return p2;
  }

 private:
  double dt_;
  mutable boost::numeric::odeint::runge_kutta4<state_type> stepper_;
  std::optional<System> sys_;
  state_type cur_{}, prev_{};
  double t_ = 0.0, t_prev_ = 0.0;
  forcing_phasor phasor_{1.0, 0.0}, phasor_prev_{1.0, 0.0}, half_turn_{1.0, 0.0};
  double half_turn_omega_ = std::numeric_limits<double>::quiet_NaN();
  int since_sync_ = kPhasorResync;
};

// Adaptive Runge-Kutta-Fehlberg 7(8) (odeint controlled_runge_kutta<runge_kutta_fehlberg78>).
// (GCC 12's uninitialized warnings on its stage buffers: see the odeint include above.)
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif
// odeint's error checker, with the components past the model's own state (a sensitivity flow's
// Phi, ref/integrate/shooting.hpp) held to kSensitivityToleranceFactor times looser tolerances:
// Newton and the Floquet multipliers need Phi to ~1e-9, not to the state's 1e-12, and without
// this Phi sets ~1/4 of the steps. The state's own components are checked exactly as before.
inline constexpr double kSensitivityToleranceFactor = 1e3;
template <std::size_t Head>
class head_error_checker : public boost::numeric::odeint::default_error_checker<double, boost::numeric::odeint::array_algebra,
                                                                                   boost::numeric::odeint::default_operations> {
  using base = boost::numeric::odeint::default_error_checker<double, boost::numeric::odeint::array_algebra,
                                                             boost::numeric::odeint::default_operations>;

 public:
  using base::base;
  template <class S, class Deriv, class Err, class Time>
  double error(algebra_type& algebra, const S& x_old, const Deriv& dxdt_old, Err& x_err, Time dt) const {
    base::error(algebra, x_old, dxdt_old, x_err, dt);  // x_err_i / tol_i, in place
    for (std::size_t i = Head; i < x_err.size(); ++i) x_err[i] *= 1.0 / kSensitivityToleranceFactor;
    return algebra.norm_inf(x_err);
  }
};

template <class System>
class rkf78_dense {
  using state_type = state_of<System>;
  using error_stepper = boost::numeric::odeint::runge_kutta_fehlberg78<state_type>;
  template <class S>
  struct checker_of {
    using type = boost::numeric::odeint::default_error_checker<double, boost::numeric::odeint::array_algebra,
                                                               boost::numeric::odeint::default_operations>;
  };
  template <class S>
    requires requires(const S& s) { s.model(); }
  struct checker_of<S> {
    using type = head_error_checker<std::tuple_size_v<typename std::remove_cvref_t<decltype(std::declval<const S&>().model())>::state_type>>;
  };
  using controlled = boost::numeric::odeint::controlled_runge_kutta<error_stepper, typename checker_of<System>::type>;

 public:
  rkf78_dense(double atol, double rtol, double max_dt)
      : controlled_(typename controlled::error_checker_type(atol, rtol),
                    typename controlled::step_adjuster_type(max_dt)) {}

  void initialize(const state_type& s, double t, double dt0) {
    cur_ = prev_ = s;
    t_ = t_prev_ = t;
    dt_ = dt0;
  }
  std::pair<double, double> do_step(const System& sys) {
    using boost::numeric::odeint::fail;
    sys_.emplace(sys);
    prev_ = cur_;
    t_prev_ = t_;
    // As odeint's failed_step_checker: a step that keeps failing is a numerical fault.
    constexpr int kMaxRejectedSteps = 500;
    for (int rejected = 0; controlled_.try_step(*sys_, prev_, t_, cur_, dt_) == fail; ++rejected) {
      if (rejected == kMaxRejectedSteps) {
        std::ostringstream msg;
        msg << "rkf78: " << kMaxRejectedSteps << " rejected steps in a row at t = " << t_ << " s";
        throw numerical_error(msg.str());
      }
    }
    return {t_prev_, t_};
  }
  void calc_state(double t, state_type& out) const {
    if (t == t_) {
      out = cur_;
    } else if (t == t_prev_) {
      out = prev_;
    } else {
      plain_.do_step(*sys_, prev_, t_prev_, out, t - t_prev_);
    }
  }
  // The model's own state at t, for a System that carries more (the monodromy's): the step of
  // the model alone, which gives the same bits as the head of the whole step (the model's
  // right-hand side does not read the rest, and odeint's algebra is per component) at a fifth of
  // the work. The event searches read only this.
  template <class Head>
  void calc_head_state(double t, Head& out) const
    requires requires(const System& s, const state_type& a) { s.model(); System::head(a); }
  {
    if (t == t_) {
      out = System::head(cur_);
    } else if (t == t_prev_) {
      out = System::head(prev_);
    } else {
      plain_head_.do_step(sys_->model(), System::head(prev_), t_prev_, out, t - t_prev_);
    }
  }
  const state_type& current_state() const { return cur_; }
  double current_time() const { return t_; }
  double current_time_step() const { return dt_; }

 private:
  // The model's state when System carries more; state_type otherwise (then unused).
  template <class S>
  struct head_of {
    using type = state_type;
  };
  template <class S>
    requires requires(const S& s) { s.model(); }
  struct head_of<S> {
    using type = typename std::remove_cvref_t<decltype(std::declval<const S&>().model())>::state_type;
  };
  using head_state = typename head_of<System>::type;

  controlled controlled_;
  mutable error_stepper plain_;
  mutable boost::numeric::odeint::runge_kutta_fehlberg78<head_state> plain_head_;
  std::optional<System> sys_;
  state_type cur_{}, prev_{};
  double t_ = 0.0, t_prev_ = 0.0, dt_ = 0.0;
};
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

struct stepper_settings {
  stepper_kind kind = stepper_kind::dopri5;
  double rtol = default_of("integration", "rtol");      // -, relative tolerance (adaptive steppers)
  double atol = default_of("integration", "atol");      // m and m/s, absolute tolerance (adaptive steppers)
  double dt = default_of("integration", "dt");          // s, fixed step of rk4; 0 = period / kDefaultStepsPerRev
  double max_dt = default_of("integration", "max_dt");  // s, largest adaptive step; 0 = period / kDefaultMinStepsPerRev
};

// Newton shooting's convergence on the one-revolution map, |P(s) - s| (positions in m, velocities
// / |w|), the registry's `tolerance`: the one value every shooting starts from
// (shooting_settings, the periodic-orbit and continuation requests, the golden cases).
inline constexpr double kShootingTolerance = default_of("", "tolerance");

// rk4's default step resolves a contact episode of the paper's k1 (about 2 ms, 1/20 rev) with
// about 50 steps. The adaptive cap keeps at most one extremum of y per step, which the grazing
// check of the hybrid integrator relies on.
inline constexpr double kDefaultStepsPerRev = 1024.0;
inline constexpr double kDefaultMinStepsPerRev = 16.0;

// Fills unset step sizes from the revolution period (s).
inline stepper_settings with_default_steps(stepper_settings s, double period) {
  if (!(s.dt > 0.0)) s.dt = period / kDefaultStepsPerRev;
  if (!(s.max_dt > 0.0)) s.max_dt = period / kDefaultMinStepsPerRev;
  return s;
}

// Builds the stepper named in `s` for `System` and passes it to f; f is instantiated per stepper.
template <class System, class F>
decltype(auto) with_stepper(const stepper_settings& s, F&& f) {
  namespace ode = boost::numeric::odeint;
  using state_type = state_of<System>;
  switch (s.kind) {
    case stepper_kind::rk4: {
      rk4_dense<System> st(s.dt);
      return f(st);
    }
    case stepper_kind::dopri5: {
      auto st = ode::make_dense_output(s.atol, s.rtol, s.max_dt, ode::runge_kutta_dopri5<state_type>());
      return f(st);
    }
    case stepper_kind::rkf78: {
      rkf78_dense<System> st(s.atol, s.rtol, s.max_dt);
      return f(st);
    }
    case stepper_kind::bulirsch_stoer: {
      ode::bulirsch_stoer_dense_out<state_type> st(s.atol, s.rtol, 1.0, 1.0, s.max_dt);
      return f(st);
    }
  }
  throw input_error("unknown stepper");
}

}  // namespace rubref
