#include "ref/orbits/continuation.hpp"

#include <Eigen/Dense>
#include <boost/math/tools/minima.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include "ref/base/errors.hpp"
#include "ref/format/record.hpp"
#include "ref/integrate/shooting.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

std::string_view to_string(continuation_parameter p) {
  switch (p) {
    case continuation_parameter::speed: return "speed";
    case continuation_parameter::clearance: return "clearance";
    case continuation_parameter::unbalance: return "unbalance";
    case continuation_parameter::mu: return "mu";
  }
  return "?";
}

std::string_view column_name(continuation_parameter p) {
  switch (p) {
    case continuation_parameter::speed: return "speed_rpm";
    case continuation_parameter::clearance: return "clearance_m";
    case continuation_parameter::unbalance: return "e_m";
    case continuation_parameter::mu: return "mu";
  }
  return "?";
}

continuation_parameter parse_continuation_parameter(const std::string& name) {
  for (auto p : {continuation_parameter::speed, continuation_parameter::clearance, continuation_parameter::unbalance,
                 continuation_parameter::mu})
    if (name == to_string(p)) return p;
  throw input_error("unknown continuation parameter '" + name + "'" + did_you_mean(name, {"speed", "clearance", "unbalance", "mu"}) +
                    " (speed, clearance, unbalance, mu)");
}

std::string_view to_string(special_kind k) {
  switch (k) {
    case special_kind::fold: return "fold";
    case special_kind::grazing: return "grazing";
    case special_kind::period_doubling: return "period_doubling";
    case special_kind::neimark_sacker: return "neimark_sacker";
  }
  return "?";
}

run_request request_at(const continuation_request& req, double parameter) {
  run_request run;
  run.variant = req.variant;
  run.params = req.params;
  run.rpm = req.rpm;
  run.samples_per_rev = req.samples_per_rev;
  run.integration = req.integration;
  run.settle_revs = 0;
  run.record_revs = req.periods;
  switch (req.parameter) {
    case continuation_parameter::speed: run.rpm = parameter; break;
    case continuation_parameter::clearance: run.params.clearance = parameter; break;
    case continuation_parameter::unbalance: run.params.e = parameter; break;
    case continuation_parameter::mu: run.params.mu = parameter; break;
  }
  return run;
}

void validate(const continuation_request& req) {
  const std::string name(to_string(req.parameter));
  check({"continuation", "from"}, req.from);
  check({"continuation", "to"}, req.to);
  require(req.from < req.to, "continuation range must have from < to (got from " + format_digits(req.from, 10) + ", to " +
                                 format_digits(req.to, 10) + "; to trace down, keep from < to and set the direction down)");
  check({"continuation", "periods"}, req.periods);
  check({"continuation", "tolerance"}, req.tolerance);
  check({"continuation", "initial_step"}, req.initial_step);
  check({"continuation", "max_step"}, req.max_step);
  check({"continuation", "min_step"}, req.min_step);
  require(req.min_step <= req.initial_step && req.initial_step <= req.max_step,
          "continuation steps must satisfy " + setting("min_step") + " <= " + setting("initial_step") + " <= " + setting("max_step"));
  check({"continuation", "max_points"}, req.max_points);
  // The parameters at both ends of the range (validate(run_request) names the bad one).
  for (double v : {req.from, req.to}) {
    if (req.parameter == continuation_parameter::mu)
      require(v >= 0.0, "continuation parameter mu must be >= 0 (got " + format_digits(v) + ")");
    validate(request_at(req, v));
  }
}

