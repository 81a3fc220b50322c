#include "ref/identification/identify.hpp"

#include <algorithm>
#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <limits>
#include <numbers>

#include "ref/base/errors.hpp"
#include "ref/base/portable_random.hpp"
#include "ref/format/record.hpp"
#include "ref/identification/term_library.hpp"
#include "ref/inference/evidence.hpp"

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


// A dwell is steady (its revolutions repeat) when they differ from their mean by at most twice
// the probe noise (noise alone gives ~1x; the loop's rule, docs/loop.md); the floor keeps
// noise-free records, whose noise estimate is their rounding, from being judged unsteady by it.
constexpr double kSteadySpread = 2.0;
constexpr double kSteadyFloor = 1e-8;  // m
// The weak form's residual is flagged when it exceeds the noise (chi^2 test) and also leaves more
// than this share of the integrals' variance unexplained: on noise-free records the residual is
// the quadrature's, far above the ~0 noise but ~1e-6 of the signal.
constexpr double kWeakUnexplained = 1e-4;

// The weak form's intervals. The rows' covariance counts the noise in the integrals of Eq. 1,
// not the noise the regressors take from z and z_dot; perturbing the data once more with the
// same noise and refitting moves the estimate by both (to first order, with the estimate's own
// covariance). kSpreadRepeats: the spread's standard error is ~1/sqrt(2 x 50) = 10 % of itself.
// The same perturbations give what one dose of the noise adds to the residual variance per row
// (regressors' noise included): the scale of the weak form's chi^2 test.
constexpr int kSpreadRepeats = 50;
// The identification's two random streams, both keyed by its seed: the perturbations' noise and
// the episode bootstrap's resamples.
constexpr std::uint64_t kPerturbationStream = 0, kBootstrapStream = 1;

struct perturbation_spread {
  Eigen::MatrixXd cov;             // of the estimate
  double residual_variance = 0.0;  // added to the whitened rows' residual variance by one dose of noise
  int done = 0;                    // perturbations that gave a fit (of kSpreadRepeats)
};

perturbation_spread perturbation_covariance(const std::vector<std::pair<const dwell*, double>>& used, const linear_part& lin,
                                        const std::vector<candidate_term>& terms, const derivative_settings& velocity,
                                        const weak_form_settings& ws, double residual_variance, unsigned seed) {
  const auto p = static_cast<Eigen::Index>(terms.size());
  portable_stream rng(seed, kPerturbationStream);  // the same draws on any toolchain (ref/base/portable_random.hpp)
  const auto gauss = [&rng] { return rng.normal(); };
  std::vector<std::size_t> all(terms.size());
  for (std::size_t j = 0; j < all.size(); ++j) all[j] = j;
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(p);
  Eigen::MatrixXd second = Eigen::MatrixXd::Zero(p, p);
  double added = 0.0;
  int done = 0;
  for (int r = 0; r < kSpreadRepeats; ++r) {
    std::vector<dwell> noisy;
    noisy.reserve(used.size());
    for (const auto& [d, sigma] : used) {
      dwell c = *d;
      for (double& v : c.x) v += sigma * gauss();
      for (double& v : c.y) v += sigma * gauss();
      noisy.push_back(std::move(c));
    }
    std::vector<dwell_forces> forces;
    forces.reserve(noisy.size());
    for (const auto& c : noisy) forces.push_back(contact_forces(c, lin, c.clearance, velocity));
    std::vector<weak_form_input> in;
    // The perturbed data carry twice the noise variance: z_dot^p unbiased at that level.
    for (std::size_t k = 0; k < forces.size(); ++k) in.push_back({&forces[k], used[k].second * std::numbers::sqrt2});
    try {
      const weak_form_system sys = weak_form(in, lin, terms, ws);
      const least_squares_fit fit = least_squares(sys.A, sys.b, all);
      mean += fit.coefficients;
      second += fit.coefficients * fit.coefficients.transpose();
      added += fit.residual.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, sys.A.rows() - p)) - residual_variance;
      ++done;
    } catch (const input_error&) {  // a perturbation that leaves no usable episode: not counted
    }
  }
  if (done < 2) return {Eigen::MatrixXd::Zero(p, p), 0.0, done};
  mean /= done;
  return {(second / done - mean * mean.transpose()) * (static_cast<double>(done) / (done - 1)), added / done, done};
}

void add_warnings(identification& id, const identify_settings& s);
identification identify_law(const std::vector<dwell>& dwells, const identify_settings& s);

}  // namespace

std::string_view to_string(law_method m) {
  switch (m) {
    case law_method::automatic: return "auto";
    case law_method::samples: return "samples";
    case law_method::weak_form: return "weak-form";
  }
  return "?";
}

law_method parse_law_method(const std::string& name) {
  for (const auto m : {law_method::automatic, law_method::samples, law_method::weak_form})
    if (name == to_string(m)) return m;
  throw input_error("unknown law method '" + name + "' (auto, samples, weak-form)");
}

std::string_view to_string(averaging a) {
  switch (a) {
    case averaging::automatic: return "auto";
    case averaging::always: return "on";
    case averaging::never: return "off";
  }
  return "?";
}

averaging parse_averaging(const std::string& name) {
  for (const auto a : {averaging::automatic, averaging::always, averaging::never})
    if (name == to_string(a)) return a;
  throw input_error("unknown averaging '" + name + "' (auto, on, off)");
}

identification identify(const std::vector<std::pair<record, std::string>>& records, const identify_settings& s) {
  if (records.empty()) throw input_error("identify needs at least one record");
  s.validate();  // before any work: every setting by its registry row, the --reid-fit names
  std::vector<dwell> dwells;
  std::vector<std::string> notes;
  for (const auto& [r, name] : records) {
    for (auto& d : split_dwells(r, name)) {
      if (!(d.clearance > 0.0)) d.clearance = s.clearance;
      if (!(d.clearance > 0.0)) throw input_error(name + ": no clearance_m metadata; give " + setting("clearance"));
      // Dwell times on the shaft's angle (the unbalance phase and Eq. 1's forcing need it).
      align_by_keyphasor(d, notes);
      dwells.push_back(std::move(d));
    }
  }
  identification id = identify(dwells, s);
  id.notes.insert(id.notes.begin(), notes.begin(), notes.end());
  return id;
}

identification identify(const std::vector<dwell>& dwells, const identify_settings& s) {
  s.validate();
  identification id = identify_law(dwells, s);
  add_warnings(id, s);
  return id;
}

namespace {
// The weak form's rows cannot rank the library (too few contact episodes).
struct weak_form_rank_error : input_error {
  explicit weak_form_rank_error(const std::string& why)
      : input_error("weak form: " + why + " (record more dwells or revolutions, or set " + setting("law_method") + " to samples)"), detail(why) {}
  std::string detail;
};

// identify_law's steps (below, in order) each take what they need and return what they find;
// identify_law_by passes the values from one to the next and assembles the identification.

// A law of the library's terms: f_N = sum_j coef_j phi_j(z, z_dot).
struct contact_law {
  std::vector<candidate_term> terms;
  std::vector<double> coef;
  double operator()(double z, double zd) const {
    double f = 0.0;
    for (std::size_t j = 0; j < terms.size(); ++j) f += coef[j] * terms[j](z, zd);
    return f;
  }
};

// A step's notes or warnings after those before it.
template <class T>
void append(std::vector<T>& to, const std::vector<T>& from) {
  to.insert(to.end(), from.begin(), from.end());
}

bool touches(const dwell& d) {
  return std::any_of(d.y.begin(), d.y.end(), [&](double y) { return y > d.clearance; });
}

// The linear part refitted on the re-timed contact-free dwells, and the note saying so.
struct free_dwells_retimed {
  linear_fit refit;
  bool untimed = false;  // some have no keyphasor
  std::string note;
};

// Contact-free dwells whose 1X phases reject one shaft angle (linear_fit::phase_chi2) put on one
// (shaft_angle_shifts), and the linear part fitted again on them.
std::optional<free_dwells_retimed> put_free_on_one_angle(const std::vector<const dwell*>& free, const linear_fit& first,
                                                         const identify_settings& s) {
  if (!(first.phase_dof > 0 && first.phase_chi2 > first.phase_limit)) return std::nullopt;
  const std::vector<double> shift = shaft_angle_shifts(free, s.mass);
  std::vector<dwell> retimed_free;
  for (std::size_t k = 0; k < free.size(); ++k) {
    dwell c = *free[k];
    for (double& t : c.t) t += shift[k];
    retimed_free.push_back(std::move(c));
  }
  std::vector<const dwell*> retimed;
  for (const auto& c : retimed_free) retimed.push_back(&c);
  const linear_fit refit = fit_linear_part(retimed, s.mass, s.derivative, s.linear_route);
  const bool untimed = std::any_of(retimed_free.begin(), retimed_free.end(), [](const dwell& d) { return !std::isfinite(d.timing_sigma); });
  return free_dwells_retimed{
      refit, untimed,
      "linear part: the contact-free dwells' 1X phases disagreed with one unbalance phase (chi^2 " + format_digits(first.phase_chi2) +
          " for " + std::to_string(first.phase_dof) + " dof, 99.9 % limit " + format_digits(first.phase_limit) +
          "), so each dwell's times were shifted to one shaft angle by its own phase (after: chi^2 " + format_digits(refit.phase_chi2) +
          "); c and k then rest on the 1X amplitudes across speeds and each dwell's x-y phase"};
}

// The linear part of Eq. 1: given, or fitted to the contact-free dwells (on one shaft angle).
struct linear_stage {
  linear_part value{};
  std::string source;                   // "given" or "fitted"
  std::optional<linear_fit> fitted;
  std::vector<dwell_noise> free_noise;  // the contact-free dwells' own, in fitted's order
  bool free_retimed_untimed = false;    // they were put on one shaft angle, and some have no keyphasor
  std::vector<std::string> notes;
};

linear_stage linear_part_of(const std::vector<dwell>& dwells, const identify_settings& s) {
  linear_stage out;
  if (s.linear) {
    const parameters& p = *s.linear;
    out.value = {p.m, p.c_x, p.c_y, p.k_x, p.k_y, p.e, p.unbalance_phase};
    out.source = "given";
    return out;
  }
  std::vector<const dwell*> free;
  for (const auto& d : dwells)
    if (!touches(d)) free.push_back(&d);
  for (const auto* d : free) out.free_noise.push_back(estimate_dwell_noise(*d));
  out.fitted = fit_linear_part(free, s.mass, s.derivative, s.linear_route);
  if (auto retimed = put_free_on_one_angle(free, *out.fitted, s)) {
    out.fitted = std::move(retimed->refit);
    out.free_retimed_untimed = retimed->untimed;
    out.notes.push_back(std::move(retimed->note));
  }
  out.value = out.fitted->value;
  out.source = "fitted";
  return out;
}

// The dwells that touch, each with its own noise, and their synchronous averages (dwells with at
// least one whole revolution).
struct touching_dwells {
  std::vector<const dwell*> given;            // identify_law's
  std::vector<std::size_t> index;             // each one's place in identify_law's dwells
  std::vector<std::optional<dwell>> retimed;  // its copy on the linear part's shaft angle (one_x_shift), where it was put there
  std::vector<dwell_noise> noise;             // each one's own
  std::vector<std::optional<averaged_dwell>> averages;
  double probe_noise = 0.0;                   // m, RMS of their noise
  std::string note;                           // on the re-timing, if any

