#include "ref/identification/identify.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include "ref/errors.hpp"
#include "ref/identification/term_library.hpp"
#include "ref/record.hpp"

namespace rubref {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct contact_sample {
  double z, zd, fn;
  std::size_t episode;
};

// Peak share of each term c_j * phi_j(z, z_dot) against the largest measured f_N.
std::vector<term_share> shares(const std::vector<candidate_term>& terms, const std::vector<double>& coef,
                               const std::vector<contact_sample>& samples) {
  double fn_max = 0.0;
  for (const auto& c : samples) fn_max = std::max(fn_max, std::abs(c.fn));
  std::vector<term_share> out;
  for (std::size_t j = 0; j < terms.size(); ++j) {
    double peak = 0.0;
    for (const auto& c : samples) peak = std::max(peak, std::abs(coef[j] * terms[j](c.z, c.zd)));
    out.push_back({terms[j].name(), fn_max > 0.0 ? peak / fn_max : 0.0});
  }
  return out;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - lo) * (v[hi] - v[lo]);
}

// The checks behind identification::warnings (docs/identification.md, "Warnings").
// A 95 % interval that contains 0 (value within 1.96 standard errors, or a bootstrap interval
// across 0) leaves the sign, let alone the size, undetermined.
constexpr double kInterval95 = 1.96;
// A steady contact-free dwell is its mean and 1X plus noise, whose RMS is the noise itself;
// content beyond 3 sigma is not noise (a transient, a nonlinearity, a second frequency). 1 nm
// floor: below any probe's resolution, so noise-free records are not flagged for rounding.
constexpr double kBeyond1xNoiseFactor = 3.0;
constexpr double kBeyond1xFloor = 1e-9;  // m
// A contact force cannot pull: an identified law whose f_N over the contact samples falls below
// -10 % of its peak pulls the rotor into the stator (a few per cent below 0 is the noise of f_N
// at onset and separation, where the law is near 0).
constexpr double kPullShare = 0.1;

std::string format_value(double v) { return format_digits(v, 4); }

void add_warnings(identification& id, const identify_settings& s);
identification identify_law(const std::vector<dwell>& dwells, const identify_settings& s);

}  // namespace

identification identify(const std::vector<std::pair<record, std::string>>& records, const identify_settings& s) {
  if (records.empty()) throw input_error("identify needs at least one record");
  std::vector<dwell> dwells;
  for (const auto& [r, name] : records) {
    for (auto& d : split_dwells(r, name)) {
      if (!(d.clearance > 0.0)) d.clearance = s.clearance;
      if (!(d.clearance > 0.0)) throw input_error(name + ": no clearance_m metadata; give --clearance");
      dwells.push_back(std::move(d));
    }
  }
  return identify(dwells, s);
}

identification identify(const std::vector<dwell>& dwells, const identify_settings& s) {
  identification id = identify_law(dwells, s);
  add_warnings(id, s);
  return id;
}