namespace {

// The model's parameter a continuation parameter is, and d(model's) / d(continuation's): the
// speed is continued in rpm, the model's w is in rad/s.
model_parameter model_parameter_of(continuation_parameter p) {
  switch (p) {
    case continuation_parameter::speed: return model_parameter::omega;
    case continuation_parameter::clearance: return model_parameter::clearance;
    case continuation_parameter::unbalance: return model_parameter::unbalance;
    case continuation_parameter::mu: return model_parameter::mu;
  }
  return model_parameter::omega;
}
double model_units_per_unit(continuation_parameter p) { return p == continuation_parameter::speed ? rpm_to_rad_s(1.0) : 1.0; }

// Pseudo-arclength continuation of the fixed points of the n-revolution map in one parameter.
// Unknowns u = (s / scale, lambda / lambda_scale); the residual G(u) = (P(s; lambda) - s) / scale.
// dG/ds = D^-1 (M - I) D from the exact monodromy M, and dG/dlambda from the exact dP/dlambda, both
// from one flow (map_and_sensitivities, ref/integrate/shooting.hpp: the parameter's variational
// equation and its saltation at every event, and the speed's dT/dw column). A forward difference
// of P erred by ~h / (lambda - lambda_g) next to a restitution branch's grazing, where P has a
// square-root singularity: the corrector slowed down and the branch crept onto it (issue 45).
template <class Law>
class branch_tracer {
 public:
  static constexpr int N = 4;
  using vec = Eigen::Matrix<double, N + 1, 1>;
  using jac = Eigen::Matrix<double, N, N + 1>;

  explicit branch_tracer(const continuation_request& req) : req_(req) {
    start_ = req.downward ? req.to : req.from;
    end_ = req.downward ? req.from : req.to;
    const run_request first = request_at(req, start_);
    scale_[0] = scale_[1] = first.params.clearance;
    scale_[2] = scale_[3] = first.params.clearance * rpm_to_rad_s(first.rpm);
    lambda_scale_ = std::abs(req.to - req.from);
    set_.tolerance = req.tolerance;
    set_.integration.events = req.integration.events;
  }

  continuation_result run() {
    continuation_result out;
    // The first orbit: shooting from the contact-free response, then from a short transient.
    periodic_orbit_request first;
    first.run = request_at(req_, start_);
    first.periods = req_.periods;
    first.tolerance = req_.tolerance;
    const periodic_orbit_result start = find_periodic_orbit(first);
    if (!start.converged)
      throw numerical_error("continuation: no periodic orbit found at the start of the range (" + std::string(column_name(req_.parameter)) +
                            " = " + format_digits(start_, 10) + "): " + start.failure);
    out.start = start.start;
    const double direction = req_.downward ? -1.0 : 1.0;
    vec t = vec::Zero();
    t[N] = direction;
    const auto corrected = correct(to_unknowns(start.samples.request.initial_state, start_), fixed_parameter(start_));
    if (!corrected) throw numerical_error("continuation: the first orbit did not converge again at the start: " + failure_);
    vec u = corrected->u;
    t = tangent(corrected->J, t);
    out.points.push_back(make_point(u, *corrected, t));

    double h = req_.initial_step;
    const double end = end_ / lambda_scale_;
    // The branch's curvature dt/ds from the last two points: the predictor u + h t + h^2/2 dt/ds
    // errs by O(h^3) instead of O(h^2), which saves most points' third corrector evaluation.
    vec curvature = vec::Zero();
    bool after_failure = false;
    while (true) {
      if (static_cast<int>(out.points.size()) >= req_.max_points) {
        out.stopped = "the maximum of " + std::to_string(req_.max_points) + " points";
        break;
      }
      const vec pred = u + h * t + (0.5 * h * h) * curvature;
      const bool past_end = direction * (pred[N] - end) >= 0.0;
      // The last point sits on the end of the range: the parameter fixed there.
      auto c = correct(pred, past_end ? fixed_parameter(end_) : arclength(t, pred));
      std::optional<vec> t_new;
      if (c) {
        t_new = tangent(c->J, t);
        if (t_new->dot(t) < kMinTangentCosine) c.reset(), failure_ = "the tangent turned by more than acos(0.9) in one step";
      }
      if (!c) {
        h *= 0.5;
        after_failure = true;
        if (h < req_.min_step) {
          end_below_min_step(out);
          break;
        }
        continue;
      }
      branch_point next = make_point(c->u, *c, *t_new);
      detect(out, out.points.back(), u, t, next);
      out.points.push_back(std::move(next));
      const double ds = (c->u - u).dot(t);
      curvature = ds > 0.0 ? vec((*t_new - t) / ds) : vec::Zero();
      const double turn = std::acos(std::clamp(t.dot(*t_new), -1.0, 1.0));
      u = c->u;
      t = *t_new;
      if (past_end) {
        out.stopped = "reached the end of the range";
        out.reached_end = true;
        break;
      }
      if (direction * (c->u[N] * lambda_scale_ - start_) < 0.0) {
        out.stopped = "the branch folded back out of the range at its start (" + std::string(column_name(req_.parameter)) + " = " +
                      format_digits(start_, 10) + ")";
        break;
      }
      h = next_step(h, turn, c->iterations, after_failure);
      after_failure = false;
      if (h < req_.min_step) {
        failure_ = "the corrector slowed down (" + std::to_string(c->iterations) + " iterations) or the tangent turned by " +
                   format_digits(turn * 180.0 / 3.14159265358979323846, 3) + " degrees at the minimum step";
        end_below_min_step(out);
        break;
      }
    }
    return out;
  }