  std::size_t size() const { return given.size(); }
  // The dwell as the steps use it: re-timed, or as given.
  const dwell& at(std::size_t k) const { return retimed[k] ? *retimed[k] : *given[k]; }
  bool any_retimed() const { return std::any_of(retimed.begin(), retimed.end(), [](const auto& d) { return d.has_value(); }); }

  // Noise of a sample: the dwell's own, or an average's, measured by its revolutions' spread
  // around their mean (spread^2 = s^2 (R - 1) / R for R revolutions of noise s, the average's
  // variance is s^2 / R). Measured rather than sigma / sqrt(R): resampling off-grid revolutions by
  // cubic interpolation lowers the noise by up to 20 % (Catmull-Rom half-way between samples
  // weighs them -1/16, 9/16, 9/16, -1/16), and the weak form's z_dot^2 correction needs the true
  // level. Never below the rounding's q / sqrt(12): revolutions that repeat round alike.
  double sample_noise(std::size_t k, bool is_averaged) const {
    const dwell_noise& n = noise[k];
    if (!is_averaged) return n.sigma;
    const auto& a = *averages[k];
    const double white = a.revolutions >= 2 ? a.spread / std::sqrt(static_cast<double>(a.revolutions - 1)) : n.sigma;
    return std::max(white, n.quantisation / std::sqrt(12.0));
  }
};

// Contact-free dwells without a keyphasor were not on one shaft angle, so neither are the
// touching ones without one (tested there, presumed here): each starts on the linear part's by
// its 1X, and the orbit fit searches and refines its forcing phase. (Keyphasor-timed dwells keep
// their angle: the free ones' shifts were small, their mean taken out.)
struct touching_retimed {
  std::vector<std::optional<dwell>> dwells;  // each one's re-timed copy, where it has no keyphasor
  std::string note;                          // empty if none was re-timed
};

touching_retimed put_touching_on_the_free_angle(const std::vector<const dwell*>& touching, const linear_part& lin, bool free_untimed) {
  touching_retimed out{std::vector<std::optional<dwell>>(touching.size()), {}};
  if (!free_untimed) return out;
  double largest = 0.0;
  bool any = false;
  for (std::size_t k = 0; k < touching.size(); ++k) {
    if (std::isfinite(touching[k]->timing_sigma)) continue;
    dwell c = *touching[k];
    const double shift = one_x_shift(c, lin);
    for (double& t : c.t) t += shift;
    largest = std::max(largest, std::abs(std::remainder(shift * c.omega(), 2.0 * std::numbers::pi)));
    out.dwells[k] = std::move(c);
    any = true;
  }
  if (any)
    out.note = "dwells in contact without a keyphasor: presumed off one shaft angle like the contact-free ones (not tested on them), "
               "each re-timed by its 1X against the linear part's (up to " + format_digits(largest) +
               " rad) as a start the orbit fit searches and refines";
  return out;
}

touching_dwells touching_of(const std::vector<dwell>& dwells, const linear_stage& linear) {
  touching_dwells out;
  for (std::size_t i = 0; i < dwells.size(); ++i)
    if (touches(dwells[i])) out.given.push_back(&dwells[i]), out.index.push_back(i);
  if (out.given.empty()) throw input_error("no dwell reaches its clearance: there is no contact to identify");
  touching_retimed retimed = put_touching_on_the_free_angle(out.given, linear.value, linear.free_retimed_untimed);
  out.retimed = std::move(retimed.dwells);
  out.note = std::move(retimed.note);
  double sq = 0.0;
  for (std::size_t k = 0; k < out.size(); ++k) {
    out.noise.push_back(estimate_dwell_noise(out.at(k)));
    sq += out.noise.back().sigma * out.noise.back().sigma;
  }
  out.probe_noise = std::sqrt(sq / static_cast<double>(out.size()));
  out.averages.resize(out.size());
  for (std::size_t k = 0; k < out.size(); ++k) {
    try {
      out.averages[k] = synchronous_average(out.at(k));
    } catch (const input_error&) {
    }
  }
  return out;
}

// Which touching dwells are averaged, and why.
struct averaging_choice {
  std::vector<bool> averaged;
  std::vector<std::string> reason;
};

// Which touching dwells are averaged, and why (identify_settings::average). Automatic: a dwell
// whose whole revolutions repeat within its own noise holds a periodic orbit plus noise, and its
// average keeps the orbit and divides the noise by sqrt(revolutions); one that does not repeat
// (a transient, a subharmonic) would be smeared by it.
averaging_choice decide_averaging(const touching_dwells& touching, averaging mode) {
  const std::size_t n = touching.size();
  averaging_choice out{std::vector<bool>(n, false), std::vector<std::string>(n)};
  for (std::size_t k = 0; k < n; ++k) {
    const auto& a = touching.averages[k];
    std::string& why = out.reason[k];
    if (!a) {
      why = "not averaged: no whole revolution of 8 or more samples";
      continue;
    }
    const std::string revs = std::to_string(a->revolutions) + " whole revolutions";
    const double limit = kSteadySpread * touching.noise[k].sigma + kSteadyFloor;
    const std::string spread = "differ from their mean by " + format_digits(a->spread) + " m RMS, ";
    const std::string noise = " twice the dwell's noise + " + format_digits(kSteadyFloor) + " m (" + format_digits(limit) + " m)";
    switch (mode) {
      case averaging::never: why = "not averaged: averaging off (settings)"; break;
      case averaging::always: out.averaged[k] = true, why = "averaged: averaging on (settings); its " + revs + " " + spread + "limit" + noise; break;
      case averaging::automatic:
        if (a->revolutions < 2) why = "not averaged: one whole revolution, nothing to average";
        else if (a->spread > limit) why = "not averaged: its " + revs + " " + spread + "above" + noise + ": not periodic at 1X";
        else out.averaged[k] = true, why = "averaged: its " + revs + " " + spread + "within" + noise;
        break;
    }
  }
  return out;
}

struct route_choice {
  law_method method;
  std::string reason;
};

// The route: the one asked for; automatic is decided by identify_law (the weak form where its
// rows can rank the library, else the samples).
route_choice choose_route(const identify_settings& s) { return {s.law_route, "chosen (law_method)"}; }

// Every touching dwell's contact forces and the noise of the samples they come from.
struct contact_force_set {
  derivative_settings velocity;      // z_dot's
  std::vector<dwell_forces> dwells;  // in the touching dwells' order
  std::vector<double> noise;         // m, each one's sample noise (touching_dwells::sample_noise)
};

// Every touching dwell's contact forces, from its average where it is averaged.
contact_force_set contact_forces_of(const touching_dwells& touching, const std::vector<bool>& averaged, const linear_part& lin,
                                    const identify_settings& s, bool weak) {
  contact_force_set out;
  out.velocity = s.derivative;  // the weak form takes only z_dot: a wider window
  if (weak) out.velocity.half_width = std::max(out.velocity.half_width, s.weak.velocity_half_width);
  for (std::size_t k = 0; k < touching.size(); ++k) {
    const dwell& d = averaged[k] ? touching.averages[k]->cycle : touching.at(k);
    out.dwells.push_back(contact_forces(d, lin, d.clearance, out.velocity));
    out.noise.push_back(touching.sample_noise(k, averaged[k]));
  }
  return out;
}

// The contact samples, per dwell and pooled, and each dwell's report.
struct pooled_contacts {
  std::vector<dwell_report> reports;                   // identification::dwells, before the shares
  std::vector<std::vector<contact_sample>> per_dwell;  // f_N as measured
  std::vector<contact_sample> pooled;
  std::size_t episodes = 0;
  double fx_fn = 0.0, fn_fn = 0.0;                     // sums of f_x f_N and f_N^2: the pooled friction slope's
};

// Friction per speed (Fig. 5, the samples route's) and the pooled contact samples.
pooled_contacts pool_contacts(const contact_force_set& forces, const touching_dwells& touching, const averaging_choice& averaging, bool weak) {
  pooled_contacts out;
  out.per_dwell.assign(forces.dwells.size(), {});
  for (std::size_t k = 0; k < forces.dwells.size(); ++k) {
    const auto& f = forces.dwells[k];
    dwell_report rep{f.source->rpm, f.source->clearance, touching.noise[k], 0, 0.0, averaging.reason[k], f.source->size(), 0, 0, 0.0, std::nullopt, {}, {}};
    if (touching.averages[k]) rep.average_spread = touching.averages[k]->spread;
    if (averaging.averaged[k]) rep.averaged_revolutions = touching.averages[k]->revolutions;
    if (!weak) {
      const friction_estimate fe = estimate_friction(f);
      if (fe.samples > 0) rep.friction = fe;
    }
    for (std::size_t i = 0; i < f.fn.size(); ++i) {
      if (!f.contact[i]) continue;
      // A new episode starts where contact starts (a periodic cycle may wrap one around its end).
      if (i == 0 || !f.contact[i - 1]) ++out.episodes, ++rep.episodes;
      out.per_dwell[k].push_back({f.z[i], f.vy[i], f.fn[i], out.episodes - 1});
      rep.max_penetration = std::max(rep.max_penetration, f.z[i]);
      out.fx_fn += f.fx[i] * f.fn[i];
      out.fn_fn += f.fn[i] * f.fn[i];
    }
    rep.contact_samples = out.per_dwell[k].size();
    out.pooled.insert(out.pooled.end(), out.per_dwell[k].begin(), out.per_dwell[k].end());
    out.reports.push_back(std::move(rep));
  }
  return out;
}

// The friction coefficient the identification reports (identification::mu and its kin).
struct friction_summary {
  double mu_mean = 0.0, mu_spread = 0.0, mu_slope = 0.0, mu = 0.0;
  double mu_standard_error = kNaN;
};

// The mean and standard deviation of the per-speed means.
friction_summary per_speed(const std::vector<double>& mu_means) {
  friction_summary out;
  for (double m : mu_means) out.mu_mean += m / mu_means.size();
  for (double m : mu_means) out.mu_spread += (m - out.mu_mean) * (m - out.mu_mean);
  out.mu_spread = mu_means.size() > 1 ? std::sqrt(out.mu_spread / (mu_means.size() - 1)) : 0.0;
  return out;
}

// The samples route's friction: the mean of the per-speed means (the paper's Fig. 5), and the
// pooled slope.
friction_summary samples_friction(const pooled_contacts& contacts) {
  std::vector<double> mu_means;
  for (const auto& rep : contacts.reports)
    if (rep.friction) mu_means.push_back(rep.friction->mean);
  friction_summary out = per_speed(mu_means);
  out.mu_slope = contacts.fn_fn > 0.0 ? contacts.fx_fn / contacts.fn_fn : 0.0;
  out.mu = out.mu_mean;
  if (mu_means.size() > 1) out.mu_standard_error = out.mu_spread / std::sqrt(static_cast<double>(mu_means.size()));
  return out;
}

// The regression's rows and targets.
struct regression {
  Eigen::MatrixXd P;
  Eigen::VectorXd y;
  weak_form_system sys;  // the weak form's (its route only)
};

// The regression: contact samples (the paper's) or the weak form's integrals.
regression regression_rows(const contact_force_set& forces, const std::vector<contact_sample>& pooled, const std::vector<candidate_term>& library,
                           const linear_part& lin, const identify_settings& s, bool weak) {
  const Eigen::Index m = static_cast<Eigen::Index>(library.size());
  regression out;
  if (weak) {
    std::vector<weak_form_input> in;
    for (std::size_t k = 0; k < forces.dwells.size(); ++k) in.push_back({&forces.dwells[k], forces.noise[k]});
    out.sys = weak_form(in, lin, library, s.weak);
    if (out.sys.A.rows() <= static_cast<Eigen::Index>(library.size()))
      throw weak_form_rank_error(std::to_string(out.sys.A.rows()) + " rows from " + std::to_string(out.sys.episodes) +
                                 " contact episodes cannot rank " + std::to_string(library.size()) + " candidate terms");
    out.P = out.sys.A;
    out.y = out.sys.b;
  } else {
    out.P.resize(static_cast<Eigen::Index>(pooled.size()), m);
    out.y.resize(static_cast<Eigen::Index>(pooled.size()));
    for (Eigen::Index i = 0; i < out.P.rows(); ++i) {
      for (Eigen::Index j = 0; j < m; ++j) out.P(i, j) = library[j](pooled[i].z, pooled[i].zd);
      out.y[i] = pooled[i].fn;
    }
  }
  return out;
}

// FROLS's terms and what they leave.
struct term_selection {
  frols_stop stop = frols_stop::err_sum;
  frols_result frols;
  std::vector<std::string> candidates, candidates_pretty;
  std::vector<double> first_step_err, paper_order_err;
  contact_law law;  // the kept terms
  double residual_rms = 0.0, force_rms = 0.0;
};

// Each candidate's ERR at the first step, and in the order of the paper's Table 1 (empty unless
// the library is Eq. 4's).
struct candidate_errs {
  std::vector<double> first_step, paper_order;
};

candidate_errs errs_of_candidates(const regression& rows, const std::vector<std::string>& candidates) {
  candidate_errs out;
  for (Eigen::Index j = 0; j < rows.P.cols(); ++j) {
    const double pp = rows.P.col(j).squaredNorm();
    out.first_step.push_back(pp > 0.0 ? std::pow(rows.P.col(j).dot(rows.y), 2) / (pp * rows.y.squaredNorm()) : 0.0);
  }
  // The paper's Table 1 ranks z^3 (0.568) above z (0.392): its values in that order.
  const std::vector<std::string> paper_order{"z3", "z1", "zd2", "z2", "zd1", "zd3", "z4", "zd4"};
  std::vector<std::size_t> order;
  for (const auto& name : paper_order)
    for (std::size_t c = 0; c < candidates.size(); ++c)
      if (candidates[c] == name) order.push_back(c);
  if (order.size() == paper_order.size() && candidates.size() == paper_order.size()) {
    const std::vector<double> err = err_in_order(rows.P, rows.y, order);
    out.paper_order.assign(candidates.size(), 0.0);
    for (std::size_t k = 0; k < order.size(); ++k) out.paper_order[order[k]] = err[k];
  }
  return out;
}

// The terms by FROLS (Eq. 3-4), their ERR at the first step and in the paper's order, and what
// the law leaves of each contact sample's f_N.
term_selection select_terms(const regression& rows, const std::vector<candidate_term>& library, const std::vector<contact_sample>& pooled,
                            const identify_settings& s, bool weak) {
  term_selection out;
  // The weak form's rows carry a known noise: its terms are selected by significance (the
  // paper's rho and 1 % threshold are shares of per-sample variance, not of the integrals').
  frols_settings fs = s.frols;
  if (weak) {
    if (fs.stop == frols_stop::err_sum) fs.stop = frols_stop::significance;
    fs.noise_variance = rows.sys.noise * rows.sys.noise;
  }
  out.stop = fs.stop;
  out.frols = frols(rows.P, rows.y, fs);
  for (const auto& t : library) {
    out.candidates.push_back(t.name());
    out.candidates_pretty.push_back(t.pretty());
  }
  candidate_errs errs = errs_of_candidates(rows, out.candidates);
  out.first_step_err = std::move(errs.first_step);
  out.paper_order_err = std::move(errs.paper_order);
  for (std::size_t j = 0; j < out.frols.kept.size(); ++j) {
    out.law.terms.push_back(library[out.frols.kept[j]]);
    out.law.coef.push_back(out.frols.coefficients[j]);
  }
  // Per contact sample: what the law leaves of the measured f_N (on the weak route that f_N is
  // noise-dominated; the fit's own residual is weak_form_report's).
  double sq = 0.0, fsq = 0.0;
  for (const auto& c : pooled) sq += std::pow(c.fn - out.law(c.z, c.zd), 2), fsq += c.fn * c.fn;
  out.residual_rms = std::sqrt(sq / std::max<std::size_t>(1, pooled.size()));
  out.force_rms = std::sqrt(fsq / std::max<std::size_t>(1, pooled.size()));
  return out;
}

// The weak form's estimates with their intervals, and its report.
struct weak_form_fit {
  std::vector<term_estimate> estimates;
  weak_form_report report;
  std::vector<std::string> warnings;
};

// The weak form's intervals and its report.
weak_form_fit weak_form_estimates(const regression& rows, const term_selection& sel, const std::vector<candidate_term>& library,
                                  const contact_force_set& forces, const linear_part& lin, const identify_settings& s) {
  weak_form_fit out;
  const auto& kept = sel.frols.kept;
  const Eigen::Index n = rows.P.rows();
  // Intervals on the whitened rows: the residual variance, but never below the noise's (few
  // rows can fit the noise by chance), with Student's t for the rows left.
  const Eigen::Index p = static_cast<Eigen::Index>(kept.size());
  const Eigen::Index dof = std::max<Eigen::Index>(1, n - p);
  const double s2 = sel.frols.residual.squaredNorm() / static_cast<double>(dof), noise2 = rows.sys.noise * rows.sys.noise;
  const double var = std::max(s2, noise2);
  const double tq = boost::math::quantile(boost::math::students_t(static_cast<double>(dof)), 0.975);
  Eigen::MatrixXd Ak(n, p);
  for (Eigen::Index j = 0; j < p; ++j) Ak.col(j) = rows.P.col(static_cast<Eigen::Index>(kept[j]));
  const Eigen::MatrixXd cov = p > 0 ? Eigen::MatrixXd(var * (Ak.transpose() * Ak).completeOrthogonalDecomposition().pseudoInverse())
                                    : Eigen::MatrixXd();
  perturbation_spread spread{Eigen::MatrixXd::Zero(p, p), 0.0, 0};
  if (p > 0 && rows.sys.noise > 0.0) {
    std::vector<std::pair<const dwell*, double>> used;
    for (std::size_t k = 0; k < forces.dwells.size(); ++k) used.push_back({forces.dwells[k].source, forces.noise[k]});
    spread = perturbation_covariance(used, lin, sel.law.terms, forces.velocity, s.weak, s2, s.seed);
    // Perturbations that left no usable episode: the data sit at the edge of what the weak
    // form can use, and the intervals below count only the rows' noise.
    if (2 * spread.done < kSpreadRepeats)
      out.warnings.push_back("weak form: only " + std::to_string(spread.done) + " of " + std::to_string(kSpreadRepeats) +
                             " noise perturbations of the data could be fitted; the intervals omit the regressors' noise");
  }
  const auto& coef = sel.law.coef;
  for (std::size_t j = 0; j < kept.size(); ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    // The larger of the rows' covariance and the perturbations' spread (which also holds the
    // regressors' noise).
    const double se = std::sqrt(std::max(cov(jj, jj), spread.cov(jj, jj)));
    out.estimates.push_back({library[kept[j]].name(), library[kept[j]].pretty(), coef[j], se, coef[j] - tq * se, coef[j] + tq * se});
  }
  weak_form_report& wr = out.report;
  wr.rows = static_cast<std::size_t>(n);
  wr.episodes = rows.sys.episodes;
  wr.noise = rows.sys.noise;
  wr.residual_rms = std::sqrt(sel.frols.residual.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, n)));
  // Against what the noise leaves in the residual: the rows' noise, or (larger, when the
  // regressors' noise counts) what one more dose of it adds.
  const double expected = std::max(noise2, spread.residual_variance);
  wr.chi2_per_dof = expected > 0.0 ? s2 / expected : std::numeric_limits<double>::infinity();
  wr.chi2_limit = boost::math::quantile(boost::math::chi_squared(static_cast<double>(dof)), 0.999) / static_cast<double>(dof);
  return out;
}

