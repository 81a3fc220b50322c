#include "ref/loop/preprocess.hpp"

#include <algorithm>
#include <cmath>
#include <complex>

#include "ref/errors.hpp"
#include "ref/parameters.hpp"

namespace rubref {

namespace {
// Only synchronous dwells can be fitted: the loop's models repeat every revolution. A dwell
// whose revolutions differ from their mean by more than this many times the noise (noise alone
// gives about 1x) holds subharmonic, quasi-periodic or chaotic motion, a drifting speed, or a
// transient that has not died out.
constexpr double kSpreadLimit = 2.0;
// Orders |k| >= 3 above this many times the averaged noise (sigma / sqrt(revolutions)) mean
// contact: noise alone stays below ~1.5x, the lightest contact the loop meets is ~100x.
constexpr double kContactDistortion = 5.0;
}  // namespace

double estimate_noise(const std::vector<loop_dwell>& dwells) {
  std::vector<const dwell*> all;
  for (const auto& ld : dwells) all.push_back(&ld.data);
  return estimate_probe_noise(all);
}

// The notch passes between the sample before a pulse and the pulse, so every pulse brackets the
// passage time to one sample; revolutions apart, the brackets of all pulses intersect in a much
// narrower one.
void align_by_keyphasor(loop_dwell& ld, std::vector<std::string>& notes) {
  dwell& d = ld.data;
  if (d.keyphasor.empty()) return;
  const double period = 60.0 / d.rpm;
  std::vector<std::size_t> pulses;
  for (std::size_t i = 1; i < d.size(); ++i)
    if (d.keyphasor[i] > 0.5 && !(d.keyphasor[i - 1] > 0.5)) pulses.push_back(i);
  if (pulses.empty()) {
    notes.push_back(d.source + ": no keyphasor pulse; times taken as recorded");
    return;
  }
  const double first = d.t[pulses.front()];
  double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity(), mean = 0.0;
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
  ld.timing_sigma = width / std::sqrt(12.0);  // uniform within the bracket
}

// Contact shows in the orbit even where it is not at the top (contact_angle): impacts put
// orders |k| >= 3 into the orbit, which no effect without contact does (unbalance, bow and
// preload are orders 0 and 1, misalignment and runout order 2, and misorientation keeps orders).
// RMS per probe of what orders -2..2 leave of one averaged revolution.
double high_order_content(const dwell& cycle) {
  const std::size_t n = cycle.size();
  const double w = cycle.omega();
  std::vector<std::complex<double>> z(n);
  for (std::size_t i = 0; i < n; ++i) z[i] = {cycle.x[i], cycle.y[i]};
  std::vector<std::complex<double>> rest = z;
  for (int k = -2; k <= 2; ++k) {
    std::complex<double> c;
    for (std::size_t i = 0; i < n; ++i) c += z[i] * std::polar(1.0 / static_cast<double>(n), -k * w * cycle.t[i]);
    for (std::size_t i = 0; i < n; ++i) rest[i] -= c * std::polar(1.0, k * w * cycle.t[i]);
  }
  double sq = 0.0;
  for (const auto& v : rest) sq += std::norm(v);
  return std::sqrt(sq / (2.0 * static_cast<double>(n)));
}

prepared_dwells prepare_dwells(const std::vector<std::pair<record, std::string>>& records, double mass, double clearance) {
  if (records.empty()) throw input_error("loop needs at least one record");
  prepared_dwells out;
  out.mass = mass;
  out.mass_source = mass > 0.0 ? "given" : "";
  std::vector<loop_dwell> all;
  for (const auto& [r, name] : records) {
    for (auto& d : split_dwells(r, name)) {
      if (!(d.clearance > 0.0)) d.clearance = clearance;
      if (!(d.clearance > 0.0)) throw input_error(name + ": no clearance_m metadata; give the clearance");
      loop_dwell ld{std::move(d), name};
      align_by_keyphasor(ld, out.notes);
      all.push_back(std::move(ld));
    }
    if (!(out.mass > 0.0) && r.find("m_kg")) {
      out.mass = r.number("m_kg");
      if (!(out.mass > 0.0 && std::isfinite(out.mass))) throw input_error(name + ": m_kg must be a finite mass > 0");
      out.mass_source = "m_kg of " + name;
    }
  }
  if (!(out.mass > 0.0)) {
    out.mass = parameters{}.m;
    out.mass_source = "the paper's (no m_kg metadata)";
  }
  out.noise = estimate_noise(all);
  const double noise = std::max(out.noise, 1e-12);
  for (auto& ld : all) {
    const averaged_dwell a = synchronous_average(ld.data);
    ld.contact = std::any_of(a.cycle.y.begin(), a.cycle.y.end(), [&](double y) { return y > ld.data.clearance; }) ||
                 high_order_content(a.cycle) > kContactDistortion * noise / std::sqrt(static_cast<double>(a.revolutions));
    if (a.spread > kSpreadLimit * noise) {
      out.excluded.push_back({ld.record, ld.data.rpm, ld.contact, a.spread,
                              "not synchronous: its revolutions differ by " + format_digits(a.spread * 1e6) + " um RMS (noise " +
                                  format_digits(noise * 1e6) + " um)"});
    } else {
      out.dwells.push_back(std::move(ld));
    }
  }
  return out;
}

}  // namespace rubref
