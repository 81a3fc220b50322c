#include "ref/identification/dwells.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>

#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"
#include "ref/model/state.hpp"

namespace rubref {

double dwell::omega() const { return rpm_to_rad_s(rpm); }

namespace {
// Data row i sits on file line first_data_line(r) + i (for messages; a record made in memory
// counts its metadata and header lines).
std::size_t first_data_line(const record& r) { return r.first_data_line > 0 ? r.first_data_line : r.metadata.size() + 2; }
}  // namespace

void check_displacement_scale(const record& r, const std::string& source) {
  std::string column;
  double peak = 0.0;
  std::size_t row = 0;
  for (const char* name : {"x_m", "y_m"}) {
    const auto& v = r.column(name);
    for (std::size_t i = 0; i < v.size(); ++i)
      if (std::abs(v[i]) > peak) peak = std::abs(v[i]), row = i, column = name;
  }
  if (peak < kImplausibleDisplacement) return;
  std::string hint = "the displacements must be metres from the stator's centre";
  for (const auto& [scale, unit, by] : {std::tuple{1e-3, "millimetres", "1000"}, std::tuple{1e-6, "micrometres", "1e6"}})
    if (peak * scale < kImplausibleDisplacement) {
      hint = "if the file holds " + std::string(unit) + ", divide x_m and y_m by " + by;
      break;
    }
  throw input_error(source + ":" + std::to_string(first_data_line(r) + row) + ": " + column + " reaches " + format_digits(r.column(column)[row]) +
                    " m, and no rotor kit's shaft moves " + format_digits(kImplausibleDisplacement * 1e3, 2) + " mm or more: " + hint);
}

std::vector<dwell> split_dwells(const record& r, const std::string& source, std::size_t min_samples) {
  const auto& t = r.column("t_s");
  const auto& x = r.column("x_m");
  const auto& y = r.column("y_m");
  const auto& rpm = r.column("speed_rpm");
  const bool has_keyphasor = std::find(r.columns.begin(), r.columns.end(), "keyphasor") != r.columns.end();
  check_displacement_scale(r, source);
  const std::size_t first_line = first_data_line(r);
  const std::string at_clearance = r.where("clearance_m").empty() ? source + ": " : r.where("clearance_m");
  double clearance = 0.0;
  if (r.find("clearance_m")) {
    try {
      clearance = r.number("clearance_m");
    } catch (const input_error& e) {
      throw input_error((r.source.empty() ? source + ": " : std::string()) + e.what());
    }
    if (!(clearance > 0.0 && std::isfinite(clearance))) throw input_error(at_clearance + "clearance_m must be a finite length > 0");
  }
  std::vector<dwell> out;
  for (std::size_t i = 0; i < t.size();) {
    std::size_t j = i;
    while (j + 1 < t.size() && rpm[j + 1] == rpm[i]) ++j;
    dwell d;
    d.rpm = rpm[i];
    d.clearance = clearance;
    d.source = source + ", lines " + std::to_string(first_line + i) + "-" + std::to_string(first_line + j);
    if (!(d.rpm > 0.0)) throw input_error(d.source + ": speed_rpm must be > 0 (got " + std::to_string(d.rpm) + ")");
    if (j - i + 1 < min_samples)
      throw input_error(d.source + ": a dwell of " + std::to_string(j - i + 1) + " samples is shorter than " + std::to_string(min_samples));
    d.t.assign(t.begin() + i, t.begin() + j + 1);
    d.x.assign(x.begin() + i, x.begin() + j + 1);
    d.y.assign(y.begin() + i, y.begin() + j + 1);
    if (has_keyphasor) {
      const auto& kp = r.column("keyphasor");
      d.keyphasor.assign(kp.begin() + i, kp.begin() + j + 1);
    }
    d.dt = (d.t.back() - d.t.front()) / static_cast<double>(d.size() - 1);
    // Uniform to 1e-6 of a step: enough for the fixed-weight derivative filters.
    constexpr double kUniformTol = 1e-6;
    for (std::size_t k = 1; k < d.size(); ++k)
      if (std::abs((d.t[k] - d.t[k - 1]) - d.dt) > kUniformTol * d.dt)
        throw input_error(source + ":" + std::to_string(first_line + i + k) + ": sampling is not uniform within the dwell at " +
                          std::to_string(d.rpm) + " rpm");
    out.push_back(std::move(d));
    i = j + 1;
  }
  return out;
}

averaged_dwell synchronous_average(const dwell& d) {
  const double period = 60.0 / d.rpm;
  const double per_rev = period / d.dt;
  const auto n = static_cast<std::size_t>(std::lround(per_rev));
  const bool on_grid = std::abs(per_rev - static_cast<double>(n)) < 1e-6 * per_rev;
  // Whole revolutions whose resampled points all lie on the record: the last one's final point,
  // one phase step before its end, must not pass the last sample.
  const int revs = static_cast<int>(std::floor((d.t.back() - d.t.front() + period / static_cast<double>(n)) / period + 1e-9));
  if (n < 8 || revs < 1)
    throw input_error(d.source + ": synchronous averaging needs at least one whole revolution of 8 or more samples");
  // Catmull-Rom cubic interpolation of v at time t (only when the grid does not land on samples).
  const auto at = [&](const std::vector<double>& v, double t) {
    const double u = (t - d.t.front()) / d.dt;
    const auto i = static_cast<std::ptrdiff_t>(std::floor(u));
    const double f = u - static_cast<double>(i);
    const auto s = [&](std::ptrdiff_t k) { return v[static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(k, 0, static_cast<std::ptrdiff_t>(v.size()) - 1))]; };
    const double p0 = s(i - 1), p1 = s(i), p2 = s(i + 1), p3 = s(i + 2);
    return p1 + 0.5 * f * (p2 - p0 + f * (2 * p0 - 5 * p1 + 4 * p2 - p3 + f * (3 * (p1 - p2) + p3 - p0)));
  };
  averaged_dwell out;
  out.revolutions = revs;
  dwell& c = out.cycle;
  c.rpm = d.rpm;
  c.clearance = d.clearance;
  c.periodic = true;
  c.dt = period / static_cast<double>(n);
  c.source = d.source + " (averaged over " + std::to_string(revs) + " revolutions)";
  c.t.resize(n);
  c.x.assign(n, 0.0);
  c.y.assign(n, 0.0);
  std::vector<double> xs(n * revs), ys(n * revs);
  for (int r = 0; r < revs; ++r)
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = static_cast<std::size_t>(r) * n + k;
      xs[i] = on_grid ? d.x[i] : at(d.x, d.t.front() + r * period + k * c.dt);
      ys[i] = on_grid ? d.y[i] : at(d.y, d.t.front() + r * period + k * c.dt);
      c.x[k] += xs[i] / revs;
      c.y[k] += ys[i] / revs;
    }
  double sq = 0.0;
  for (int r = 0; r < revs; ++r)
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = static_cast<std::size_t>(r) * n + k;
      sq += std::pow(xs[i] - c.x[k], 2) + std::pow(ys[i] - c.y[k], 2);
    }
  out.spread = std::sqrt(sq / (2.0 * n * revs));
  for (std::size_t k = 0; k < n; ++k) c.t[k] = d.t.front() + static_cast<double>(k) * c.dt;
  return out;
}