// The weak form's friction, pooled and per dwell.
struct weak_form_friction_result {
  friction_summary friction;
  std::vector<std::optional<friction_estimate>> per_dwell;  // each touching dwell's, from its rows
};

// Friction: int f_x psi = mu int f_N psi on every row (Eq. 2), both sides from the data. The
// noise in the regressor's sum of squares (rows x noise^2) is taken out, else it biases mu
// towards 0.
weak_form_friction_result weak_form_friction(const weak_form_system& sys, const contact_force_set& forces) {
  weak_form_friction_result out;
  const double noise2 = sys.noise * sys.noise;
  const auto friction = [&](const std::vector<Eigen::Index>& rows, double& se) {
    double bb = 0.0, bxb = 0.0;
    for (const auto r : rows) bb += sys.b[r] * sys.b[r], bxb += sys.bx[r] * sys.b[r];
    double den = bb - static_cast<double>(rows.size()) * noise2;
    if (!(den > 0.5 * bb)) den = bb;  // noise-dominated: no correction (the warnings say so)
    const double mu = den > 0.0 ? bxb / den : kNaN;
    double rr = 0.0;
    for (const auto r : rows) rr += std::pow(sys.bx[r] - mu * sys.b[r], 2);
    const double sx2 = rows.size() > 1 ? rr / static_cast<double>(rows.size() - 1) : kNaN;
    se = std::sqrt(std::max(sx2, noise2 * (1.0 + mu * mu)) / den);
    return mu;
  };
  std::vector<Eigen::Index> all_rows;
  std::vector<std::vector<Eigen::Index>> rows_of(forces.dwells.size());
  for (Eigen::Index r = 0; r < sys.A.rows(); ++r) {
    all_rows.push_back(r);
    rows_of[sys.dwell_of_row[static_cast<std::size_t>(r)]].push_back(r);
  }
  double mu_standard_error = kNaN;
  const double mu_slope = friction(all_rows, mu_standard_error);
  std::vector<double> mu_means;
  out.per_dwell.assign(forces.dwells.size(), std::nullopt);
  for (std::size_t k = 0; k < forces.dwells.size(); ++k) {
    if (rows_of[k].empty()) continue;
    double se = 0.0;
    const double mu = friction(rows_of[k], se);
    out.per_dwell[k] = friction_estimate{forces.dwells[k].source->rpm, rows_of[k].size(), mu, se, mu, mu};
    mu_means.push_back(mu);
  }
  out.friction = per_speed(mu_means);
  out.friction.mu = out.friction.mu_slope = mu_slope;
  out.friction.mu_standard_error = mu_standard_error;
  return out;
}

