#include "ref/golden.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <optional>
#include <sstream>

#include "ref/errors.hpp"
#include "ref/orbit_io.hpp"
#include "ref/orbit_summary.hpp"
#include "ref/orbits/periodic_orbit.hpp"
#include "ref/parallel.hpp"
#include "ref/parameter_io.hpp"
#include "ref/version.hpp"
#include "variants/all_variants.hpp"

namespace rubref {

orbit_statistics statistics_of(std::span<const double> t, std::span<const double> x, std::span<const double> y,
                               double omega, double delta) {
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
    if (y[i] > delta) ++in_contact;
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
      for (const double rpm : kGoldenSpeeds) out.push_back({std::string(decltype(law)::name), c, rpm});
  });
  return out;
}

std::string golden_file_name(const golden_spec& spec) {
  return spec.variant + "_" + format_number(spec.clearance * 1e3) + "mm_" + format_number(spec.rpm) + "rpm.csv";
}

run_request golden_request(const golden_spec& spec) {
  run_request req;
  req.variant = spec.variant;
  req.params.delta = spec.clearance;
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

std::string str(double v) { return format_number(v); }

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
  return statistics_of(t, x, y, rpm_to_rad_s(o.request.rpm), o.request.params.delta);
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

}  // namespace

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
  r.set("description", "rubref golden orbit: " + spec.variant + ", clearance " + mm + " mm, " + str(spec.rpm) +
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
  r.set("stick_velocity_m_s", req.integration.events.stick_velocity);
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
