#include "ref/validation/golden.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>

#include "ref/analysis/orbit_io.hpp"
#include "ref/analysis/orbit_summary.hpp"
#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/base/version.hpp"
#include "ref/model/parameter_io.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

orbit_statistics statistics_of(std::span<const double> t, std::span<const double> x, std::span<const double> y,
                               double omega, double clearance) {
  orbit_statistics s;
  const std::size_t n = t.size();
  if (n == 0) return s;
  const auto [x_lo, x_hi] = std::minmax_element(x.begin(), x.end());
  const auto [y_lo, y_hi] = std::minmax_element(y.begin(), y.end());
  s.peak_to_peak_x = *x_hi - *x_lo;
  s.peak_to_peak_y = *y_hi - *y_lo;
  std::size_t in_contact = 0;
  Eigen::MatrixXcd A(static_cast<Eigen::Index>(n), 3);
  Eigen::VectorXcd r(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    s.max_radius = std::max(s.max_radius, std::hypot(x[i], y[i]));
    if (y[i] > clearance) ++in_contact;
    const auto k = static_cast<Eigen::Index>(i);
    const std::complex<double> rot = std::polar(1.0, omega * t[i]);
    A(k, 0) = 1.0;
    A(k, 1) = rot;
    A(k, 2) = std::conj(rot);
    r[k] = {x[i], y[i]};
  }
  s.contact_fraction = static_cast<double>(in_contact) / static_cast<double>(n);
  if (n >= 3) {
    const Eigen::VectorXcd c = A.colPivHouseholderQr().solve(r);
    s.forward_1x = std::abs(c[1]);
    s.backward_1x = std::abs(c[2]);
  }
  return s;
}

std::string_view to_string(comparison_kind k) { return k == comparison_kind::orbit ? "orbit" : "statistics"; }

std::vector<golden_spec> golden_matrix() {
  std::vector<golden_spec> out;
  for_each_variant([&](auto law) {
    for (const double c : kGoldenClearances)
      for (const double rpm : kGoldenSpeeds) out.push_back({std::string(decltype(law)::name), c, rpm, parameters{}.e, ""});
  });
  out.push_back(long_contact_case());
  out.push_back(chatter_sticking_case());
  return out;
}

// The matrix's contacts are brief (at most 5.5 % of the samples, a few degrees of arc per
// revolution). Far above the resonance, with a clearance well inside the unbalance's whirl
// radius (e = 71 um), the rotor stays on the stator through one long episode each revolution
// (9.4 % of it, ~34 deg): the compliant law's force-penetration curve deep in and the friction
// over a long arc, which short grazes do not exercise. Found with `rubref simulate` over
// 0.5 um - 0.15 mm and 300 - 8000 rpm: no compliant case with the paper's parameters reached
// 20 % (the rotor bounces off the stiff contact, k1 = 96 k_y), and the longer contacts found
// (14 % at 4000 rpm) do not settle to 1e-9 of the orbit in the files' 200 revolutions
// (15 decay times 2m/c there), so they would not be shot orbit cases.
golden_spec long_contact_case() { return {"piecewise-linear", 1e-5, 2800.0, parameters{}.e, ""}; }
// Chatter ending in sticking (docs/model.md, "Chatter") needs the unbalance to press the rotor on
// the face, m e w^2 > k_y delta, slowly against the rebounds. With the paper's e (71 um) that
// takes a clearance of a micrometre or so; a larger unbalance, e = 0.5 mm (a rig's trial mass),
// reaches it at a realistic 20 um and 600 rpm: each revolution the rotor hits the face, chatters
// down (r = 0.86), sticks, and is released, a period-1 orbit that shooting converges.
golden_spec chatter_sticking_case() { return {"restitution", 2e-5, 600.0, 5e-4, "chatter-sticking"}; }

std::string golden_file_name(const golden_spec& spec) {
  return spec.variant + "_" + format_number(spec.clearance * 1e3) + "mm_" + format_number(spec.rpm) + "rpm" +
         (spec.feature.empty() ? "" : "_" + spec.feature) + ".csv";
}