// The samples route's estimates with their intervals, and its residual tests.
struct samples_result {
  std::vector<term_estimate> estimates;
  std::vector<correlation_test> validity;
};

// The samples route's intervals (an episode bootstrap) and its residual tests (the weak form's
// intervals are weak_form_estimates').
samples_result samples_estimates(const regression& rows, const term_selection& sel, const std::vector<candidate_term>& library,
                                 const pooled_contacts& contacts, const identify_settings& s) {
  const auto& pooled = contacts.pooled;
  const std::size_t episodes = contacts.episodes;
  const Eigen::MatrixXd& P = rows.P;
  const Eigen::VectorXd& y = rows.y;
  const auto& kept = sel.frols.kept;
  const Eigen::Index m = static_cast<Eigen::Index>(library.size());
  const Eigen::Index n = P.rows();
  samples_result out;
  // Episode bootstrap: contact samples within an episode are correlated, whole episodes are not.
  std::vector<std::vector<double>> boot(kept.size());
  if (s.bootstrap > 0 && episodes > 1 && !kept.empty()) {
    std::vector<std::vector<Eigen::Index>> rows_of(episodes);
    for (Eigen::Index i = 0; i < n; ++i) rows_of[pooled[i].episode].push_back(i);
    portable_stream rng(s.seed, kBootstrapStream);  // the same resamples on any toolchain: same intervals everywhere
    for (int b = 0; b < s.bootstrap; ++b) {
      std::vector<Eigen::Index> picked;
      for (std::size_t e = 0; e < episodes; ++e) {
        const auto& r = rows_of[rng.below(episodes)];
        picked.insert(picked.end(), r.begin(), r.end());
      }
      if (picked.size() <= kept.size()) continue;
      Eigen::MatrixXd Pb(picked.size(), m);
      Eigen::VectorXd yb(picked.size());
      for (std::size_t i = 0; i < picked.size(); ++i) {
        Pb.row(i) = P.row(picked[i]);
        yb[i] = y[picked[i]];
      }
      const least_squares_fit fb = least_squares(Pb, yb, kept);
      for (std::size_t j = 0; j < kept.size(); ++j) boot[j].push_back(fb.coefficients[j]);
    }
  }
  for (std::size_t j = 0; j < kept.size(); ++j)
    out.estimates.push_back({library[kept[j]].name(), library[kept[j]].pretty(), sel.frols.coefficients[j], sel.frols.standard_errors[j],
                             percentile(boot[j], 0.025), percentile(boot[j], 0.975)});

  // Residual correlation tests, episode by episode (samples route: the residual is per sample).
  std::vector<std::vector<double>> e(episodes), z(episodes), zd(episodes);
  for (Eigen::Index i = 0; i < n; ++i) {
    e[pooled[i].episode].push_back(sel.frols.residual[i]);
    z[pooled[i].episode].push_back(pooled[i].z);
    zd[pooled[i].episode].push_back(pooled[i].zd);
  }
  out.validity = residual_tests(e, z, zd, s.correlation_lags);
  return out;
}