namespace {
identification identify_law(const std::vector<dwell>& dwells, const identify_settings& s) {
  if (dwells.empty()) throw input_error("identify needs at least one dwell");
  const std::vector<candidate_term> library = parse_library(s.library);
  const auto touches = [](const dwell& d) { return std::any_of(d.y.begin(), d.y.end(), [&](double y) { return y > d.clearance; }); };

  identification id;
  {
    std::vector<const dwell*> all;
    for (const auto& d : dwells) all.push_back(&d);
    id.probe_noise = estimate_probe_noise(all);
  }
  if (s.linear) {
    const parameters& p = *s.linear;
    id.linear = {p.m, p.c_x, p.c_y, p.k_x, p.k_y, p.e, p.unbalance_phase};
    id.linear_source = "given";
  } else {
    std::vector<const dwell*> free;
    for (const auto& d : dwells)
      if (!touches(d)) free.push_back(&d);
    id.linear_fitted = fit_linear_part(free, s.mass, s.derivative, s.linear_route);
    id.linear = id.linear_fitted->value;
    id.linear_source = "fitted";
  }

  std::vector<dwell_forces> forces;
  std::vector<averaged_dwell> averaged;  // kept alive: forces point at their cycles
  averaged.reserve(dwells.size());
  for (const auto& d : dwells) {
    if (!touches(d)) continue;
    if (s.average_revolutions) {
      averaged.push_back(synchronous_average(d));
      forces.push_back(contact_forces(averaged.back().cycle, id.linear, d.clearance, s.derivative));
    } else {
      forces.push_back(contact_forces(d, id.linear, d.clearance, s.derivative));
    }
  }
  if (forces.empty()) throw input_error("no dwell reaches its clearance: there is no contact to identify");

  // Friction per speed (Fig. 5) and the pooled contact samples for FROLS.
  std::vector<contact_sample> pooled;
  std::vector<std::vector<contact_sample>> per_dwell(forces.size());
  double fxfn = 0.0, fnfn = 0.0;
  std::vector<double> mu_means;
  for (std::size_t k = 0; k < forces.size(); ++k) {
    const auto& f = forces[k];
    dwell_report rep{f.source->rpm, f.source->clearance, 0, 0.0, f.source->size(), 0, 0, 0.0, std::nullopt, {}, {}};
    if (s.average_revolutions) {
      rep.averaged_revolutions = averaged[k].revolutions;
      rep.average_spread = averaged[k].spread;
    }
    const friction_estimate fe = estimate_friction(f);
    if (fe.samples > 0) {
      rep.friction = fe;
      mu_means.push_back(fe.mean);
    }
    for (std::size_t i = 0; i < f.fn.size(); ++i) {
      if (!f.contact[i]) continue;
      // A new episode starts where contact starts (a periodic cycle may wrap one around its end).
      if (i == 0 || !f.contact[i - 1]) ++id.episodes, ++rep.episodes;
      per_dwell[k].push_back({f.z[i], f.vy[i], f.fn[i], id.episodes - 1});
      rep.max_penetration = std::max(rep.max_penetration, f.z[i]);
      fxfn += f.fx[i] * f.fn[i];
      fnfn += f.fn[i] * f.fn[i];
    }
    rep.contact_samples = per_dwell[k].size();
    pooled.insert(pooled.end(), per_dwell[k].begin(), per_dwell[k].end());
    id.dwells.push_back(std::move(rep));
  }
  for (double m : mu_means) id.mu_mean += m / mu_means.size();
  for (double m : mu_means) id.mu_spread += (m - id.mu_mean) * (m - id.mu_mean);
  id.mu_spread = mu_means.size() > 1 ? std::sqrt(id.mu_spread / (mu_means.size() - 1)) : 0.0;
  id.mu_slope = fnfn > 0.0 ? fxfn / fnfn : 0.0;

  // FROLS over the pooled contact samples.
  const Eigen::Index n = static_cast<Eigen::Index>(pooled.size()), m = static_cast<Eigen::Index>(library.size());
  Eigen::MatrixXd P(n, m);
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) P(i, j) = library[j](pooled[i].z, pooled[i].zd);
    y[i] = pooled[i].fn;
  }
  id.contact_samples = pooled.size();
  id.force_rms = std::sqrt(y.squaredNorm() / std::max<Eigen::Index>(1, n));
  id.frols = frols(P, y, s.frols);
  for (const auto& t : library) {
    id.candidates.push_back(t.name());
    id.candidates_pretty.push_back(t.pretty());
  }
  for (Eigen::Index j = 0; j < m; ++j) {
    const double pp = P.col(j).squaredNorm();
    id.first_step_err.push_back(pp > 0.0 ? std::pow(P.col(j).dot(y), 2) / (pp * y.squaredNorm()) : 0.0);
  }
  id.residual_rms = std::sqrt(id.frols.residual.squaredNorm() / std::max<Eigen::Index>(1, n));
  {
    // The paper's Table 1 ranks z^3 (0.568) above z (0.392): its values in that order.
    const std::vector<std::string> paper_order{"z3", "z1", "zd2", "z2", "zd1", "zd3", "z4", "zd4"};
    std::vector<std::size_t> order;
    for (const auto& name : paper_order)
      for (std::size_t c = 0; c < id.candidates.size(); ++c)
        if (id.candidates[c] == name) order.push_back(c);
    if (order.size() == paper_order.size() && id.candidates.size() == paper_order.size()) {
      const std::vector<double> err = err_in_order(P, y, order);
      id.paper_order_err.assign(id.candidates.size(), 0.0);
      for (std::size_t k = 0; k < order.size(); ++k) id.paper_order_err[order[k]] = err[k];
    }
  }

  // Episode bootstrap: contact samples within an episode are correlated, whole episodes are not.
  const auto& kept = id.frols.kept;
  std::vector<std::vector<double>> boot(kept.size());
  if (s.bootstrap > 0 && id.episodes > 1 && !kept.empty()) {
    std::vector<std::vector<Eigen::Index>> rows_of(id.episodes);
    for (Eigen::Index i = 0; i < n; ++i) rows_of[pooled[i].episode].push_back(i);
    std::mt19937_64 rng(s.seed);  // its output sequence is fixed by the standard: same intervals everywhere
    for (int b = 0; b < s.bootstrap; ++b) {
      std::vector<Eigen::Index> rows;
      for (std::size_t e = 0; e < id.episodes; ++e) {
        const auto& r = rows_of[rng() % id.episodes];
        rows.insert(rows.end(), r.begin(), r.end());
      }
      if (rows.size() <= kept.size()) continue;
      Eigen::MatrixXd Pb(rows.size(), m);
      Eigen::VectorXd yb(rows.size());
      for (std::size_t i = 0; i < rows.size(); ++i) {
        Pb.row(i) = P.row(rows[i]);
        yb[i] = y[rows[i]];
      }
      const least_squares_fit fb = least_squares(Pb, yb, kept);
      for (std::size_t j = 0; j < kept.size(); ++j) boot[j].push_back(fb.coefficients[j]);
    }
  }
  for (std::size_t j = 0; j < kept.size(); ++j)
    id.estimates.push_back({library[kept[j]].name(), library[kept[j]].pretty(), id.frols.coefficients[j],
                            id.frols.standard_errors[j], percentile(boot[j], 0.025), percentile(boot[j], 0.975)});

  // Residual correlation tests, episode by episode.
  {
    std::vector<std::vector<double>> e(id.episodes), z(id.episodes), zd(id.episodes);
    for (Eigen::Index i = 0; i < n; ++i) {
      e[pooled[i].episode].push_back(id.frols.residual[i]);
      z[pooled[i].episode].push_back(pooled[i].z);
      zd[pooled[i].episode].push_back(pooled[i].zd);
    }
    id.validity = residual_tests(e, z, zd, s.correlation_lags);
  }

  // Term shares per speed: the reference law (Table 2) and the identified one.
  const std::vector<candidate_term> reference_terms = parse_library("z1,z3,zd2");
  std::vector<candidate_term> kept_terms;
  std::vector<double> kept_coef;
  for (std::size_t j = 0; j < kept.size(); ++j) {
    kept_terms.push_back(library[kept[j]]);
    kept_coef.push_back(id.frols.coefficients[j]);
  }
  for (std::size_t k = 0; k < forces.size(); ++k) {
    id.dwells[k].reference_shares = shares(reference_terms, {s.reference.k1, s.reference.k3, s.reference.c2}, per_dwell[k]);
    id.dwells[k].identified_shares = shares(kept_terms, kept_coef, per_dwell[k]);
  }

  {
    double peak = 0.0, least = 0.0;
    for (const auto& c : pooled) {
      double f = 0.0;
      for (std::size_t j = 0; j < kept_terms.size(); ++j) f += kept_coef[j] * kept_terms[j](c.z, c.zd);
      peak = std::max(peak, f), least = std::min(least, f);
    }
    if (!kept_terms.empty() && least < -kPullShare * peak)
      id.warnings.push_back("the identified law pulls the rotor into the stator: its f_N falls to " + format_value(least) +
                            " N over the contact samples (peak " + format_value(peak) + " N); a contact force cannot pull");
  }

  if (s.reidentify) {
    parameters start = s.reference;
    start.m = id.linear.m;
    start.c_x = id.linear.c_x;
    start.c_y = id.linear.c_y;
    start.k_x = id.linear.k_x;
    start.k_y = id.linear.k_y;
    start.e = id.linear.e;
    start.delta = forces.front().source->clearance;
    start.mu = id.mu_mean;
    start.k1 = start.k3 = start.c2 = 0.0;
    for (const auto& est : id.estimates) {
      if (est.name == "z1") start.k1 = est.value;
      if (est.name == "z3") start.k3 = est.value;
      if (est.name == "zd2") start.c2 = est.value;
    }
    // Only Eq. 5's family can be simulated; fit what FROLS found of it (positive starts).
    reid_settings rs = s.reid;
    rs.derivative_half_width = s.derivative.half_width;
    std::erase_if(rs.fit, [&](const std::string& name) {
      return (name == "k1" && !(start.k1 > 0)) || (name == "k3" && !(start.k3 > 0)) || (name == "c2" && !(start.c2 > 0)) ||
             (name == "mu" && !(start.mu > 0));
    });
    id.reid = reidentify(forces, start, id.linear.phase, rs);
  }
  return id;
}