run_request golden_request(const golden_spec& spec) {
  run_request req;
  req.variant = spec.variant;
  req.params.clearance = spec.clearance;
  req.params.e = spec.e;
  req.rpm = spec.rpm;
  req.settle_revs = kGoldenSettleRevs;
  req.record_revs = kGoldenRecordRevs;
  req.samples_per_rev = kGoldenSamplesPerRev;
  return req;
}

integration_options golden_method() {
  integration_options opt;
  opt.stepper.kind = stepper_kind::rkf78;
  opt.stepper.rtol = 1e-13;
  opt.stepper.atol = 1e-18;
  return opt;
}

integration_options golden_cross_check() {
  integration_options opt = golden_method();
  opt.stepper.kind = stepper_kind::bulirsch_stoer;
  // Independent of the careful method in the free flight too: integrated, not in closed form
  // (else an impact law, whose contacts are instants, would be cross-checked by itself).
  opt.exact_free_flight = false;
  return opt;
}

namespace {


std::vector<double> column_of(const orbit& o, int component) {
  std::vector<double> v;
  v.reserve(o.samples.size());
  for (const auto& s : o.samples) v.push_back(s.s[component]);
  return v;
}

std::vector<double> times_of(const orbit& o) {
  std::vector<double> v;
  for (const auto& s : o.samples) v.push_back(s.t);
  return v;
}

orbit_statistics orbit_statistics_of(const orbit& o) {
  const auto t = times_of(o), x = column_of(o, idx::x), y = column_of(o, idx::y);
  return statistics_of(t, x, y, rpm_to_rad_s(o.request.rpm), o.request.params.clearance);
}

// Largest position difference between two orbits on the same grid, m.
double largest_difference(const orbit& a, const orbit& b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.samples.size(); ++i)
    for (const int c : {idx::x, idx::y}) worst = std::max(worst, std::abs(a.samples[i].s[c] - b.samples[i].s[c]));
  return worst;
}

// The smallest whole number of revolutions after which the orbit repeats to `tol` m, checked
// over the whole record (so at most half the record); 0 if none.
int period_in_revs(const orbit& o, double tol) {
  const std::size_t per_rev = static_cast<std::size_t>(o.request.samples_per_rev), n = o.samples.size();
  for (std::size_t p = 1; 2 * p * per_rev <= n; ++p) {
    double worst = 0.0;
    for (std::size_t i = 0; i + p * per_rev < n; ++i)
      for (const int c : {idx::x, idx::y}) worst = std::max(worst, std::abs(o.samples[i].s[c] - o.samples[i + p * per_rev].s[c]));
    if (worst <= tol) return static_cast<int>(p);
  }
  return 0;
}

// Keeps the states at the grid's times (revolution starts).
struct state_keeper {
  std::vector<state_type>* out;
  template <class System>
  void on_sample(double, const state_type& s, const System&) {
    out->push_back(s);
  }
  void on_event(const contact_event&) {}
};

struct scan_start {
  std::string what;  // the header's `attractor_<k>_start`
  state_type state;  // at t, in the file's frame
  double t;          // s
};

// Lengths in the start descriptions: 6 digits, in mm (0.27, not 0.27000000000000002).
std::string mm_text(double metres) { return format_digits(metres * 1e3, 6); }