// Term shares per speed, and whether the law pulls the rotor into the stator.
struct shares_and_pull_result {
  std::vector<std::vector<term_share>> reference, identified;  // per touching dwell
  std::vector<std::string> warnings;
};

// Term shares per speed, and whether the law pulls the rotor into the stator. On the weak route
// the shares compare with the law's own f_N: the measured one is noise there.
shares_and_pull_result shares_and_pull(const pooled_contacts& contacts, const contact_law& law, bool law_force, const parameters& reference) {
  shares_and_pull_result out;
  // Term shares per speed: the reference law (Table 2) and the identified one.
  const std::vector<candidate_term> reference_terms = parse_library("z1,z3,zd2");
  for (std::vector<contact_sample> samples : contacts.per_dwell) {
    if (law_force)
      for (auto& c : samples) c.fn = law(c.z, c.zd);
    out.reference.push_back(shares(reference_terms, {reference.k1, reference.k3, reference.c2}, samples));
    out.identified.push_back(shares(law.terms, law.coef, samples));
  }

  double peak = 0.0, least = 0.0;
  for (const auto& c : contacts.pooled) {
    const double f = law(c.z, c.zd);
    peak = std::max(peak, f), least = std::min(least, f);
  }
  if (!law.terms.empty() && least < -kPullShare * peak)
    out.warnings.push_back("the identified law pulls the rotor into the stator: its f_N falls to " + format_digits(least) +
                           " N over the contact samples (peak " + format_digits(peak) + " N); a contact force cannot pull");
  return out;
}

// Eq. 5's family, the laws the orbit fit can simulate: library name and parameter.
constexpr std::array<std::pair<std::string_view, std::string_view>, 3> kFamily{{{"z1", "k1"}, {"z3", "k3"}, {"zd2", "c2"}}};
double parameters::*law_member(std::string_view term) {
  return term == "z1" ? &parameters::k1 : term == "z3" ? &parameters::k3 : &parameters::c2;
}
std::string family_parameter(std::string_view term) {
  for (const auto& [name, param] : kFamily)
    if (name == term) return std::string(param);
  return {};
}
// The orbit fit's start for a term the weak form puts at <= 0: this share of the peak force, a
// term large enough to matter and small enough not to move the orbit far from the others' law.
constexpr double kRestartShare = 0.1;
// Phases tried per cycle when the shaft angle is not known: 30 degrees apart, well inside the
// basin Levenberg-Marquardt converges from (measured: the orbit fit starting 1.8 rad off fails).
constexpr int kPhaseSearch = 12;

std::string structure_text(const std::vector<std::string>& terms, const std::vector<candidate_term>& library) {
  std::string out = "{";
  for (const auto& t : terms) {
    for (const auto& c : library)
      if (c.name() == t) out += (out.size() > 1 ? ", " : "") + c.pretty();
  }
  return out + "}";
}

// The start of either output-error stage: the identified linear part and the first dwell's
// clearance on the reference law's other parameters.
parameters output_error_start(const identify_settings& s, const linear_part& lin, const contact_force_set& forces) {
  parameters p = s.reference;
  p.m = lin.m;
  p.c_x = lin.c_x;
  p.c_y = lin.c_y;
  p.k_x = lin.k_x;
  p.k_y = lin.k_y;
  p.e = lin.e;
  p.clearance = forces.dwells.front().source->clearance;
  return p;
}

// What the orbit fit refines: the weak form's law, its rows and the data it came from.
struct weak_law {
  const std::vector<candidate_term>& library;
  const linear_part& linear;
  const contact_force_set& forces;
  const std::vector<contact_sample>& pooled;
  const weak_form_system& sys;
  const std::vector<term_estimate>& estimates;
  const contact_law& law;
  double mu, mu_standard_error;
};

// The structures the orbit fit compares: the family's terms present in the library, every subset
// with a stiffness (or, without the comparison, the weak form's selection when it lies in the
// family).
struct structure_family {
  std::vector<std::size_t> column;  // library index of each family term present
  std::vector<std::string> present;
  std::vector<std::vector<std::size_t>> subsets;  // indices into present
};

structure_family structures_to_compare(const weak_law& weak, bool compare_structures) {
  structure_family out;
  for (const auto& [name, param] : kFamily)
    for (std::size_t c = 0; c < weak.library.size(); ++c)
      if (weak.library[c].name() == name) out.column.push_back(c), out.present.push_back(std::string(name));
  const auto& estimates = weak.estimates;
  for (unsigned mask = 1; mask < (1u << out.present.size()); ++mask) {
    std::vector<std::size_t> sub;
    bool stiffness = false, selected = true;
    for (std::size_t b = 0; b < out.present.size(); ++b) {
      const bool in = (mask & (1u << b)) != 0;
      if (in) sub.push_back(b), stiffness = stiffness || out.present[b] != "zd2";
      const bool kept = std::any_of(estimates.begin(), estimates.end(), [&](const term_estimate& e) { return e.name == out.present[b]; });
      selected = selected && in == kept;
    }
    const bool in_family = std::all_of(estimates.begin(), estimates.end(), [](const term_estimate& e) { return !family_parameter(e.name).empty(); });
    if (compare_structures ? stiffness : selected && in_family) out.subsets.push_back(sub);
  }
  return out;
}

// One structure's orbit fit, and the weak form's least squares on its terms it started from.
struct structure_trial {
  structure_candidate report;
  std::vector<term_estimate> start;
  std::optional<orbit_fit_result> fit;
};

// The orbit fit of one structure (`sub` of the family), started from the weak form's least
// squares on its own terms.
structure_trial fit_structure(const weak_law& weak, const std::vector<orbit_fit_cycle>& cycles, const structure_family& family,
                              const std::vector<std::size_t>& sub, double peak_force, const identify_settings& s, int phase_search) {
  structure_trial t;
  std::vector<std::size_t> cols;
  for (const auto b : sub) t.report.terms.push_back(family.present[b]), cols.push_back(family.column[b]);
  const least_squares_fit ls = least_squares(weak.sys.A, weak.sys.b, cols);
  parameters start = output_error_start(s, weak.linear, weak.forces);
  start.unbalance_phase = weak.linear.phase;
  start.mu = std::isfinite(weak.mu) && weak.mu > 0.0 ? weak.mu : 0.0;
  start.k1 = start.k3 = start.c2 = 0.0;
  std::vector<std::string> members;
  std::string restarted;
  for (std::size_t j = 0; j < cols.size(); ++j) {
    const auto& term = weak.library[cols[j]];
    double v = ls.coefficients[static_cast<Eigen::Index>(j)];
    const double se = ls.standard_errors[static_cast<Eigen::Index>(j)];
    if (!(v > 0.0)) {
      // A contact law's terms are > 0: a term the weak form puts at <= 0 starts where it
      // carries kRestartShare of the weak law's peak force over the contact samples.
      double peak_term = 0.0;
      for (const auto& c : weak.pooled) peak_term = std::max(peak_term, std::abs(term(c.z, c.zd)));
      restarted += (restarted.empty() ? "" : ", ") + term.pretty() + " from " + format_digits(v);
      v = peak_term > 0.0 ? kRestartShare * peak_force / peak_term : 0.0;
    }
    t.start.push_back({term.name(), term.pretty(), v, se, kNaN, kNaN});
    members.push_back(family_parameter(term.name()));
    start.*law_member(term.name()) = v;
  }
  if (weak.sys.A.rows() <= static_cast<Eigen::Index>(cols.size()) ||
      std::any_of(t.start.begin(), t.start.end(), [](const term_estimate& e) { return !(e.value > 0.0); })) {
    t.report.status = "not fitted: no positive start from the weak form's rows";
    return t;
  }
  orbit_fit_settings os = s.orbit;
  os.phase_search = std::max(os.phase_search, phase_search);
  const orbit_fit_result fit = fit_periodic_orbits(cycles, start, members, os);
  t.report.fitted = true;
  t.report.converged = fit.converged;
  t.report.chi2_per_dof = fit.final_chi2;
  t.report.status = fit.status + (restarted.empty() ? "" : "; started at " + format_digits(100.0 * kRestartShare) +
                                                            " % of the peak force where the weak form's least squares gave <= 0: " + restarted);
  if (fit.converged && std::isfinite(fit.final_chi2))
    t.report.bic = information_criterion(fit.final_chi2 * static_cast<double>(fit.residuals - fit.unknowns), static_cast<double>(fit.residuals),
                                         fit.unknowns);
  t.fit = fit;
  return t;
}