void add_warnings(identification& id, const identify_settings& s) {
  auto& w = id.warnings;
  if (id.linear_fitted) {
    const auto& L = id.linear;
    const auto& se = id.linear_fitted->standard_error;
    const std::array<std::pair<const char*, double>, 4> values{{{"c_x", L.c_x}, {"c_y", L.c_y}, {"k_x", L.k_x}, {"k_y", L.k_y}}};
    for (std::size_t i = 0; i < values.size(); ++i) {
      const auto& [name, v] = values[i];
      if (!(v > 0.0))
        w.push_back(std::string("linear part: ") + name + " = " + format_value(v) + " is unphysical (damping and stiffness are > 0)");
      else if (v <= kInterval95 * se[i])
        w.push_back(std::string("linear part: ") + name + " = " + format_value(v) + " ± " + format_value(se[i]) +
                    " (standard error) is not determined by the contact-free dwells");
    }
    const auto& beyond = id.linear_fitted->beyond_1x_rms;
    const double limit = std::max(kBeyond1xNoiseFactor * id.probe_noise, kBeyond1xFloor);
    for (std::size_t k = 0; k < beyond.size(); ++k)
      if (beyond[k] > limit)
        w.push_back("linear part: contact-free dwell " + std::to_string(k + 1) + " has " + format_value(beyond[k]) +
                    " m RMS beyond its 1X response, above 3x the probe noise (" + format_value(id.probe_noise) +
                    " m): not a steady linear response (a transient, a nonlinearity or a second frequency)");
  }
  for (const auto& e : id.estimates) {
    if (e.name == "z1" && !(e.value > 0.0))
      w.push_back("term " + e.name + ": k1 = " + format_value(e.value) + " N/m is unphysical (a contact stiffness is > 0)");
    const bool bootstrap_across_zero = std::isfinite(e.ci_low) && std::isfinite(e.ci_high) && e.ci_low <= 0.0 && e.ci_high >= 0.0;
    if (bootstrap_across_zero || std::abs(e.value) <= kInterval95 * e.standard_error)
      w.push_back("term " + e.name + " = " + format_value(e.value) + ": its 95 % interval contains 0 (standard error " +
                  format_value(e.standard_error) + (std::isfinite(e.ci_low) ? ", bootstrap [" + format_value(e.ci_low) + ", " +
                  format_value(e.ci_high) + "]" : std::string()) + "): the data do not determine it");
  }
  if (!(id.mu_mean >= 0.0 && id.mu_mean <= 1.0))
    w.push_back("friction: mu = " + format_value(id.mu_mean) + " is outside [0, 1]: implausible for a rub");
  else if (id.dwells.size() > 1 && id.mu_spread > id.mu_mean)
    w.push_back("friction: the per-speed means of mu scatter by " + format_value(id.mu_spread) + " around " + format_value(id.mu_mean) +
                ": not determined by the data");
  std::string failed;
  for (const auto& t : id.validity)
    if (!t.pass) failed += (failed.empty() ? "" : ", ") + t.name;
  // Residual structure matters only where the residual does: when the kept terms leave more than
  // rho of the force's variance unexplained (FROLS's own stopping share). On clean records the
  // residual is the derivatives' truncation error, correlated but ~1e-6 of the force.
  const double unexplained = id.force_rms > 0.0 ? std::pow(id.residual_rms / id.force_rms, 2) : 0.0;
  if (!failed.empty() && unexplained > s.frols.rho)
    w.push_back("residual tests failed (" + failed + ") with " + format_value(100.0 * unexplained) +
                " % of the force's variance unexplained: the law leaves structure in the residual, or noise dominates the forces");
  if (id.reid) {
    const auto& r = *id.reid;
    if (r.final_failed)
      w.push_back("re-identification: the model's orbit could not be computed at the final parameters (" + r.failure +
                  "): its estimates are not valid");
    else if (r.failed_evaluations > 0)
      w.push_back("re-identification: " + std::to_string(r.failed_evaluations) + " of " + std::to_string(r.evaluations) +
                  " evaluations could not compute the model's orbit (" + r.failure + ")");
    if (r.initial_failed)
      w.push_back("re-identification: the start (FROLS's law) does not simulate (" + r.failure + ")");
    for (const auto& p : r.parameters) {
      if (p.at_bound)
        w.push_back("re-identification: " + p.name + " = " + format_value(p.value) + " is at its bound (0 or 10x its start " +
                    format_value(p.initial) + ")");
    }
  }
}
}  // namespace