std::vector<scan_start> scan_starts(const run_request& req) {
  const double omega = rpm_to_rad_s(req.rpm), period = 2.0 * std::numbers::pi / omega, clearance = req.params.clearance;
  std::vector<scan_start> out;
  // Another unbalance phase phi from t' = 0 is, in the file's frame (phi = 0), rest at t = phi / w.
  for (int k = 1; k <= 7; ++k)
    out.push_back({"rest, unbalance phase " + std::to_string(45 * k) + " deg (rest at t = " + std::to_string(k) + "T/8)", state_type{},
                   k * period / 8.0});
  // The contact-free steady response, the first start of find_periodic_orbit (`rubref orbit`);
  // an impact law cannot start inside the stator, so its y is clipped to the clearance there.
  visit_variant(req.variant, [&]<class Law>() {
    parameters free = req.params;
    free.clearance = std::numeric_limits<double>::max();
    state_type s = free_flight<4>(*rotor_system<Law>(free, omega).free_dynamics()).particular(0.0);
    std::string what = "contact-free steady response at t = 0";
    if constexpr (!compliant_law<Law>) {
      if (s[idx::y] > clearance) {
        s[idx::y] = clearance;
        what += ", y clipped to the clearance";
      }
    }
    out.push_back({what, s, 0.0});
  });
  // Displaced at rest: near the stator, below it, and to either side.
  for (const auto& [x, y] : {std::pair{0.0, 0.9 * clearance}, {0.0, -0.9 * clearance}, {0.9 * clearance, 0.0}, {-0.9 * clearance, 0.0}})
    out.push_back({"rest at (x, y) = (" + mm_text(x) + ", " + mm_text(y) + ") mm at t = 0", state_type{x, y, 0.0, 0.0}, 0.0});
  return out;
}

// Smallest p <= kScanMaxPeriodRevs after which the revolution-start states repeat to `tol`
// (state_distance) over all of them; 0 if none.
int poincare_period(const std::vector<state_type>& s, double omega, double tol) {
  for (int p = 1; p <= kScanMaxPeriodRevs; ++p) {
    double worst = 0.0;
    for (std::size_t i = 0; i + static_cast<std::size_t>(p) < s.size(); ++i)
      worst = std::max(worst, state_distance(s[i], s[i + static_cast<std::size_t>(p)], omega));
    if (worst <= tol) return p;
  }
  return 0;
}

// What one start settles on.
struct start_outcome {
  bool on_orbit = false;  // a stable shot orbit of period <= kScanMaxPeriodRevs that the start reached
  int period = 0;
  state_type state{};     // at t0
  double max_multiplier = 0.0;
};

// From `start`: the fast path to t0 (= settle_revs T), the revolution starts after it, and, if
// they repeat, Newton with the careful stepper at t0 from the last of them (the model is
// T-periodic: a state at t0 + k T is a state at t0).
start_outcome settle_start(const run_request& fast, const run_request& careful, const scan_start& start, double t0, double tol_period,
                           double tol_reached) {
  start_outcome out;
  const double omega = rpm_to_rad_s(fast.rpm);
  std::vector<state_type> revs;
  int period = visit_variant(fast.variant, [&]<class Law>() {
    const rotor_system<Law> model(fast.params, omega);
    const double T = 2.0 * std::numbers::pi / omega;
    auto at = start_state(model, start.state, start.t);
    double from = t0;
    for (const int extra : {0, kScanExtraSettleRevs}) {
      from += extra * T;
      revs.clear();
      state_keeper keep{&revs};
      at = integrate_hybrid(model, at, from + kScanPoincareRevs * T, fast.integration, sample_grid{from, T, kScanPoincareRevs}, keep);
      if (const int p = poincare_period(revs, omega, tol_period); p > 0) return p;
    }
    return 0;
  });
  if (period == 0) return out;
  shot_options so;
  so.t0 = t0;
  so.stepper = careful.integration.stepper;
  so.tolerance = kGoldenShootingTolerance;
  const periodic_orbit_result shot = shoot_from(careful, revs.back(), period, so);
  if (!shot.converged || !shot.stable) return out;
  const state_type& s = shot.samples.request.initial_state;
  if (!(state_distance(s, revs.back(), omega) <= tol_reached)) return out;
  out.on_orbit = true;
  out.period = period;
  out.state = s;
  out.max_multiplier = shot.max_multiplier_modulus;
  return out;
}

}  // namespace

double state_distance(const state_type& a, const state_type& b, double omega) {
  const double w = std::abs(omega);
  return std::max({std::abs(a[idx::x] - b[idx::x]), std::abs(a[idx::y] - b[idx::y]), std::abs(a[idx::vx] - b[idx::vx]) / w,
                   std::abs(a[idx::vy] - b[idx::vy]) / w});
}