// Every structure fitted, lowest BIC first (structures without one after, in their order).
std::vector<structure_trial> fit_structures(const weak_law& weak, const std::vector<orbit_fit_cycle>& cycles, const structure_family& family,
                                            const identify_settings& s, int phase_search) {
  // The weak law's peak force over the contact samples.
  double peak_force = 0.0;
  for (const auto& c : weak.pooled) peak_force = std::max(peak_force, std::abs(weak.law(c.z, c.zd)));
  std::vector<structure_trial> trials;
  for (const auto& sub : family.subsets) trials.push_back(fit_structure(weak, cycles, family, sub, peak_force, s, phase_search));
  std::stable_sort(trials.begin(), trials.end(), [](const structure_trial& a, const structure_trial& b) {
    const bool fa = std::isfinite(a.report.bic), fb = std::isfinite(b.report.bic);
    return fa != fb ? fa : fa && a.report.bic < b.report.bic;
  });
  return trials;
}

// The structures' fits, and whether the cycles' phases were searched.
struct structure_fits {
  std::vector<structure_trial> trials;  // lowest BIC first
  bool phases_searched = false;
  std::vector<std::string> notes;
};

// Times not on one shaft angle (the contact-free dwells' test): each cycle's phase searched from
// the start. Otherwise searched only when the cycles' given phases leave no fit within the noise
// (no convergence, or chi^2 above its limit): the dwells in contact may not be on the linear
// part's shaft angle (no keyphasor, t_s not shaft-synchronous), and the search changes only the
// start, so the same model's lower chi^2 decides.
structure_fits fit_structures_on_their_angles(const weak_law& weak, const std::vector<orbit_fit_cycle>& cycles, const structure_family& family,
                                              const identify_settings& s, bool unknown_angle) {
  structure_fits out;
  out.phases_searched = unknown_angle;
  out.trials = fit_structures(weak, cycles, family, s, unknown_angle ? kPhaseSearch : 0);
  const auto within_noise = [](const std::vector<structure_trial>& ts) {
    return std::isfinite(ts.front().report.bic) && ts.front().fit->final_chi2 <= orbit_fit_chi2_limit(*ts.front().fit);
  };
  if (!unknown_angle && !within_noise(out.trials)) {
    std::vector<structure_trial> searched = fit_structures(weak, cycles, family, s, kPhaseSearch);
    const bool better = std::isfinite(searched.front().report.bic) &&
                        (!std::isfinite(out.trials.front().report.bic) || searched.front().report.bic < out.trials.front().report.bic);
    out.notes.push_back(std::string("orbit fit: the cycles' forcing phases from the linear part left no fit within the noise; with each "
                                    "cycle's phase searched (") + std::to_string(kPhaseSearch) + " starts) the fits " +
                        (better ? "improved and are reported (the dwells in contact were not on the linear part's shaft angle)"
                                : "did not improve, and the first are reported"));
    if (better) out.trials = std::move(searched), out.phases_searched = true;
  }
  return out;
}

bool same_terms(std::vector<std::string> a, std::vector<std::string> b) {
  std::sort(a.begin(), a.end()), std::sort(b.begin(), b.end());
  return a == b;
}

// The structure the orbit fits choose, and the verdict on it.
struct structure_choice {
  const structure_trial* best = nullptr;  // none when no structure's fit converged
  verdict decision;
};

// The excess over the noise an orbit fit leaves: chi^2 - dof.
double excess_of(const orbit_fit_result& f) { return f.final_chi2 * static_cast<double>(f.residuals - f.unknowns) - static_cast<double>(f.residuals - f.unknowns); }

// The lowest criterion, by the evidence rules (ref/inference/evidence.hpp) and their verdict: the
// claim "full" where its orbits leave the noise, "partial" where its terms remove claim_share of
// what the simplest structure fitted (the fewest terms: k1 z, the piecewise-linear law) leaves,
// tentative with a rival within min_criterion_rise (a superset of the chosen terms is no rival:
// it trails by ~ln(residuals) minus what its extra term explains, the term is not needed).
// Without a converged fit, the weak form's own selection stands, tentatively.
structure_choice choose_structure(const std::vector<structure_trial>& trials, const std::vector<std::string>& weak_terms,
                                  const std::vector<candidate_term>& library) {
  const evidence_rules rules;
  if (!std::isfinite(trials.front().report.bic)) {
    claim_inputs unfitted;
    unfitted.plausible = false;
    return {nullptr, decide("law terms", weak_terms, unfitted, rules, {},
                            {"no structure's orbit fit converged: the weak form's selection " + structure_text(weak_terms, library) + " and estimates stand"})};
  }
  const structure_trial* best = &trials.front();
  const auto superset = [&](const std::vector<std::string>& terms) {
    return std::all_of(best->report.terms.begin(), best->report.terms.end(),
                       [&](const std::string& t) { return std::find(terms.begin(), terms.end(), t) != terms.end(); });
  };
  const structure_trial* rival = nullptr;
  for (std::size_t k = 1; k < trials.size() && !rival; ++k)
    if (std::isfinite(trials[k].report.bic) && !superset(trials[k].report.terms)) rival = &trials[k];
  const structure_trial* simplest = best;
  for (const auto& t : trials)
    if (std::isfinite(t.report.bic) && t.report.terms.size() < simplest->report.terms.size()) simplest = &t;
  const double gap = rival ? rival->report.bic - best->report.bic : kNaN;
  // The criteria's difference's numerical uncertainty, from each fit's residual sum's own.
  const auto sum_of = [](const orbit_fit_result& f) { return f.final_chi2 * static_cast<double>(f.residuals - f.unknowns); };
  const decision apart = rival ? decisive(best->report.bic, rival->report.bic, rules,
                                          criterion_change_uncertainty(static_cast<double>(best->fit->residuals), sum_of(*best->fit), best->fit->sum_uncertainty,
                                                                       sum_of(*rival->fit), rival->fit->sum_uncertainty))
                               : decision{true, false};
  const bool is_decisive = apart.yes;
  claim_inputs in;
  in.on_margin = apart.on_margin;
  in.residual_is_noise = best->fit->final_chi2 <= orbit_fit_chi2_limit(*best->fit);
  in.explained_share = simplest == best ? (in.residual_is_noise ? 1.0 : 0.0) : explained_share(excess_of(*simplest->fit), excess_of(*best->fit));
  const std::string reason =
      "orbit fit: " + structure_text(best->report.terms, library) + " has the lowest BIC (chi^2/dof " + format_digits(best->report.chi2_per_dof) + ")" +
      (rival ? "; the nearest rival that is not a superset of it, " + structure_text(rival->report.terms, library) + ", is " + format_digits(gap) +
                   " above" + (is_decisive ? "" : " (within " + format_digits(rules.min_criterion_rise) + ": not decisive)")
             : std::string("; no rival that is not a superset of it was fitted"));
  return {best, decide("law terms", best->report.terms, in, rules, is_decisive ? std::string() : structure_text(rival->report.terms, library), {reason})};
}

// The chosen structure's estimates: the orbit fit's values and normal 95 % intervals.
struct refined_law {
  std::vector<term_estimate> estimates;
  contact_law law;
  double mu = 0.0, mu_standard_error = 0.0;
};

refined_law law_of(const structure_trial& best, const std::vector<candidate_term>& library) {
  const orbit_fit_result& fit = *best.fit;
  refined_law out;
  for (std::size_t j = 0; j < best.start.size(); ++j) {
    const auto& p = fit.parameters[j];
    const auto& st = best.start[j];
    out.estimates.push_back({st.name, st.pretty, p.value, p.standard_error, p.value - kInterval95 * p.standard_error,
                             p.value + kInterval95 * p.standard_error});
    for (const auto& c : library)
      if (c.name() == st.name) out.law.terms.push_back(c);
    out.law.coef.push_back(p.value);
  }
  const auto& mu = fit.parameters[best.start.size()];
  out.mu = mu.value;
  out.mu_standard_error = mu.standard_error;
  return out;
}

// What the orbit fit found: the structures it compared, the one it chose and its law.
struct orbit_refinement {
  std::vector<std::string> notes;
  bool phases_searched = false;
  std::vector<structure_candidate> structures;
  std::optional<orbit_fit_result> orbit;
  std::optional<verdict> structure;           // the verdict on the structure chosen (when the orbit fit compared structures)
  std::vector<term_estimate> weak_estimates;  // the chosen structure's start, or the weak form's estimates
  double weak_mu = kNaN, weak_mu_standard_error = kNaN;
  std::optional<refined_law> chosen;  // when a structure's fit converged
};