nlohmann::ordered_json to_json(const identification& id, const identify_settings& s) {
  using json = nlohmann::ordered_json;
  const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json j;
  j["settings"] = {{"library", s.library},
                   {"rho", s.frols.rho},
                   {"err_threshold", s.frols.err_threshold},
                   {"stop", s.frols.stop == frols_stop::err_sum ? "err_sum" : s.frols.stop == frols_stop::aic ? "aic" : "bic"},
                   {"derivative", {{"method", "Savitzky-Golay, windows split at y = clearance"},
                                   {"half_width", s.derivative.half_width}, {"degree", s.derivative.degree}}},
                   {"bootstrap_resamples", s.bootstrap},
                   {"friction_force_share", kFrictionForceShare}};
  const auto& L = id.linear;
  j["linear"] = {{"source", id.linear_source}, {"method", id.linear_fitted ? std::string(to_string(id.linear_fitted->method)) : "given"},
                 {"m_kg", L.m}, {"c_x_kg_s", L.c_x}, {"c_y_kg_s", L.c_y}, {"k_x_N_m", L.k_x},
                 {"k_y_N_m", L.k_y}, {"e_m", L.e}, {"unbalance_phase_rad", L.phase}};
  if (id.linear_fitted) {
    const auto& se = id.linear_fitted->standard_error;
    j["linear"]["standard_error"] = {{"c_x_kg_s", se[0]}, {"c_y_kg_s", se[1]}, {"k_x_N_m", se[2]}, {"k_y_N_m", se[3]},
                                     {"e_m", se[4]}, {"unbalance_phase_rad", se[5]}};
    j["linear"]["dwells"] = id.linear_fitted->dwells;
    j["linear"]["residual_rms_m_s2"] = id.linear_fitted->residual_rms;
    if (!id.linear_fitted->beyond_1x_rms.empty()) j["linear"]["beyond_1x_rms_m"] = id.linear_fitted->beyond_1x_rms;
    j["linear"]["note"] = "m is not identifiable from displacements (Eq. 1 scales with it); it is taken as given";
  }
  j["friction"] = {{"mu_mean", id.mu_mean}, {"mu_spread", id.mu_spread}, {"mu_slope", id.mu_slope}};
  for (const auto& d : id.dwells) {
    json jd = {{"speed_rpm", d.rpm}, {"clearance_m", d.clearance}, {"samples", d.samples}, {"contact_samples", d.contact_samples},
               {"episodes", d.episodes}, {"max_penetration_m", d.max_penetration}};
    if (d.friction)
      jd["mu"] = {{"samples", d.friction->samples}, {"mean", d.friction->mean}, {"std", d.friction->std_dev},
                  {"median", d.friction->median}, {"slope", d.friction->slope}};
    for (const auto& sh : d.reference_shares) jd["reference_law_peak_share"][sh.term] = sh.peak_share;
    for (const auto& sh : d.identified_shares) jd["identified_law_peak_share"][sh.term] = sh.peak_share;
    j["dwells"].push_back(jd);
  }
  j["frols"]["contact_samples"] = id.contact_samples;
  j["frols"]["episodes"] = id.episodes;
  j["frols"]["force_rms_N"] = id.force_rms;
  for (std::size_t k = 0; k < id.frols.order.size(); ++k) {
    const auto& st = id.frols.order[k];
    j["frols"]["order"].push_back({{"step", k + 1}, {"term", id.candidates[st.candidate]}, {"err", st.err},
                                   {"err_sum", st.err_sum}, {"aic", st.aic}, {"bic", st.bic}});
  }
  for (std::size_t c = 0; c < id.candidates.size(); ++c) j["frols"]["first_step_err"][id.candidates[c]] = id.first_step_err[c];
  for (std::size_t c = 0; c < id.paper_order_err.size(); ++c) j["frols"]["paper_order_err"][id.candidates[c]] = id.paper_order_err[c];
  j["frols"]["steps_selected"] = id.frols.steps_selected;
  j["frols"]["err_sum_kept"] = id.frols.err_sum_kept;
  j["frols"]["residual_rms_N"] = id.residual_rms;
  for (const auto& e : id.estimates)
    j["estimates"].push_back({{"term", e.name}, {"value", e.value}, {"standard_error", e.standard_error},
                              {"bootstrap_95", {num(e.ci_low), num(e.ci_high)}}});
  for (const auto& t : id.validity)
    j["validity"].push_back({{"test", t.name}, {"band", t.band}, {"max_abs", t.max_abs},
                             {"outside_fraction", t.outside_fraction}, {"pass", t.pass}});
  if (id.reid) {
    j["reidentification"] = {{"algorithm", id.reid->algorithm}, {"evaluations", id.reid->evaluations},
                             {"failed_evaluations", id.reid->failed_evaluations}, {"final_failed", id.reid->final_failed},
                             {"initial_rms_m", num(id.reid->initial_rms)}, {"final_rms_m", num(id.reid->final_rms)}};
    for (const auto& p : id.reid->parameters)
      j["reidentification"]["parameters"].push_back({{"name", p.name}, {"initial", p.initial}, {"value", p.value},
                                                     {"standard_error", num(p.standard_error)}, {"identifiable", p.identifiable},
                                                     {"at_bound", p.at_bound}});
  }
  j["probe_noise_m"] = id.probe_noise;
  j["warnings"] = id.warnings;
  return j;
}