std::vector<state_type> revolution_states(const run_request& careful, const state_type& on_orbit, int revs, double t0) {
  run_request one = careful;
  one.samples_per_rev = 1;
  const orbit o = record_periods(one, on_orbit, revs, t0);
  std::vector<state_type> out;
  for (const auto& s : o.samples) out.push_back(s.s);
  return out;
}

attractor_scan scan_attractors(const golden_spec& spec, std::span<const state_type> own, double radius, unsigned threads) {
  const run_request fast = golden_request(spec);  // rubref's defaults: the fast path for the transients
  run_request careful = fast;
  careful.integration = golden_method();
  const double omega = rpm_to_rad_s(spec.rpm);
  const double t0 = fast.settle_revs * (2.0 * std::numbers::pi / omega);  // the file's first sample, as simulate has it
  const std::vector<scan_start> starts = scan_starts(fast);
  std::vector<start_outcome> outcomes(starts.size());
  parallel_for(starts.size(), threads, [&](std::size_t i) {
    outcomes[i] = settle_start(fast, careful, starts[i], t0, kScanPeriodRelTol * radius, kScanReachedRelTol * radius);
  });

  // One entry per attractor, in the order of the starts: a state within the tolerance of a
  // revolution shift of the case's own orbit, or of one already kept, is that one.
  attractor_scan out;
  out.starts = static_cast<int>(starts.size());
  const double same = kDistinctAttractorRelTol * radius;
  std::vector<std::vector<state_type>> kept_shifts;
  const auto near_any = [&](const state_type& s, std::span<const state_type> shifts) {
    return std::any_of(shifts.begin(), shifts.end(), [&](const state_type& o) { return state_distance(s, o, omega) <= same; });
  };
  for (std::size_t i = 0; i < starts.size(); ++i) {
    const start_outcome& o = outcomes[i];
    if (!o.on_orbit) {
      ++out.unsettled;
      continue;
    }
    if (near_any(o.state, own)) continue;
    auto known = std::find_if(kept_shifts.begin(), kept_shifts.end(), [&](const auto& shifts) { return near_any(o.state, shifts); });
    if (known != kept_shifts.end()) {
      out.attractors[static_cast<std::size_t>(known - kept_shifts.begin())].start += "; " + starts[i].what;
      continue;
    }
    out.attractors.push_back({starts[i].what, o.period, o.state, o.max_multiplier});
    kept_shifts.push_back(revolution_states(careful, o.state, o.period, t0));
  }
  out.description = "from " + std::to_string(out.starts) +
                    " starts besides the file's (rest with unbalance phase 45, 90, .., 315 deg; the contact-free steady "
                    "response at t = 0; rest at (0, +-0.9 delta), (+-0.9 delta, 0) at t = 0), each settled to t = " +
                    std::to_string(fast.settle_revs) + " T by rubref's fast path (" + std::to_string(fast.settle_revs + kScanExtraSettleRevs) +
                    " T if not periodic by then), period <= " + std::to_string(kScanMaxPeriodRevs) +
                    " rev found over " + std::to_string(kScanPoincareRevs) + " revolutions, then shot with the careful stepper to " +
                    format_number(kGoldenShootingTolerance) + " m; " + std::to_string(out.unsettled) +
                    " start(s) settled on no stable orbit of period <= " + std::to_string(kScanMaxPeriodRevs) + " rev (chaotic, or not periodic by then)";
  return out;
}

record make_golden(const golden_spec& spec, std::string_view date, unsigned threads) {
  run_request req = golden_request(spec);
  req.integration = golden_method();
  run_request cross_req = req;
  cross_req.integration = golden_cross_check();
  std::vector<orbit> pair(2);
  parallel_for(2, threads, [&](std::size_t i) { pair[i] = simulate(i == 0 ? req : cross_req); });
  const orbit& transient = pair[0];
  const double transient_radius = summarize(transient).max_radius;
  const double cross_difference = largest_difference(transient, pair[1]);
  const bool reproducible = cross_difference <= kReproducibleRelTol * transient_radius;
  const int period = period_in_revs(transient, kReproducibleRelTol * transient_radius);

