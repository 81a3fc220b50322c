#include "ref/loop/preprocess.hpp"

#include <algorithm>
#include <cmath>
#include <complex>

#include "ref/base/errors.hpp"
#include "ref/model/parameters.hpp"

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
// Periods tried for a dwell that does not repeat every revolution: the study's regime maps find
// period-2 and period-3 rub orbits of the paper's rotor, and rarely longer ones; beyond this the
// dwell is taken as not periodic.
constexpr int kMaxPeriods = 6;

// The average of a dwell over blocks of `periods` revolutions (as one "revolution" of rpm / periods).
averaged_dwell average_over(const dwell& d, int periods) {
  dwell slow = d;
  slow.rpm = d.rpm / periods;
  return synchronous_average(slow);
}
}  // namespace

double estimate_noise(const std::vector<loop_dwell>& dwells) {
  std::vector<const dwell*> all;
  for (const auto& ld : dwells) all.push_back(&ld.data);
  return estimate_probe_noise(all);
}

void align_by_keyphasor(loop_dwell& ld, std::vector<std::string>& notes) { ld.timing_sigma = rubref::align_by_keyphasor(ld.data, notes); }

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
      if (!(d.clearance > 0.0)) throw input_error(name + ": no clearance_m metadata; give " + setting("clearance"));
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
    if (a.spread <= kSpreadLimit * noise) {
      out.dwells.push_back(std::move(ld));
      continue;
    }
    // Not the same every revolution: the same every n revolutions? (Two blocks of n at least, to
    // tell.) Such motion is contact's: without it the model is linear in its forcing, whose only
    // periodic response repeats every revolution.
    int periods = 0;
    double spread = a.spread;
    for (int n = 2; n <= kMaxPeriods && !periods; ++n) {
      if (a.revolutions < 2 * n) break;
      const averaged_dwell an = average_over(ld.data, n);
      if (an.revolutions >= 2 && an.spread <= kSpreadLimit * noise) periods = n, spread = an.spread;
    }
    if (periods) {
      ld.periods = periods;
      ld.contact = true;
      out.notes.push_back(ld.record + " (" + format_digits(ld.data.rpm) + " rpm) repeats every " + std::to_string(periods) +
                          " revolutions, not every one (its revolutions differ by " + format_digits(a.spread * 1e6) + " um RMS, its blocks of " +
                          std::to_string(periods) + " by " + format_digits(spread * 1e6) + " um): it is fitted on the model's period-" +
                          std::to_string(periods) + " orbit");
      out.dwells.push_back(std::move(ld));
      continue;
    }
    const int tried = std::min(kMaxPeriods, a.revolutions / 2);
    out.excluded.push_back({ld.record, ld.data.rpm, ld.contact, a.spread,
                            "not periodic: its revolutions differ by " + format_digits(a.spread * 1e6) + " um RMS (noise " + format_digits(noise * 1e6) +
                                " um)" +
                                (tried >= 2 ? ", and so do its blocks of 2.." + std::to_string(tried) + " revolutions"
                                            : std::string(", and it has too few revolutions to test a longer period")) +
                                " (quasi-periodic or chaotic motion, a drifting speed, or a transient that has not died out)"});
  }
  return out;
}

}  // namespace rubref