// The weak form's estimates refined by the averaged cycles' periodic orbits, and the law's
// structure chosen by them: every structure of Eq. 5's family in the library that has a
// stiffness (z or z^3), each started from the weak form's least squares on its own terms, is
// fitted; the lowest information criterion (ref/inference/evidence.hpp, chi^2 against each cycle's
// own noise) is reported, the others as runners-up. The weak form's selection is one candidate among them:
// at micrometre noise its significance test can drop a term the orbits resolve (z_dot^2 at 5 um)
// or take one they do not (z_dot^4).
orbit_refinement refine_by_orbits(const weak_law& weak, const std::vector<bool>& averaged, bool unknown_angle, const identify_settings& s) {
  orbit_refinement out;
  if (!s.orbit_fit || weak.estimates.empty()) return out;
  const auto& forces = weak.forces.dwells;
  std::vector<orbit_fit_cycle> cycles;
  for (std::size_t k = 0; k < forces.size(); ++k)
    if (averaged[k]) cycles.push_back({&forces[k], weak.forces.noise[k]});
  if (cycles.empty()) {
    out.notes.push_back("orbit fit: not run, no dwell is averaged (each dwell's averaging says why); the weak form's estimates stand");
    return out;
  }
  if (cycles.size() < forces.size())
    out.notes.push_back("orbit fit: " + std::to_string(forces.size() - cycles.size()) + " dwell(s) not averaged left out (each dwell's averaging says why)");
  const structure_family family = structures_to_compare(weak, s.compare_structures);
  if (family.subsets.empty()) {
    out.notes.push_back(s.compare_structures ? "orbit fit: not run, the library holds no stiffness of Eq. 5's family (z, z^3), the only laws it simulates"
                                             : "orbit fit: not run, the weak form's selection lies outside Eq. 5's family (z, z^3, z_dot^2), the only laws it simulates");
    return out;
  }
  std::vector<std::string> weak_terms;
  for (const auto& e : weak.estimates) weak_terms.push_back(e.name);

  structure_fits fits = fit_structures_on_their_angles(weak, cycles, family, s, unknown_angle);
  append(out.notes, fits.notes);
  out.phases_searched = fits.phases_searched;
  for (const auto& t : fits.trials) out.structures.push_back(t.report);
  out.weak_estimates = weak.estimates;
  out.weak_mu = weak.mu;
  out.weak_mu_standard_error = weak.mu_standard_error;

  const structure_choice choice = choose_structure(fits.trials, weak_terms, weak.library);
  out.structure = choice.decision;
  if (!choice.best) {
    // The weak form's own selection, when the orbit fit could not choose: its fit, for its warning.
    for (const auto& t : fits.trials)
      if (t.fit && same_terms(t.report.terms, weak_terms)) out.orbit = *t.fit;
    return out;
  }
  out.orbit = *choice.best->fit;
  if (!same_terms(choice.best->report.terms, weak_terms))
    out.notes.push_back("structure: the orbit fit chose " + structure_text(choice.best->report.terms, weak.library) + " over the weak form's selection " +
                        structure_text(weak_terms, weak.library) + " (every structure's BIC: identification.json, structures)");
  out.chosen = law_of(*choice.best, weak.library);
  out.weak_estimates = choice.best->start;
  return out;
}

// The output-error re-identification of Eq. 5's family (reidentify).
reid_result reidentify_law(const identification& id, const contact_force_set& forces, const identify_settings& s) {
  parameters start = output_error_start(s, id.linear, forces);
  start.mu = id.mu;
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
  return reidentify(forces.dwells, start, id.linear.phase, rs);
}


// The law (docs/identification.md): the linear part, the route, the contact forces, the
// regression, FROLS's terms, their intervals by the route's own means, and the orbit fit and the
// re-identification where asked for. Each step is one function above.
identification identify_law_by(const std::vector<dwell>& dwells, const identify_settings& s, bool first_pass = true);

// Where the orbit fit had to search the touching dwells' forcing phases, the weak form ran on
// times it then found wrong, and its law (the orbit fit's start, and the structures' starts) with
// them. The dwells are put on the angles the orbit fit found (as if timed by a keyphasor) and
// everything runs again once, the notes of the first pass kept.
identification again_on_the_orbits_angles(const identification& first, const touching_dwells& touching, const std::vector<bool>& averaged,
                                          const std::vector<dwell>& dwells, const identify_settings& s) {
  std::vector<dwell> timed = dwells;
  const auto& phase = first.orbit->phase;
  std::size_t cycle = 0;
  for (std::size_t k = 0; k < touching.size(); ++k) {
    if (!averaged[k]) continue;
    const dwell& used = touching.at(k);  // as the first pass had it (1X-shifted, perhaps)
    dwell& d = timed[touching.index[k]];
    const double shift = used.t.front() - d.t.front() + std::remainder(phase[cycle++] - first.linear.phase, 2.0 * std::numbers::pi) / d.omega();
    for (double& t : d.t) t += shift;
    d.timing_sigma = 0.0;  // timed by the first pass's orbit fit
  }
  identification id = identify_law_by(timed, s, false);
  std::vector<std::string> notes = first.notes;
  notes.push_back("the dwells in contact were put on the shaft angles the orbit fit found and identified again (the notes below are that pass's)");
  for (const auto& n : id.notes)
    if (std::find(first.notes.begin(), first.notes.end(), n) == first.notes.end()) notes.push_back(n);
  id.notes = std::move(notes);
  return id;
}

// The route's friction, as the identification reports it.
void put_friction(identification& id, const friction_summary& f) {
  id.mu_mean = f.mu_mean, id.mu_spread = f.mu_spread, id.mu_slope = f.mu_slope, id.mu = f.mu, id.mu_standard_error = f.mu_standard_error;
}

identification identify_law_by(const std::vector<dwell>& dwells, const identify_settings& s, bool first_pass) {
  const std::vector<candidate_term> library = parse_library(s.library);
  identification id;
  const linear_stage linear = linear_part_of(dwells, s);
  id.linear = linear.value, id.linear_source = linear.source, id.linear_fitted = linear.fitted, id.free_noise = linear.free_noise;
  append(id.notes, linear.notes);

  const touching_dwells touching = touching_of(dwells, linear);
  if (!touching.note.empty()) id.notes.push_back(touching.note);
  id.probe_noise = touching.probe_noise;
  const averaging_choice averaging = decide_averaging(touching, s.average);
  const route_choice route = choose_route(s);
  id.law_route = route.method, id.law_route_reason = route.reason;
  const bool weak = route.method == law_method::weak_form;

  const contact_force_set forces = contact_forces_of(touching, averaging.averaged, id.linear, s, weak);
  const pooled_contacts contacts = pool_contacts(forces, touching, averaging, weak);
  id.dwells = contacts.reports, id.episodes = contacts.episodes;
  const regression rows = regression_rows(forces, contacts.pooled, library, id.linear, s, weak);
  id.contact_samples = contacts.pooled.size();

  const term_selection selection = select_terms(rows, library, contacts.pooled, s, weak);
  id.stop = selection.stop, id.frols = selection.frols;
  id.candidates = selection.candidates, id.candidates_pretty = selection.candidates_pretty;
  id.first_step_err = selection.first_step_err, id.paper_order_err = selection.paper_order_err;
  id.residual_rms = selection.residual_rms, id.force_rms = selection.force_rms;

  orbit_refinement orbits;
  if (weak) {
    const weak_form_fit fit = weak_form_estimates(rows, selection, library, forces, id.linear, s);
    id.estimates = fit.estimates, id.weak = fit.report;
    append(id.warnings, fit.warnings);
    const weak_form_friction_result friction = weak_form_friction(rows.sys, forces);
    put_friction(id, friction.friction);
    for (std::size_t k = 0; k < friction.per_dwell.size(); ++k)
      if (friction.per_dwell[k]) id.dwells[k].friction = friction.per_dwell[k];
    orbits = refine_by_orbits({library, id.linear, forces, contacts.pooled, rows.sys, id.estimates, selection.law, id.mu, id.mu_standard_error},
                              averaging.averaged, touching.any_retimed(), s);
  } else {
    const samples_result r = samples_estimates(rows, selection, library, contacts, s);
    id.estimates = r.estimates, id.validity = r.validity;
    put_friction(id, samples_friction(contacts));
  }
  append(id.notes, orbits.notes);
  id.phases_searched = orbits.phases_searched, id.structures = orbits.structures, id.orbit = orbits.orbit;
  id.structure = orbits.structure;
  id.weak_estimates = orbits.weak_estimates, id.weak_mu = orbits.weak_mu, id.weak_mu_standard_error = orbits.weak_mu_standard_error;
  if (orbits.chosen) id.estimates = orbits.chosen->estimates, id.mu = orbits.chosen->mu, id.mu_standard_error = orbits.chosen->mu_standard_error;
  if (first_pass && id.phases_searched && id.orbit && id.orbit->converged) return again_on_the_orbits_angles(id, touching, averaging.averaged, dwells, s);

  // The shares and the pull check see the law reported: the orbit fit's where it chose one.
  const shares_and_pull_result shares = shares_and_pull(contacts, orbits.chosen ? orbits.chosen->law : selection.law, weak, s.reference);
  for (std::size_t k = 0; k < id.dwells.size(); ++k)
    id.dwells[k].reference_shares = shares.reference[k], id.dwells[k].identified_shares = shares.identified[k];
  append(id.warnings, shares.warnings);
  if (s.reidentify) id.reid = reidentify_law(id, forces, s);
  return id;
}