  // A periodic case's orbit is the fixed point of its period map, by Newton shooting with the
  // exact monodromy (ref/integrate/shooting.hpp) from the settled state, with the careful
  // method's stepper; the transients from rest only pick which attractor the case is, and must
  // agree with it. Its Floquet multipliers go into the file: a transient reaches a stable orbit.
  std::optional<periodic_orbit_result> shot;
  orbit fixed_point;
  double shot_difference = 0.0;
  if (reproducible && period > 0) {
    shot_options so;
    so.t0 = transient.samples.front().t;
    so.stepper = req.integration.stepper;
    so.tolerance = kGoldenShootingTolerance;
    shot = shoot_from(req, transient.samples.front().s, period, so);
    const std::string where = "golden case " + golden_file_name(spec) + ": ";
    if (!shot->converged)
      throw numerical_error(where + "Newton shooting from the settled state did not converge (" + shot->failure + ")");
    if (!shot->stable)
      throw numerical_error(where + "the shot orbit is unstable (largest Floquet multiplier modulus " +
                            format_number(shot->max_multiplier_modulus) + "), but a transient reached it");
    fixed_point = record_periods(req, shot->samples.request.initial_state, req.record_revs, so.t0);
    for (std::size_t i = 0; i < fixed_point.samples.size(); ++i)
      if (fixed_point.samples[i].t != transient.samples[i].t) throw numerical_error(where + "the shot orbit's grid is not the transient's");
    shot_difference = largest_difference(fixed_point, transient);
    if (!(shot_difference <= kReproducibleRelTol * transient_radius))
      throw numerical_error(where + "the shot orbit differs from the settled transient by " + format_number(shot_difference) + " m");
  }
  const orbit& golden = shot ? fixed_point : transient;
  const orbit_summary summary = summarize(golden);
  const double radius = summary.max_radius;
  const double orbit_tol = kGoldenOrbitRelTol * radius;
  const orbit_statistics stats = orbit_statistics_of(golden);

  // Tolerances of the statistics. Orbit cases: a candidate within the orbit tolerance moves a
  // length statistic by at most that much, and can flip only the samples that lie within it of
  // the clearance. Statistics cases: twice the range over an ensemble of careful runs that
  // record other stretches of the same attractor (other settle lengths, both methods), and no
  // less than the orbit case's.
  orbit_statistics tol;
  for (const auto& info : statistic_table) tol.*info.member = orbit_tol;
  std::size_t near_clearance = 0;
  for (const auto& s : golden.samples)
    if (std::abs(s.s[idx::y] - spec.clearance) <= orbit_tol) ++near_clearance;
  tol.contact_fraction = static_cast<double>(near_clearance + 1) / static_cast<double>(golden.samples.size());
  constexpr std::array<int, 4> kEnsembleSettle{200, 210, 220, 230};  // revolutions
  if (!reproducible) {
    std::vector<orbit_statistics> ensemble(2 * kEnsembleSettle.size());
    parallel_for(ensemble.size(), threads, [&](std::size_t i) {
      run_request r = i % 2 == 0 ? req : cross_req;
      r.settle_revs = kEnsembleSettle[i / 2];
      ensemble[i] = orbit_statistics_of(simulate(r));
    });
    for (const auto& info : statistic_table) {
      double lo = stats.*info.member, hi = lo;
      for (const auto& e : ensemble) {
        lo = std::min(lo, e.*info.member);
        hi = std::max(hi, e.*info.member);
      }
      tol.*info.member = std::max(tol.*info.member, 2.0 * (hi - lo));
    }
  }