 private:
  // The branch cannot be followed further with steps of min_step: at the stator's face that is a
  // grazing where the branch ends (for the impact law the impacting branch leaves it with an
  // unbounded slope: docs/orbits.md); elsewhere the step fell below the minimum.
  void end_below_min_step(continuation_result& out) const {
    const branch_point& last = out.points.back();
    const std::string where = std::string(column_name(req_.parameter)) + " = " + format_digits(last.parameter, 10);
    if (std::abs(last.max_z) <= kGrazingGap * request_at(req_, last.parameter).params.clearance) {
      out.special.push_back({special_kind::grazing, last.parameter, last.rpm, last.state, true, out.points.size() - 1});
      out.stopped = "the branch ends at a grazing at " + where + " (" + failure_ + ")";
    } else {
      out.stopped = "the step fell below the minimum at " + where + ": " + failure_;
    }
  }

  // Two successive unit tangents closer than this are one smooth branch; a sharper turn in one
  // step is taken as a jump to another branch and the step is halved.
  static constexpr double kMinTangentCosine = 0.9;
  // Step control by the branch's turning (as COCO's atlas algorithms do, with their 10-degree
  // maximum angle between tangents): each step aims at a 5-degree turn of the tangent, growing or
  // shrinking by at most 2x. A step does not grow right after a failed step (else growing by 2
  // and halving on failure could alternate forever at a branch's end), and shrinks x0.7 after a
  // corrector of more than 3 iterations: one that slows down (near the singular slope of an
  // impacting branch at its grazing) must not let the branch creep on at a constant step. The turn, not a small max_step, sets the resolution, so folds and fast
  // phase changes get short steps and straight stretches long ones. A step below min_step, after
  // a failure or a success, ends the branch there.
  static constexpr double kTargetTurn = 5.0 * 3.14159265358979323846 / 180.0;  // rad
  static constexpr double kMaxStepFactor = 2.0;

  double next_step(double h, double turn, int iterations, bool after_failure) const {
    double factor = turn > 0.0 ? kTargetTurn / turn : kMaxStepFactor;
    factor = std::clamp(factor, 1.0 / kMaxStepFactor, kMaxStepFactor);
    if (after_failure) factor = std::min(factor, 1.0);
    if (iterations > 3) factor = std::min(factor, 0.7);
    return std::min(h * factor, req_.max_step);
  }
  static constexpr int kMaxCorrectorIterations = 10;
  // A last point closer to the stator than this share of the clearance is at a grazing (the
  // corrector's tolerance is 1e-12 m, so points may approach the face to ~1e-10 m).
  static constexpr double kGrazingGap = 1e-6;
  // Special points are located to this arclength (the parameter to 1e-10 of the range).
  static constexpr double kLocateArclength = 1e-10;
  static constexpr int kMaxLocateIterations = 60;