// The notch passes between the sample before a pulse and the pulse, so every pulse brackets the
// passage time to one sample; revolutions apart, the brackets of all pulses intersect in a much
// narrower one.
double align_by_keyphasor(dwell& d, std::vector<std::string>& notes) {
  constexpr double kNone = std::numeric_limits<double>::infinity();
  if (d.keyphasor.empty()) return kNone;
  const double period = 60.0 / d.rpm;
  std::vector<std::size_t> pulses;
  for (std::size_t i = 1; i < d.size(); ++i)
    if (d.keyphasor[i] > 0.5 && !(d.keyphasor[i - 1] > 0.5)) pulses.push_back(i);
  if (pulses.empty()) {
    notes.push_back(d.source + ": no keyphasor pulse; times taken as recorded");
    return kNone;
  }
  const double first = d.t[pulses.front()];
  double lo = -kNone, hi = kNone, mean = 0.0;
  // Closed brackets, widened by a hair: with a sample rate that is a whole multiple of the speed
  // the notch can pass exactly at a sample, and rounding puts that pulse on either side of it.
  const double hair = 1e-6 * d.dt;
  for (const std::size_t i : pulses) {
    const double revs = std::round((d.t[i] - first) / period);
    const double t = d.t[i] - revs * period;
    lo = std::max(lo, t - d.dt - hair);
    hi = std::min(hi, t + hair);
    mean += t / static_cast<double>(pulses.size());
  }
  double t0 = 0.5 * (lo + hi), width = hi - lo;
  if (!(hi > lo)) {  // the brackets disagree: the speed is not what the record states
    notes.push_back(d.source + ": keyphasor pulses are not one revolution of " + format_digits(d.rpm) + " rpm apart");
    t0 = mean - 0.5 * d.dt;
    width = d.dt;
  }
  for (double& t : d.t) t -= t0;
  d.timing_sigma = width / std::sqrt(12.0);  // uniform within the bracket
  return d.timing_sigma;
}

double estimate_probe_noise(const std::vector<const dwell*>& dwells) {
  std::vector<double> a;
  for (const auto* d : dwells)
    for (const auto* v : {&d->x, &d->y})
      for (std::size_t i = 4; i < v->size(); ++i)
        a.push_back(std::abs((*v)[i] - 4 * (*v)[i - 1] + 6 * (*v)[i - 2] - 4 * (*v)[i - 3] + (*v)[i - 4]));
  if (a.empty()) return 0.0;
  std::nth_element(a.begin(), a.begin() + static_cast<std::ptrdiff_t>(a.size() / 2), a.end());
  return 1.4826 * a[a.size() / 2] / std::sqrt(70.0);
}

double quantisation_step(const std::vector<double>& v) {
  std::vector<double> u(v);
  std::sort(u.begin(), u.end());
  u.erase(std::unique(u.begin(), u.end()), u.end());
  if (u.size() < 2) return 0.0;
  double q = std::numeric_limits<double>::infinity();
  for (std::size_t i = 1; i < u.size(); ++i) q = std::min(q, u[i] - u[i - 1]);
  // On the grid: every value a whole number of steps from the smallest, to a thousandth of a step
  // (values read back from decimal text carry ~1e-16 relative rounding, far below that).
  for (const double x : u) {
    const double steps = (x - u.front()) / q;
    if (std::abs(steps - std::round(steps)) > 1e-3) return 0.0;
  }
  return q;
}

dwell_noise estimate_dwell_noise(const dwell& d) {
  dwell_noise n;
  n.white = estimate_probe_noise({&d});
  n.quantisation = std::max(quantisation_step(d.x), quantisation_step(d.y));
  n.sigma = std::max(n.white, n.quantisation / std::sqrt(12.0));
  return n;
}

}  // namespace rubref