  record r;
  const std::string mm = format_number(spec.clearance * 1e3);
  r.set("description", "rubref golden orbit: " + spec.variant + ", clearance " + mm + " mm, " + format_number(spec.rpm) +
                           " rpm, steady state from rest (docs/validation.md)");
  r.set("generator", "rubref " + std::string(version()) + " golden/generate_golden (RUBREF_REGENERATE_GOLDEN=1)");
  r.set("commit", std::string(commit()));
  r.set("date", std::string(date));
  r.set("variant", spec.variant);
  r.set("contact_law", std::string(visit_variant(spec.variant, []<class V>() { return V::equation; })));
  write_parameters(r, req.params);
  r.set("speed_rpm", spec.rpm);
  r.set("initial_state", "0 0 0 0");
  r.set("settle_revs", static_cast<double>(req.settle_revs));
  r.set("record_revs", static_cast<double>(req.record_revs));
  r.set("samples_per_rev", static_cast<double>(req.samples_per_rev));
  r.set("sample_rate_hz", req.samples_per_rev * spec.rpm / 60.0);
  r.set("method", shot ? "periodic orbit by Newton shooting (exact monodromy, saltation matrices) from the settled transient, "
                         "rkf78 (Runge-Kutta-Fehlberg 7(8), odeint) with located contact events; the transient from rest "
                         "(rkf78) and its cross-check (Bulirsch-Stoer) agree with it"
                       : "rkf78 (Runge-Kutta-Fehlberg 7(8), odeint) with located contact events, cross-checked by Bulirsch-Stoer");
  r.set("stepper", std::string(to_string(req.integration.stepper.kind)));
  r.set("rtol", req.integration.stepper.rtol);
  r.set("atol", req.integration.stepper.atol);
  r.set("max_dt_s", with_default_steps(req.integration.stepper, 60.0 / spec.rpm).max_dt);
  r.set("event_time_tolerance_s", req.integration.events.time_tolerance);
  r.set("stick_time_revs", req.integration.events.stick_time);
  r.set("cross_check_stepper", std::string(to_string(cross_req.integration.stepper.kind)));
  r.set("cross_check_max_difference_m", cross_difference);
  r.set("comparison", std::string(to_string(reproducible ? comparison_kind::orbit : comparison_kind::statistics)));
  r.set("period_revs", static_cast<double>(period));
  if (shot) {
    r.set("shooting_residual_m", shot->residual);
    r.set("shooting_iterations", static_cast<double>(shot->iterations));
    r.set("floquet_max_modulus", shot->max_multiplier_modulus);
    r.set("transient_max_difference_m", shot_difference);
  }
  if (reproducible) r.set("tolerance_orbit_m", orbit_tol);
  for (const auto& info : statistic_table) {
    r.set(std::string(info.key), stats.*info.member);
    r.set("tolerance_" + std::string(info.key), tol.*info.member);
  }
  // Informative: exact event-based quantities (not compared).
  r.set("max_penetration_m", summary.max_penetration);
  r.set("contact_episodes_per_rev", summary.contact_episodes_per_rev);
  r.set("regime", std::string(to_string(summary.regime)));
  r.set("whirl", summary.backward_whirl() ? "backward" : "forward");

  // Other stable orbits of the same model from other starts (after the case's own run, which it
  // does not touch): a candidate that settled on one fails for that reason alone.
  std::vector<state_type> own;
  for (std::size_t i = 0; i < golden.samples.size(); i += static_cast<std::size_t>(req.samples_per_rev)) own.push_back(golden.samples[i].s);
  const attractor_scan scan = scan_attractors(spec, own, radius, threads);
  r.set("attractor_scan", scan.description);
  r.set("coexisting_attractors", static_cast<double>(scan.attractors.size()));
  for (std::size_t i = 0; i < scan.attractors.size(); ++i) {
    const coexisting_attractor& a = scan.attractors[i];
    const int k = static_cast<int>(i) + 1;
    r.set(attractor_key(k, "start"), a.start);
    r.set(attractor_key(k, "period_revs"), static_cast<double>(a.period_revs));
    std::string state;
    for (const double v : a.state) state += (state.empty() ? "" : " ") + format_number_17(v);
    r.set(attractor_key(k, "state"), state);
    r.set(attractor_key(k, "max_multiplier"), a.max_multiplier);
  }

  orbit_columns cols;
  cols.append(golden.samples, spec.rpm);
  cols.move_into(r);
  return r;
}

std::string attractor_key(int k, std::string_view field) { return "attractor_" + std::to_string(k) + "_" + std::string(field); }