  struct constraint {
    vec c;
    double c0;  // c . u = c0
  };
  constraint arclength(const vec& t, const vec& pred) const { return {t, t.dot(pred)}; }
  constraint fixed_parameter(double value) const {
    vec c = vec::Zero();
    c[N] = 1.0;
    return {c, value / lambda_scale_};
  }

  struct evaluation {
    vec u;
    Eigen::Matrix<double, N, 1> G;
    jac J;
    square_matrix<N> monodromy;
    std::size_t events = 0;
    int iterations = 0;
  };

  vec to_unknowns(const state_type& s, double lambda) const {
    vec u;
    for (int i = 0; i < N; ++i) u[i] = s[static_cast<std::size_t>(i)] / scale_[static_cast<std::size_t>(i)];
    u[N] = lambda / lambda_scale_;
    return u;
  }
  state_type to_state(const vec& u) const {
    state_type s{};
    for (int i = 0; i < N; ++i) s[static_cast<std::size_t>(i)] = u[i] * scale_[static_cast<std::size_t>(i)];
    return s;
  }
  rotor_system<Law> system_at(double lambda) const {
    const run_request r = request_at(req_, lambda);
    return rotor_system<Law>(r.params, rpm_to_rad_s(r.rpm));
  }

  // G and its Jacobian at u; nullopt (failure_ says why) when the map cannot be evaluated there.
  std::optional<evaluation> evaluate(const vec& u) {
    const double lambda = u[N] * lambda_scale_;
    const state_type s = to_state(u);
    try {
      const run_request r = request_at(req_, lambda);
      validate(r);
      const auto sys = system_at(lambda);
      if constexpr (!compliant_law<Law>)
        if (sys.penetration(s) > 0.0) {
          failure_ = "a state inside the stator";
          return std::nullopt;
        }
      const auto f = map_and_sensitivities(sys, s, 0.0, req_.periods, model_parameter_of(req_.parameter), set_.integration);
      const double per_unit = model_units_per_unit(req_.parameter);  // d(model's lambda)/d(lambda)
      evaluation e;
      e.u = u;
      e.monodromy = f.monodromy;
      e.events = f.counts.events;
      for (int i = 0; i < N; ++i) {
        const auto k = static_cast<std::size_t>(i);
        e.G[i] = (f.end[k] - s[k]) / scale_[k];
        for (int j = 0; j < N; ++j)
          e.J(i, j) = (f.monodromy(i, j) - (i == j ? 1.0 : 0.0)) * scale_[static_cast<std::size_t>(j)] / scale_[k];
        e.J(i, N) = f.parameter[i] * per_unit * lambda_scale_ / scale_[k];
      }
      if (!e.G.allFinite() || !e.J.allFinite()) {
        failure_ = "a non-finite map";
        return std::nullopt;
      }
      return e;
    } catch (const numerical_error& err) {
      failure_ = err.what();
    } catch (const input_error& err) {
      failure_ = err.what();
    }
    return std::nullopt;
  }

  // Newton on (G(u), c . u - c0) = 0 from `pred`.
  std::optional<evaluation> correct(const vec& pred, const constraint& k) {
    vec u = pred;
    double last = std::numeric_limits<double>::infinity();
    for (int it = 0; it < kMaxCorrectorIterations; ++it) {
      auto e = evaluate(u);
      if (!e) return std::nullopt;
      const double res = e->G.cwiseAbs().maxCoeff() * scale_[0];  // m (velocities / |w|)
      if (res <= req_.tolerance && std::abs(k.c.dot(u) - k.c0) <= 1e-12) {
        e->iterations = it + 1;
        return e;
      }
      if (it >= 2 && !(res < last)) {
        failure_ = "the corrector stopped converging (residual " + (format_digits(res, 3) + " m") + ")";
        return std::nullopt;
      }
      last = res;
      Eigen::Matrix<double, N + 1, N + 1> A;
      A.template topRows<N>() = e->J;
      A.row(N) = k.c.transpose();
      vec r;
      r.template head<N>() = e->G;
      r[N] = k.c.dot(u) - k.c0;
      const Eigen::FullPivLU<Eigen::Matrix<double, N + 1, N + 1>> lu(A);
      if (!lu.isInvertible()) {
        failure_ = "a singular corrector (a branch point)";
        return std::nullopt;
      }
      u -= lu.solve(r);
    }
    failure_ = "no convergence in " + std::to_string(kMaxCorrectorIterations) + " corrector iterations";
    return std::nullopt;
  }