std::string to_markdown(const identification& id) {
  std::ostringstream md;
  md.precision(4);
  md << "# Identification\n\n";
  if (!id.warnings.empty()) {
    md << "## Warnings\n\n";
    for (const auto& w : id.warnings) md << "- " << w << "\n";
    md << "\n";
  }
  md << "Probe noise (from the data): " << id.probe_noise << " m.\n\n";
  md << "Linear part (" << id.linear_source << "): m = " << id.linear.m << " kg, c_x = " << id.linear.c_x << " kg/s, c_y = "
     << id.linear.c_y << " kg/s, k_x = " << id.linear.k_x << " N/m, k_y = " << id.linear.k_y << " N/m, e = " << id.linear.e
     << " m, unbalance phase = " << id.linear.phase << " rad.\n\n";
  md << "## ERR of each term (Table 1)\n\n| step | term | ERR | ERR alone |\n|---|---|---|---|\n";
  for (std::size_t k = 0; k < id.frols.order.size(); ++k) {
    const auto& st = id.frols.order[k];
    md << "| " << k + 1 << " | " << id.candidates_pretty[st.candidate] << " | " << st.err << " | " << id.first_step_err[st.candidate] << " |\n";
  }
  md << "\nSelected " << id.frols.steps_selected << " steps; kept (ERR ≥ threshold): ";
  for (const auto& e : id.estimates) md << e.pretty << " ";
  md << "(Σ ERR " << id.frols.err_sum_kept << ").\n\n## Estimates (Table 2)\n\n| term | value | standard error | bootstrap 95 % |\n|---|---|---|---|\n";
  for (const auto& e : id.estimates)
    md << "| " << e.pretty << " | " << e.value << " | " << e.standard_error << " | [" << e.ci_low << ", " << e.ci_high << "] |\n";
  md << "\nResidual RMS " << id.residual_rms << " N against an RMS contact force of " << id.force_rms << " N over "
     << id.contact_samples << " contact samples in " << id.episodes << " episodes.\n\n";
  md << "## Friction per speed (Fig. 5)\n\n| speed [rpm] | samples | mean μ | std | median | slope |\n|---|---|---|---|---|---|\n";
  for (const auto& d : id.dwells)
    if (d.friction)
      md << "| " << d.rpm << " | " << d.friction->samples << " | " << d.friction->mean << " | " << d.friction->std_dev << " | "
         << d.friction->median << " | " << d.friction->slope << " |\n";
  md << "\nμ = " << id.mu_mean << " (mean over speeds, spread " << id.mu_spread << "); pooled slope " << id.mu_slope << ".\n\n";
  md << "## Residual correlation tests\n\n| test | max |φ| | band | outside | pass |\n|---|---|---|---|---|\n";
  for (const auto& t : id.validity)
    md << "| " << t.name << " | " << t.max_abs << " | " << t.band << " | " << t.outside_fraction << " | " << (t.pass ? "yes" : "no") << " |\n";
  if (id.reid) {
    md << "\n## Output-error re-identification (" << id.reid->algorithm << ", " << id.reid->evaluations << " evaluations)\n\n"
       << "Orbit RMS error " << id.reid->initial_rms << " m → " << id.reid->final_rms << " m.\n\n| parameter | start | estimate | standard error | identifiable |\n|---|---|---|---|---|\n";
    for (const auto& p : id.reid->parameters)
      md << "| " << p.name << " | " << p.initial << " | " << p.value << " | " << p.standard_error << " | " << (p.identifiable ? "yes" : "no") << " |\n";
  }
  return md.str();
}

}  // namespace rubref