golden_case read_golden_case(const record& r, const std::string& source) {
  const auto need = [&](std::string_view key) -> const std::string& {
    const std::string* v = r.find(key);
    if (!v) throw input_error(source + ": not a golden case (no '" + std::string(key) + "' metadata)");
    return *v;
  };
  // A record read from a file names its file and line itself; a record made in memory does not.
  const std::string prefix = r.source.empty() ? source + ": " : std::string();
  const auto number = [&](std::string_view key) {
    need(key);
    try {
      return r.number(key);
    } catch (const input_error& e) {
      throw input_error(prefix + e.what());
    }
  };
  // Counts (revolutions, samples): whole numbers in [0, 1e8], checked before the conversion to
  // int (a double out of int's range converts with undefined behaviour).
  const auto count = [&](std::string_view key) {
    const double v = number(key);
    if (!(v >= 0.0 && v <= 1e8 && v == std::floor(v)))
      throw input_error((r.where(key).empty() ? source + ": " : r.where(key)) + "metadata '" + std::string(key) +
                        "' must be a whole number in [0, 1e8] (got " + *r.find(key) + ")");
    return static_cast<int>(v);
  };
  golden_case g;
  g.name = source;
  g.request.variant = need("variant");
  try {
    visit_variant(g.request.variant, []<class V>() {});
  } catch (const input_error& e) {
    throw input_error((r.where("variant").empty() ? source + ": " : r.where("variant")) + e.what());
  }
  g.request.params = read_parameters(r);
  g.request.rpm = number("speed_rpm");
  g.request.settle_revs = count("settle_revs");
  g.request.record_revs = count("record_revs");
  g.request.samples_per_rev = count("samples_per_rev");
  const std::string& comparison = need("comparison");
  if (comparison == "orbit") {
    g.comparison = comparison_kind::orbit;
    g.orbit_tolerance = number("tolerance_orbit_m");
  } else if (comparison == "statistics") {
    g.comparison = comparison_kind::statistics;
  } else {
    throw input_error(source + ": comparison must be 'orbit' or 'statistics' (got '" + comparison + "')");
  }
  g.period_revs = count("period_revs");
  for (const auto& info : statistic_table) {
    g.statistics.*info.member = number(info.key);
    g.statistics_tolerance.*info.member = number("tolerance_" + std::string(info.key));
  }
  try {
    validate(g.request);
  } catch (const input_error& e) {
    throw input_error(source + ": " + e.what());
  }
  try {
    g.t = r.column("t_s");
    g.x = r.column("x_m");
    g.y = r.column("y_m");
    g.vx = r.column("vx_m_s");
    g.vy = r.column("vy_m_s");
  } catch (const input_error& e) {
    throw input_error(prefix + e.what());
  }
  const std::size_t expected = static_cast<std::size_t>(g.request.record_revs) * static_cast<std::size_t>(g.request.samples_per_rev);
  if (g.t.size() != expected)
    throw input_error(source + ": " + std::to_string(g.t.size()) + " samples, but record_revs x samples_per_rev = " +
                      std::to_string(expected));
  if (r.find("coexisting_attractors")) {
    g.attractors_scanned = true;
    const int n = count("coexisting_attractors");
    for (int k = 1; k <= n; ++k) {
      coexisting_attractor a;
      a.start = need(attractor_key(k, "start"));
      a.period_revs = count(attractor_key(k, "period_revs"));
      a.max_multiplier = number(attractor_key(k, "max_multiplier"));
      const std::string key = attractor_key(k, "state");
      std::istringstream in(need(key));
      for (double& v : a.state)
        if (!(in >> v) || !std::isfinite(v))
          throw input_error((r.where(key).empty() ? source + ": " : r.where(key)) + "metadata '" + key + "' must be four finite numbers x y vx vy");
      if (a.period_revs < 1)
        throw input_error((r.where(attractor_key(k, "period_revs")).empty() ? source + ": " : r.where(attractor_key(k, "period_revs"))) +
                          "metadata '" + attractor_key(k, "period_revs") + "' must be at least 1");
      g.attractors.push_back(std::move(a));
    }
  }
  return g;
}

}  // namespace rubref