  // The unit null vector of J, oriented along `previous`.
  static vec tangent(const jac& J, const vec& previous) {
    Eigen::Matrix<double, N + 1, N + 1> A;
    A.template topRows<N>() = J;
    A.row(N) = previous.transpose();
    vec rhs = vec::Zero();
    rhs[N] = 1.0;
    vec t = A.fullPivLu().solve(rhs);
    t.normalize();
    if (t.dot(previous) < 0.0) t = -t;
    return t;
  }

  branch_point make_point(const vec& u, const evaluation& e, const vec& t) const {
    branch_point p;
    p.parameter = u[N] * lambda_scale_;
    const run_request r = request_at(req_, p.parameter);
    p.rpm = r.rpm;
    p.state = to_state(u);
    p.newton_iterations = e.iterations;
    p.tangent_parameter = t[N];
    const Eigen::EigenSolver<square_matrix<N>> eig(e.monodromy, false);
    for (int i = 0; i < N; ++i) p.multipliers.push_back(eig.eigenvalues()[i]);
    std::sort(p.multipliers.begin(), p.multipliers.end(), [](const auto& a, const auto& b) { return std::abs(a) > std::abs(b); });
    p.max_floquet_modulus = std::abs(p.multipliers.front());
    p.stable = p.max_floquet_modulus < 1.0;
    const orbit o = record_periods(r, p.state, req_.periods);
    p.summary = summarize(o);
    if (p.summary.contact_episodes_per_rev > 0.0) {
      p.max_z = p.summary.max_penetration;
    } else {
      // Clear of the stator: the closest approach, by Brent on the exact free flight around the
      // highest sample (the value at a maximum is exact to rounding, its time to sqrt(eps)).
      const auto& s = o.samples;
      std::size_t top = 0;
      for (std::size_t i = 1; i < s.size(); ++i)
        if (s[i].s[idx::y] > s[top].s[idx::y]) top = i;
      p.max_z = s[top].s[idx::y] - r.params.clearance;
      const auto sys = system_at(p.parameter);
      if (const auto d = sys.free_dynamics()) {
        const free_flight<N> ff(*d);
        const auto arc = ff.from(0.0, p.state);
        const double dt = sys.period() / r.samples_per_rev;
        const double t_top = s[top].t;
        std::uintmax_t iterations = 100;
        const auto best = boost::math::tools::brent_find_minima([&](double t) { return -arc.penetration(t).first; }, t_top - dt,
                                                                t_top + dt, std::numeric_limits<double>::digits, iterations);
        p.max_z = std::max(p.max_z, -best.second);
      }
      // Admissibility: a contact-free orbit found above the stator is a missed contact (an episode
      // shallower than the integrator's min_depth is passed over by design).
      if (p.max_z > set_.integration.events.min_depth_fraction * r.params.clearance)
        throw numerical_error("continuation: the orbit at " + std::string(column_name(req_.parameter)) + " = " +
                              format_digits(p.parameter, 10) + " reaches " + (format_digits(p.max_z, 3) + " m") +
                              " into the stator without a contact event");
    }
    return p;
  }

  // Test functions; each changes sign across its special point.
  static double fold_test(const branch_point& p) { return p.tangent_parameter; }
  static double grazing_test(const branch_point& p) { return p.max_z; }
  static double period_doubling_test(const branch_point& p) {  // det(M + I)
    std::complex<double> d = 1.0;
    for (const auto& m : p.multipliers) d *= m + 1.0;
    return d.real();
  }
  static double torus_test(const branch_point& p) {  // the largest modulus of a complex pair, minus 1
    double best = -1.0;
    for (const auto& m : p.multipliers)
      if (std::abs(m.imag()) > 1e-9 * std::max(1.0, std::abs(m))) best = std::max(best, std::abs(m) - 1.0);
    return best;
  }