// law_method::automatic: the weak form wherever its rows can rank the library. Measured on
// rubref rig records (docs/identification.md §5), it is at least as close as the samples route
// from noise-free records up (the samples route's c2 is +1.7 % off there by its second
// derivatives' truncation, and its mu 7 % off at 61 nm quantisation); the samples route serves
// where the weak form cannot (too few contact episodes), and on request (the paper's Table 1).
identification identify_law(const std::vector<dwell>& dwells, const identify_settings& s) {
  if (dwells.empty()) throw input_error("identify needs at least one dwell");
  if (s.law_route != law_method::automatic) return identify_law_by(dwells, s);
  identify_settings route = s;
  route.law_route = law_method::weak_form;
  try {
    identification id = identify_law_by(dwells, route);
    id.law_route_reason = "automatic: the weak form, whose " + std::to_string(id.weak->rows) + " rows from " +
                          std::to_string(id.weak->episodes) + " contact episodes rank the library";
    return id;
  } catch (const weak_form_rank_error& e) {
    route.law_route = law_method::samples;
    identification id = identify_law_by(dwells, route);
    id.law_route_reason = "automatic: the samples route, as the weak form's " + e.detail;
    return id;
  }
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
        w.push_back(std::string("linear part: ") + name + " = " + format_digits(v) + " is unphysical (damping and stiffness are > 0)");
      else if (v <= kInterval95 * se[i])
        w.push_back(std::string("linear part: ") + name + " = " + format_digits(v) + " ± " + format_digits(se[i]) +
                    " (standard error) is not determined by the contact-free dwells");
    }
    const auto& lf = *id.linear_fitted;
    if (lf.phase_dof > 0 && lf.phase_chi2 > lf.phase_limit)
      w.push_back("linear part: the contact-free dwells' 1X phases disagree with one unbalance phase (chi^2 " + format_digits(lf.phase_chi2) + " for " +
                  std::to_string(lf.phase_dof) + " dof, 99.9 % limit " + format_digits(lf.phase_limit) +
                  "): their times are not on one shaft angle (without a keyphasor t_s must be shaft-synchronous, docs/data-format.md) or the "
                  "forcing is not one unbalance; c, k and e from them are not reliable");
    const auto& beyond = id.linear_fitted->beyond_1x_rms;
    for (std::size_t k = 0; k < beyond.size() && k < id.free_noise.size(); ++k) {
      const double limit = std::max(kBeyond1xNoiseFactor * id.free_noise[k].sigma, kBeyond1xFloor);
      if (beyond[k] > limit)
        w.push_back("linear part: contact-free dwell " + std::to_string(k + 1) + " has " + format_digits(beyond[k]) +
                    " m RMS beyond its 1X response, above 3x its noise (" + format_digits(id.free_noise[k].sigma) +
                    " m): not a steady linear response (a transient, a nonlinearity or a second frequency)");
    }
  }
  for (const auto& e : id.estimates) {
    if (e.name == "z1" && !(e.value > 0.0))
      w.push_back("term " + e.name + ": k1 = " + format_digits(e.value) + " N/m is unphysical (a contact stiffness is > 0)");
    const bool bootstrap_across_zero = std::isfinite(e.ci_low) && std::isfinite(e.ci_high) && e.ci_low <= 0.0 && e.ci_high >= 0.0;
    if (bootstrap_across_zero || std::abs(e.value) <= kInterval95 * e.standard_error)
      w.push_back("term " + e.name + " = " + format_digits(e.value) + ": its 95 % interval contains 0 (standard error " +
                  format_digits(e.standard_error) + (std::isfinite(e.ci_low) ? ", bootstrap [" + format_digits(e.ci_low) + ", " +
                  format_digits(e.ci_high) + "]" : std::string()) + "): the data do not determine it");
  }
  if (!id.structures.empty() && !id.orbit && id.structure)
    w.push_back(id.structure->reasons.front() + " (statuses in identification.json, structure)");
  if (id.orbit && !id.orbit->converged)
    w.push_back("orbit fit: " + id.orbit->status + " (" + std::to_string(id.orbit->failed_evaluations) +
                " failed orbit evaluations); the weak form's estimates are reported");
  if (id.orbit && id.orbit->converged)
    for (const auto& p : id.orbit->parameters)
      if ((p.name == "mu" || p.name == "c_x" || p.name == "c_y" || p.name == "k_x" || p.name == "k_y") && !(p.value >= 0.0))  // the law's terms: above
        w.push_back("orbit fit: " + p.name + " = " + format_digits(p.value) + " is unphysical (friction, damping and stiffness are >= 0)");
  if (id.orbit && id.orbit->converged && id.orbit->final_chi2 > orbit_fit_chi2_limit(*id.orbit))
    w.push_back("orbit fit: the averaged cycles leave " + format_digits(id.orbit->final_chi2) + "x the residual the probe noise leaves (limit " +
                format_digits(orbit_fit_chi2_limit(*id.orbit)) + "; RMS " + format_digits(id.orbit->final_rms) +
                " m): the model misses something (a term, an effect outside Eq. 1, a wrong linear part); intervals widened by its square root");
  if (id.weak && id.weak->chi2_per_dof > id.weak->chi2_limit && 1.0 - id.frols.err_sum_kept > kWeakUnexplained) {
    const std::string excess = "weak form: the residual variance is " + format_digits(id.weak->chi2_per_dof) + "x what the probe noise leaves (limit " +
                               format_digits(id.weak->chi2_limit) + " under noise alone), " + format_digits(100.0 * (1.0 - id.frols.err_sum_kept)) +
                               " % of the integrals' variance";
    // The orbit fit is the stronger test of the law (it reads no derivative of the data and sees
    // the whole revolution): where it leaves only noise, the weak form's excess is the weak
    // form's own (its rows' approximations at this noise, or a shaft angle the orbit fit found),
    // not the law's, and is a note.
    const bool orbits_fit = id.orbit && id.orbit->converged && id.orbit->final_chi2 <= orbit_fit_chi2_limit(*id.orbit);
    if (orbits_fit)
      id.notes.push_back(excess + "; the orbit fit leaves only noise (chi^2/dof " + format_digits(id.orbit->final_chi2) + ", limit " +
                         format_digits(orbit_fit_chi2_limit(*id.orbit)) + "), so the reported law is not what the weak form misses" +
                         (id.phases_searched ? " (its rows hold the unbalance at the linear part's shaft angle, which the dwells in contact are not on)" : ""));
    else
      w.push_back(excess + ": " +
                  (id.phases_searched ? std::string("its rows hold the unbalance at the linear part's shaft angle, which the orbit fit found the dwells "
                                                    "in contact are not on (notes)")
                                      : std::string("the law leaves what noise cannot explain (a missing term, an effect outside Eq. 1, or a wrong linear part)")));
  }
  if (!(id.mu >= 0.0 && id.mu <= 1.0))
    w.push_back("friction: mu = " + format_digits(id.mu) + " is outside [0, 1]: implausible for a rub");
  else if (id.dwells.size() > 1 && id.mu_spread > id.mu_mean)
    w.push_back("friction: the per-speed means of mu scatter by " + format_digits(id.mu_spread) + " around " + format_digits(id.mu_mean) +
                ": not determined by the data");
  std::string failed;
  for (const auto& t : id.validity)
    if (!t.pass) failed += (failed.empty() ? "" : ", ") + t.name;
  // Residual structure matters only where the residual does: when the kept terms leave more than
  // rho of the force's variance unexplained (FROLS's own stopping share). On clean records the
  // residual is the derivatives' truncation error, correlated but ~1e-6 of the force.
  const double unexplained = id.force_rms > 0.0 ? std::pow(id.residual_rms / id.force_rms, 2) : 0.0;
  if (!failed.empty() && unexplained > s.frols.rho)
    w.push_back("residual tests failed (" + failed + ") with " + format_digits(100.0 * unexplained) +
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
        w.push_back("re-identification: " + p.name + " = " + format_digits(p.value) + " is at its bound (0 or 10x its start " +
                    format_digits(p.initial) + ")");
    }
  }
}
}  // namespace

void identify_settings::validate() const {
  check({"identify", "mass"}, mass);
  check({"identify", "clearance"}, clearance);
  derivative.validate();
  weak.validate();
  frols.validate();
  orbit.validate();
  check({"identify", "bootstrap"}, bootstrap);
  check({"identify", "seed"}, seed);
  check({"identify", "correlation_lags"}, correlation_lags);
  if (reidentify) reid.validate();
}

}  // namespace rubref