  void detect(continuation_result& out, const branch_point& a, const vec& ua, const vec& ta, const branch_point& b) {
    const std::size_t after = out.points.size() - 1;
    const auto check = [&](special_kind kind, double (*test)(const branch_point&)) {
      const double fa = test(a), fb = test(b);
      if (!(fa * fb < 0.0)) return;
      if (kind == special_kind::neimark_sacker && (fa == -1.0 || fb == -1.0)) return;  // a pair appeared or vanished, not a crossing
      out.special.push_back(locate(kind, test, a, ua, ta, b, after));
    };
    const std::size_t first = out.special.size();
    check(special_kind::fold, fold_test);
    check(special_kind::grazing, grazing_test);
    check(special_kind::period_doubling, period_doubling_test);
    check(special_kind::neimark_sacker, torus_test);
    // Several in one step are listed in their order along the branch.
    const auto along = [&](const special_point& sp) { return (to_unknowns(sp.state, sp.parameter) - ua).dot(ta); };
    std::stable_sort(out.special.begin() + static_cast<std::ptrdiff_t>(first), out.special.end(),
                     [&](const special_point& x, const special_point& y) { return along(x) < along(y); });
  }

  // The zero of `test` between a and b on the arclength along a's tangent (each trial point
  // corrected onto the branch): the Illinois variant of regula falsi, with a bisection whenever a
  // step fails to halve the bracket (a grazing's test is not smooth there: max_z has a kink).
  // Located: the bracket is below kLocateArclength (1e-10 of the range in the parameter) or the
  // test is below 1e-12 of its values at a and b.
  special_point locate(special_kind kind, double (*test)(const branch_point&), const branch_point& a, const vec& ua,
                       const vec& ta, const branch_point& b, std::size_t after) {
    special_point sp{kind, a.parameter, a.rpm, a.state, false, after};
    double s_lo = 0.0, s_hi = (to_unknowns(b.state, b.parameter) - ua).dot(ta);
    double f_lo = test(a), f_hi = test(b);
    const double f_scale = std::max(std::abs(f_lo), std::abs(f_hi));
    int side = 0;
    bool bisect = false;
    for (int it = 0; it < kMaxLocateIterations; ++it) {
      if (std::abs(s_hi - s_lo) <= kLocateArclength) {
        sp.located = true;
        break;
      }
      const double width = std::abs(s_hi - s_lo);
      const double s = bisect ? 0.5 * (s_lo + s_hi) : (s_lo * f_hi - s_hi * f_lo) / (f_hi - f_lo);
      const vec pred = ua + s * ta;
      const auto c = correct(pred, arclength(ta, pred));
      if (!c) break;
      const branch_point p = make_point(c->u, *c, tangent(c->J, ta));
      const double f = test(p);
      sp.parameter = p.parameter;
      sp.rpm = p.rpm;
      sp.state = p.state;
      if (std::abs(f) <= 1e-12 * f_scale) {
        sp.located = true;
        break;
      }
      if ((f < 0.0) == (f_lo < 0.0)) {
        s_lo = s, f_lo = f;
        if (side == -1) f_hi *= 0.5;
        side = -1;
      } else {
        s_hi = s, f_hi = f;
        if (side == 1) f_lo *= 0.5;
        side = 1;
      }
      bisect = std::abs(s_hi - s_lo) > 0.5 * width;
    }
    return sp;
  }

  const continuation_request& req_;
  shooting_settings set_;
  std::array<double, N> scale_{};
  double lambda_scale_ = 1.0;
  double start_ = 0.0, end_ = 0.0;  // from and to, or to and from when tracing downward
  std::string failure_;
};

}  // namespace

continuation_result continue_branch(const continuation_request& req) {
  validate(req);
  return visit_variant(req.variant, [&]<class Law>() { return branch_tracer<Law>(req).run(); });
}

}  // namespace rubref
