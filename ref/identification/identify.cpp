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

// What identify_law's steps (below, in order) share: the dwells that touch, their synchronous
// averages, the route, the contact forces, the pooled contact samples, the regression and the
// terms kept.
struct law_context {
  law_context(identification& result, const identify_settings& settings) : id(result), s(settings), library(parse_library(settings.library)) {}

  identification& id;
  const identify_settings& s;
  std::vector<candidate_term> library;
  std::vector<const dwell*> touching;
  std::vector<std::size_t> touching_index;  // each one's place in identify_law's dwells
  std::vector<dwell> retimed_free;  // contact-free dwells put on one shaft angle (shaft_angle_shifts)
  std::vector<dwell> retimed_touching;  // the dwells in contact likewise (one_x_shift), when the free ones were
  std::vector<dwell_noise> noise;  // each touching dwell's own
  std::vector<std::optional<averaged_dwell>> averages;
  std::vector<bool> averaged;
  std::vector<std::string> averaging_reason;
  bool weak = false;   // the weak form's route
  derivative_settings velocity;
  std::vector<dwell_forces> forces;
  std::vector<contact_sample> pooled;
  std::vector<std::vector<contact_sample>> per_dwell;
  double fxfn = 0.0, fnfn = 0.0;
  std::vector<double> mu_means;
  Eigen::MatrixXd P;
  Eigen::VectorXd y;
  weak_form_system sys;
  std::vector<candidate_term> kept_terms;
  std::vector<double> kept_coef;

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
  // The identified law's f_N.
  double law(double z, double zd) const {
    double f = 0.0;
    for (std::size_t j = 0; j < kept_terms.size(); ++j) f += kept_coef[j] * kept_terms[j](z, zd);
    return f;
  }
  // The start of either output-error stage: the identified linear part and the first dwell's
  // clearance on the reference law's other parameters.
  parameters output_error_start() const {
    parameters p = s.reference;
    p.m = id.linear.m;
    p.c_x = id.linear.c_x;
    p.c_y = id.linear.c_y;
    p.k_x = id.linear.k_x;
    p.k_y = id.linear.k_y;
    p.e = id.linear.e;
    p.clearance = forces.front().source->clearance;
    return p;
  }
};

bool touches(const dwell& d) {
  return std::any_of(d.y.begin(), d.y.end(), [&](double y) { return y > d.clearance; });
}

// Contact-free dwells whose 1X phases reject one shaft angle (linear_fit::phase_chi2) put on one
// (shaft_angle_shifts), and the linear part fitted again on them.
void put_free_on_one_angle(law_context& ctx, const std::vector<const dwell*>& free) {
  identification& id = ctx.id;
  const identify_settings& s = ctx.s;
  const linear_fit first = *id.linear_fitted;  // a copy: refitted below
  if (!(first.phase_dof > 0 && first.phase_chi2 > first.phase_limit)) return;
  const std::vector<double> shift = shaft_angle_shifts(free, s.mass);
  for (std::size_t k = 0; k < free.size(); ++k) {
    dwell c = *free[k];
    for (double& t : c.t) t += shift[k];
    ctx.retimed_free.push_back(std::move(c));
  }
  std::vector<const dwell*> retimed;
  for (const auto& c : ctx.retimed_free) retimed.push_back(&c);
  id.linear_fitted = fit_linear_part(retimed, s.mass, s.derivative, s.linear_route);
  id.notes.push_back("linear part: the contact-free dwells' 1X phases disagreed with one unbalance phase (chi^2 " + format_digits(first.phase_chi2) +
                     " for " + std::to_string(first.phase_dof) + " dof, 99.9 % limit " + format_digits(first.phase_limit) +
                     "), so each dwell's times were shifted to one shaft angle by its own phase (after: chi^2 " +
                     format_digits(id.linear_fitted->phase_chi2) + "); c and k then rest on the 1X amplitudes across speeds and each dwell's x-y phase");
}

// Contact-free dwells without a keyphasor were not on one shaft angle, so neither are the
// touching ones without one (tested there, presumed here): each starts on the linear part's by
// its 1X, and the orbit fit searches and refines its forcing phase. (Keyphasor-timed dwells keep
// their angle: the free ones' shifts were small, their mean taken out.)
void put_touching_on_the_free_angle(law_context& ctx) {
  const bool free_untimed = std::any_of(ctx.retimed_free.begin(), ctx.retimed_free.end(), [](const dwell& d) { return !std::isfinite(d.timing_sigma); });
  if (!free_untimed) return;
  double largest = 0.0;
  ctx.retimed_touching.reserve(ctx.touching.size());  // no reallocation: touching points into it
  for (auto*& d : ctx.touching) {
    if (std::isfinite(d->timing_sigma)) continue;
    dwell c = *d;
    const double shift = one_x_shift(c, ctx.id.linear);
    for (double& t : c.t) t += shift;
    largest = std::max(largest, std::abs(std::remainder(shift * c.omega(), 2.0 * std::numbers::pi)));
    ctx.retimed_touching.push_back(std::move(c));
    d = &ctx.retimed_touching.back();
  }
  if (!ctx.retimed_touching.empty())
    ctx.id.notes.push_back("dwells in contact without a keyphasor: presumed off one shaft angle like the contact-free ones (not tested on them), "
                           "each re-timed by its 1X against the linear part's (up to " + format_digits(largest) +
                           " rad) as a start the orbit fit searches and refines");
}

// The linear part (given, or fitted to the contact-free dwells, on one shaft angle); the dwells
// that touch, each with its own noise, and their synchronous averages (dwells with at least one
// whole revolution).
void linear_part_and_touching(law_context& ctx, const std::vector<dwell>& dwells) {
  identification& id = ctx.id;
  const identify_settings& s = ctx.s;
  if (s.linear) {
    const parameters& p = *s.linear;
    id.linear = {p.m, p.c_x, p.c_y, p.k_x, p.k_y, p.e, p.unbalance_phase};
    id.linear_source = "given";
  } else {
    std::vector<const dwell*> free;
    for (const auto& d : dwells)
      if (!touches(d)) free.push_back(&d);
    for (const auto* d : free) id.free_noise.push_back(estimate_dwell_noise(*d));
    id.linear_fitted = fit_linear_part(free, s.mass, s.derivative, s.linear_route);
    put_free_on_one_angle(ctx, free);
    id.linear = id.linear_fitted->value;
    id.linear_source = "fitted";
  }
  for (std::size_t i = 0; i < dwells.size(); ++i)
    if (touches(dwells[i])) ctx.touching.push_back(&dwells[i]), ctx.touching_index.push_back(i);
  if (ctx.touching.empty()) throw input_error("no dwell reaches its clearance: there is no contact to identify");
  put_touching_on_the_free_angle(ctx);
  double sq = 0.0;
  for (const auto* d : ctx.touching) {
    ctx.noise.push_back(estimate_dwell_noise(*d));
    sq += ctx.noise.back().sigma * ctx.noise.back().sigma;
  }
  id.probe_noise = std::sqrt(sq / static_cast<double>(ctx.touching.size()));
  ctx.averages.resize(ctx.touching.size());
  for (std::size_t k = 0; k < ctx.touching.size(); ++k) {
    try {
      ctx.averages[k] = synchronous_average(*ctx.touching[k]);
    } catch (const input_error&) {
    }
  }
}

// Which touching dwells are averaged, and why (identify_settings::average). Automatic: a dwell
// whose whole revolutions repeat within its own noise holds a periodic orbit plus noise, and its
// average keeps the orbit and divides the noise by sqrt(revolutions); one that does not repeat
// (a transient, a subharmonic) would be smeared by it.
void decide_averaging(law_context& ctx) {
  const std::size_t n = ctx.touching.size();
  ctx.averaged.assign(n, false);
  ctx.averaging_reason.assign(n, {});
  for (std::size_t k = 0; k < n; ++k) {
    const auto& a = ctx.averages[k];
    std::string& why = ctx.averaging_reason[k];
    if (!a) {
      why = "not averaged: no whole revolution of 8 or more samples";
      continue;
    }
    const std::string revs = std::to_string(a->revolutions) + " whole revolutions";
    const double limit = kSteadySpread * ctx.noise[k].sigma + kSteadyFloor;
    const std::string spread = "differ from their mean by " + format_digits(a->spread) + " m RMS, ";
    const std::string noise = " twice the dwell's noise + " + format_digits(kSteadyFloor) + " m (" + format_digits(limit) + " m)";
    switch (ctx.s.average) {
      case averaging::never: why = "not averaged: averaging off (settings)"; break;
      case averaging::always: ctx.averaged[k] = true, why = "averaged: averaging on (settings); its " + revs + " " + spread + "limit" + noise; break;
      case averaging::automatic:
        if (a->revolutions < 2) why = "not averaged: one whole revolution, nothing to average";
        else if (a->spread > limit) why = "not averaged: its " + revs + " " + spread + "above" + noise + ": not periodic at 1X";
        else ctx.averaged[k] = true, why = "averaged: its " + revs + " " + spread + "within" + noise;
        break;
    }
  }
}

// The route: the one asked for; automatic is decided by identify_law (the weak form where its
// rows can rank the library, else the samples).
void choose_route(law_context& ctx) {
  ctx.id.law_route = ctx.s.law_route;
  ctx.id.law_route_reason = "chosen (law_method)";
  ctx.weak = ctx.id.law_route == law_method::weak_form;
}

// Every touching dwell's contact forces, from its average where it is averaged.
void contact_forces_of(law_context& ctx) {
  const identify_settings& s = ctx.s;
  ctx.velocity = s.derivative;  // the weak form takes only z_dot: a wider window
  if (ctx.weak) ctx.velocity.half_width = std::max(ctx.velocity.half_width, s.weak.velocity_half_width);
  for (std::size_t k = 0; k < ctx.touching.size(); ++k) {
    const dwell& d = ctx.averaged[k] ? ctx.averages[k]->cycle : *ctx.touching[k];
    ctx.forces.push_back(contact_forces(d, ctx.id.linear, d.clearance, ctx.velocity));
  }
}

// Friction per speed (Fig. 5) and the pooled contact samples.
void pool_contacts(law_context& ctx) {
  identification& id = ctx.id;
  ctx.per_dwell.assign(ctx.forces.size(), {});
  for (std::size_t k = 0; k < ctx.forces.size(); ++k) {
    const auto& f = ctx.forces[k];
    dwell_report rep{f.source->rpm, f.source->clearance, ctx.noise[k], 0, 0.0, ctx.averaging_reason[k], f.source->size(), 0, 0, 0.0, std::nullopt, {}, {}};
    if (ctx.averages[k]) rep.average_spread = ctx.averages[k]->spread;
    if (ctx.averaged[k]) rep.averaged_revolutions = ctx.averages[k]->revolutions;
    if (!ctx.weak) {
      const friction_estimate fe = estimate_friction(f);
      if (fe.samples > 0) {
        rep.friction = fe;
        ctx.mu_means.push_back(fe.mean);
      }
    }
    for (std::size_t i = 0; i < f.fn.size(); ++i) {
      if (!f.contact[i]) continue;
      // A new episode starts where contact starts (a periodic cycle may wrap one around its end).
      if (i == 0 || !f.contact[i - 1]) ++id.episodes, ++rep.episodes;
      ctx.per_dwell[k].push_back({f.z[i], f.vy[i], f.fn[i], id.episodes - 1});
      rep.max_penetration = std::max(rep.max_penetration, f.z[i]);
      ctx.fxfn += f.fx[i] * f.fn[i];
      ctx.fnfn += f.fn[i] * f.fn[i];
    }
    rep.contact_samples = ctx.per_dwell[k].size();
    ctx.pooled.insert(ctx.pooled.end(), ctx.per_dwell[k].begin(), ctx.per_dwell[k].end());
    id.dwells.push_back(std::move(rep));
  }
  if (!ctx.weak) {
    const auto& mu_means = ctx.mu_means;
    for (double m : mu_means) id.mu_mean += m / mu_means.size();
    for (double m : mu_means) id.mu_spread += (m - id.mu_mean) * (m - id.mu_mean);
    id.mu_spread = mu_means.size() > 1 ? std::sqrt(id.mu_spread / (mu_means.size() - 1)) : 0.0;
    id.mu_slope = ctx.fnfn > 0.0 ? ctx.fxfn / ctx.fnfn : 0.0;
    id.mu = id.mu_mean;
    if (mu_means.size() > 1) id.mu_standard_error = id.mu_spread / std::sqrt(static_cast<double>(mu_means.size()));
  }
}


// The regression: contact samples (the paper's) or the weak form's integrals.
void regression_rows(law_context& ctx) {
  identification& id = ctx.id;
  const identify_settings& s = ctx.s;
  const auto& library = ctx.library;
  const bool weak = ctx.weak;
  const auto& averaged = ctx.averaged;
  const auto& forces = ctx.forces;
  auto& pooled = ctx.pooled;
  const Eigen::Index m = static_cast<Eigen::Index>(library.size());
  Eigen::MatrixXd& P = ctx.P;
  Eigen::VectorXd& y = ctx.y;
  weak_form_system& sys = ctx.sys;
  if (weak) {
    std::vector<weak_form_input> in;
    for (std::size_t k = 0; k < forces.size(); ++k) in.push_back({&forces[k], ctx.sample_noise(k, averaged[k])});
    sys = weak_form(in, id.linear, library, s.weak);
    if (sys.A.rows() <= static_cast<Eigen::Index>(library.size()))
      throw weak_form_rank_error(std::to_string(sys.A.rows()) + " rows from " + std::to_string(sys.episodes) +
                                 " contact episodes cannot rank " + std::to_string(library.size()) + " candidate terms");
    P = sys.A;
    y = sys.b;
  } else {
    P.resize(static_cast<Eigen::Index>(pooled.size()), m);
    y.resize(static_cast<Eigen::Index>(pooled.size()));
    for (Eigen::Index i = 0; i < P.rows(); ++i) {
      for (Eigen::Index j = 0; j < m; ++j) P(i, j) = library[j](pooled[i].z, pooled[i].zd);
      y[i] = pooled[i].fn;
    }
  }
  id.contact_samples = pooled.size();
}

// The terms by FROLS (Eq. 3-4), their ERR at the first step and in the paper's order, and what
// the law leaves of each contact sample's f_N.
void select_terms(law_context& ctx) {
  identification& id = ctx.id;
  const identify_settings& s = ctx.s;
  const auto& library = ctx.library;
  const bool weak = ctx.weak;
  auto& pooled = ctx.pooled;
  const Eigen::MatrixXd& P = ctx.P;
  const Eigen::VectorXd& y = ctx.y;
  const weak_form_system& sys = ctx.sys;
  const Eigen::Index m = static_cast<Eigen::Index>(library.size());
  // The weak form's rows carry a known noise: its terms are selected by significance (the
  // paper's rho and 1 % threshold are shares of per-sample variance, not of the integrals').
  frols_settings fs = s.frols;
  if (weak) {
    if (fs.stop == frols_stop::err_sum) fs.stop = frols_stop::significance;
    fs.noise_variance = sys.noise * sys.noise;
  }
  id.stop = fs.stop;
  id.frols = frols(P, y, fs);
  for (const auto& t : library) {
    id.candidates.push_back(t.name());
    id.candidates_pretty.push_back(t.pretty());
  }
  for (Eigen::Index j = 0; j < m; ++j) {
    const double pp = P.col(j).squaredNorm();
    id.first_step_err.push_back(pp > 0.0 ? std::pow(P.col(j).dot(y), 2) / (pp * y.squaredNorm()) : 0.0);
  }
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
  const auto& kept = id.frols.kept;
  auto& kept_terms = ctx.kept_terms;
  auto& kept_coef = ctx.kept_coef;
  for (std::size_t j = 0; j < kept.size(); ++j) {
    kept_terms.push_back(library[kept[j]]);
    kept_coef.push_back(id.frols.coefficients[j]);
  }
  {
    // Per contact sample: what the law leaves of the measured f_N (on the weak route that f_N is
    // noise-dominated; the fit's own residual is weak_form_report's).
    double sq = 0.0, fsq = 0.0;
    for (const auto& c : pooled) sq += std::pow(c.fn - ctx.law(c.z, c.zd), 2), fsq += c.fn * c.fn;
    id.residual_rms = std::sqrt(sq / std::max<std::size_t>(1, pooled.size()));
    id.force_rms = std::sqrt(fsq / std::max<std::size_t>(1, pooled.size()));
  }

}

// The weak form's intervals, its report and its friction (Eq. 2 on every row).
void weak_form_estimates(law_context& ctx) {
  identification& id = ctx.id;
  const identify_settings& s = ctx.s;
  const auto& library = ctx.library;
  const auto& averaged = ctx.averaged;
  const auto& velocity = ctx.velocity;
  const auto& forces = ctx.forces;
  auto& pooled = ctx.pooled;
  auto& per_dwell = ctx.per_dwell;
  auto& mu_means = ctx.mu_means;
  const Eigen::MatrixXd& P = ctx.P;
  const weak_form_system& sys = ctx.sys;
  const auto& kept_terms = ctx.kept_terms;
  const auto& kept_coef = ctx.kept_coef;
  const auto& kept = id.frols.kept;
  const Eigen::Index n = P.rows();
  // Intervals on the whitened rows: the residual variance, but never below the noise's (few
  // rows can fit the noise by chance), with Student's t for the rows left.
  const Eigen::Index p = static_cast<Eigen::Index>(kept.size());
  const Eigen::Index dof = std::max<Eigen::Index>(1, n - p);
  const double s2 = id.frols.residual.squaredNorm() / static_cast<double>(dof), noise2 = sys.noise * sys.noise;
  const double var = std::max(s2, noise2);
  const double tq = boost::math::quantile(boost::math::students_t(static_cast<double>(dof)), 0.975);
  Eigen::MatrixXd Ak(n, p);
  for (Eigen::Index j = 0; j < p; ++j) Ak.col(j) = P.col(static_cast<Eigen::Index>(kept[j]));
  const Eigen::MatrixXd cov = p > 0 ? Eigen::MatrixXd(var * (Ak.transpose() * Ak).completeOrthogonalDecomposition().pseudoInverse())
                                    : Eigen::MatrixXd();
  perturbation_spread spread{Eigen::MatrixXd::Zero(p, p), 0.0, 0};
  if (p > 0 && sys.noise > 0.0) {
    std::vector<std::pair<const dwell*, double>> used;
    for (std::size_t k = 0; k < forces.size(); ++k) used.push_back({forces[k].source, ctx.sample_noise(k, averaged[k])});
    spread = perturbation_covariance(used, id.linear, kept_terms, velocity, s.weak, s2, s.seed);
    // Perturbations that left no usable episode: the data sit at the edge of what the weak
    // form can use, and the intervals below count only the rows' noise.
    if (2 * spread.done < kSpreadRepeats)
      id.warnings.push_back("weak form: only " + std::to_string(spread.done) + " of " + std::to_string(kSpreadRepeats) +
                            " noise perturbations of the data could be fitted; the intervals omit the regressors' noise");
  }
  for (std::size_t j = 0; j < kept.size(); ++j) {
    const auto jj = static_cast<Eigen::Index>(j);
    // The larger of the rows' covariance and the perturbations' spread (which also holds the
    // regressors' noise).
    const double se = std::sqrt(std::max(cov(jj, jj), spread.cov(jj, jj)));
    id.estimates.push_back({library[kept[j]].name(), library[kept[j]].pretty(), kept_coef[j], se, kept_coef[j] - tq * se,
                            kept_coef[j] + tq * se});
  }
  weak_form_report wr;
  wr.rows = static_cast<std::size_t>(n);
  wr.episodes = sys.episodes;
  wr.noise = sys.noise;
  wr.residual_rms = std::sqrt(id.frols.residual.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, n)));
  // Against what the noise leaves in the residual: the rows' noise, or (larger, when the
  // regressors' noise counts) what one more dose of it adds.
  const double expected = std::max(noise2, spread.residual_variance);
  wr.chi2_per_dof = expected > 0.0 ? s2 / expected : std::numeric_limits<double>::infinity();
  wr.chi2_limit = boost::math::quantile(boost::math::chi_squared(static_cast<double>(dof)), 0.999) / static_cast<double>(dof);
  id.weak = wr;

  // Friction: int f_x psi = mu int f_N psi on every row (Eq. 2), both sides from the data. The
  // noise in the regressor's sum of squares (rows x noise^2) is taken out, else it biases mu
  // towards 0.
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
  std::vector<std::vector<Eigen::Index>> rows_of(forces.size());
  for (Eigen::Index r = 0; r < n; ++r) {
    all_rows.push_back(r);
    rows_of[sys.dwell_of_row[static_cast<std::size_t>(r)]].push_back(r);
  }
  id.mu = id.mu_slope = friction(all_rows, id.mu_standard_error);
  for (std::size_t k = 0; k < forces.size(); ++k) {
    if (rows_of[k].empty()) continue;
    double se = 0.0;
    const double mu = friction(rows_of[k], se);
    id.dwells[k].friction = friction_estimate{forces[k].source->rpm, rows_of[k].size(), mu, se, mu, mu};
    mu_means.push_back(mu);
  }
  for (double v : mu_means) id.mu_mean += v / mu_means.size();
  for (double v : mu_means) id.mu_spread += (v - id.mu_mean) * (v - id.mu_mean);
  id.mu_spread = mu_means.size() > 1 ? std::sqrt(id.mu_spread / (mu_means.size() - 1)) : 0.0;
  // The shares below compare with the law's own f_N: the measured one is noise here.
  for (auto* v : {&pooled})
    for (auto& c : *v) c.fn = ctx.law(c.z, c.zd);
  for (auto& d : per_dwell)
    for (auto& c : d) c.fn = ctx.law(c.z, c.zd);
}

// The samples route's intervals (an episode bootstrap) and its residual tests (the weak form's
// intervals are weak_form_estimates').
void samples_estimates(law_context& ctx) {
  identification& id = ctx.id;
  const identify_settings& s = ctx.s;
  const auto& library = ctx.library;
  auto& pooled = ctx.pooled;
  const Eigen::MatrixXd& P = ctx.P;
  const Eigen::VectorXd& y = ctx.y;
  const auto& kept = id.frols.kept;
  const Eigen::Index m = static_cast<Eigen::Index>(library.size());
  const Eigen::Index n = P.rows();
  // Episode bootstrap: contact samples within an episode are correlated, whole episodes are not.
  std::vector<std::vector<double>> boot(kept.size());
  if (s.bootstrap > 0 && id.episodes > 1 && !kept.empty()) {
    std::vector<std::vector<Eigen::Index>> rows_of(id.episodes);
    for (Eigen::Index i = 0; i < n; ++i) rows_of[pooled[i].episode].push_back(i);
    portable_stream rng(s.seed, kBootstrapStream);  // the same resamples on any toolchain: same intervals everywhere
    for (int b = 0; b < s.bootstrap; ++b) {
      std::vector<Eigen::Index> rows;
      for (std::size_t e = 0; e < id.episodes; ++e) {
        const auto& r = rows_of[rng.below(id.episodes)];
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
    id.estimates.push_back({library[kept[j]].name(), library[kept[j]].pretty(), id.frols.coefficients[j], id.frols.standard_errors[j],
                            percentile(boot[j], 0.025), percentile(boot[j], 0.975)});

  // Residual correlation tests, episode by episode (samples route: the residual is per sample).
  std::vector<std::vector<double>> e(id.episodes), z(id.episodes), zd(id.episodes);
  for (Eigen::Index i = 0; i < n; ++i) {
    e[pooled[i].episode].push_back(id.frols.residual[i]);
    z[pooled[i].episode].push_back(pooled[i].z);
    zd[pooled[i].episode].push_back(pooled[i].zd);
  }
  id.validity = residual_tests(e, z, zd, s.correlation_lags);
}

// Term shares per speed, and whether the law pulls the rotor into the stator.
void shares_and_pull(law_context& ctx) {
  identification& id = ctx.id;
  const identify_settings& s = ctx.s;
  const auto& forces = ctx.forces;
  auto& pooled = ctx.pooled;
  auto& per_dwell = ctx.per_dwell;
  const auto& kept_terms = ctx.kept_terms;
  const auto& kept_coef = ctx.kept_coef;
  // Term shares per speed: the reference law (Table 2) and the identified one.
  const std::vector<candidate_term> reference_terms = parse_library("z1,z3,zd2");
  for (std::size_t k = 0; k < forces.size(); ++k) {
    id.dwells[k].reference_shares = shares(reference_terms, {s.reference.k1, s.reference.k3, s.reference.c2}, per_dwell[k]);
    id.dwells[k].identified_shares = shares(kept_terms, kept_coef, per_dwell[k]);
  }

  {
    double peak = 0.0, least = 0.0;
    for (const auto& c : pooled) {
      const double f = ctx.law(c.z, c.zd);
      peak = std::max(peak, f), least = std::min(least, f);
    }
    if (!kept_terms.empty() && least < -kPullShare * peak)
      id.warnings.push_back("the identified law pulls the rotor into the stator: its f_N falls to " + format_digits(least) +
                            " N over the contact samples (peak " + format_digits(peak) + " N); a contact force cannot pull");
  }
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
// A structure another comes within this BIC of is not decided by the data: 10 is "very strong"
// evidence on Kass and Raftery's scale (the tables' loop uses the same, docs/real-data.md).
constexpr double kDecisiveBic = 10.0;
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

// The weak form's estimates refined by the averaged cycles' periodic orbits, and the law's
// structure chosen by them: every structure of Eq. 5's family in the library that has a
// stiffness (z or z^3), each started from the weak form's least squares on its own terms, is
// fitted; the lowest BIC (chi^2 + unknowns ln residuals, chi^2 against each cycle's own noise)
// is reported, the others as runners-up. The weak form's selection is one candidate among them:
// at micrometre noise its significance test can drop a term the orbits resolve (z_dot^2 at 5 um)
// or take one they do not (z_dot^4).
void refine_by_orbits(law_context& ctx) {
  identification& id = ctx.id;
  const identify_settings& s = ctx.s;
  if (!ctx.weak || !s.orbit_fit || id.estimates.empty()) return;
  const auto& forces = ctx.forces;
  std::vector<orbit_fit_cycle> cycles;
  for (std::size_t k = 0; k < forces.size(); ++k)
    if (ctx.averaged[k]) cycles.push_back({&forces[k], ctx.sample_noise(k, true)});
  if (cycles.empty()) {
    id.notes.push_back("orbit fit: not run, no dwell is averaged (each dwell's averaging says why); the weak form's estimates stand");
    return;
  }
  if (cycles.size() < forces.size())
    id.notes.push_back("orbit fit: " + std::to_string(forces.size() - cycles.size()) + " dwell(s) not averaged left out (each dwell's averaging says why)");

  // The candidates: the family's terms present in the library, every subset with a stiffness
  // (or, without the comparison, the weak form's selection when it lies in the family).
  std::vector<std::size_t> column;  // library index of each family term present
  std::vector<std::string> present;
  for (const auto& [name, param] : kFamily)
    for (std::size_t c = 0; c < ctx.library.size(); ++c)
      if (ctx.library[c].name() == name) column.push_back(c), present.push_back(std::string(name));
  std::vector<std::vector<std::size_t>> subsets;  // indices into present
  for (unsigned mask = 1; mask < (1u << present.size()); ++mask) {
    std::vector<std::size_t> sub;
    bool stiffness = false, selected = true;
    for (std::size_t b = 0; b < present.size(); ++b) {
      const bool in = (mask & (1u << b)) != 0;
      if (in) sub.push_back(b), stiffness = stiffness || present[b] != "zd2";
      const bool kept = std::any_of(id.estimates.begin(), id.estimates.end(), [&](const term_estimate& e) { return e.name == present[b]; });
      selected = selected && in == kept;
    }
    const bool in_family = std::all_of(id.estimates.begin(), id.estimates.end(), [](const term_estimate& e) { return !family_parameter(e.name).empty(); });
    if (s.compare_structures ? stiffness : selected && in_family) subsets.push_back(sub);
  }
  if (subsets.empty()) {
    id.notes.push_back(s.compare_structures ? "orbit fit: not run, the library holds no stiffness of Eq. 5's family (z, z^3), the only laws it simulates"
                                            : "orbit fit: not run, the weak form's selection lies outside Eq. 5's family (z, z^3, z_dot^2), the only laws it simulates");
    return;
  }
  std::vector<std::string> weak_terms;
  for (const auto& e : id.estimates) weak_terms.push_back(e.name);

  struct trial {
    structure_candidate report;
    std::vector<term_estimate> start;  // the weak form's least squares on these terms
    std::optional<orbit_fit_result> fit;
  };
  const Eigen::Index dof_rows = ctx.sys.A.rows();
  // The weak law's peak force over the contact samples (their f_N is the law's here).
  double peak_force = 0.0;
  for (const auto& c : ctx.pooled) peak_force = std::max(peak_force, std::abs(c.fn));
  // Every structure fitted, lowest BIC first (structures without one after, in their order).
  const auto fit_structures = [&](int phase_search) {
    std::vector<trial> trials;
    for (const auto& sub : subsets) {
      trial t;
      std::vector<std::size_t> cols;
      for (const auto b : sub) t.report.terms.push_back(present[b]), cols.push_back(column[b]);
      const least_squares_fit ls = least_squares(ctx.sys.A, ctx.sys.b, cols);
      parameters start = ctx.output_error_start();
      start.unbalance_phase = id.linear.phase;
      start.mu = std::isfinite(id.mu) && id.mu > 0.0 ? id.mu : 0.0;
      start.k1 = start.k3 = start.c2 = 0.0;
      std::vector<std::string> members;
      std::string restarted;
      for (std::size_t j = 0; j < cols.size(); ++j) {
        const auto& term = ctx.library[cols[j]];
        double v = ls.coefficients[static_cast<Eigen::Index>(j)];
        const double se = ls.standard_errors[static_cast<Eigen::Index>(j)];
        if (!(v > 0.0)) {
          // A contact law's terms are > 0: a term the weak form puts at <= 0 starts where it
          // carries kRestartShare of the weak law's peak force over the contact samples.
          double peak_term = 0.0;
          for (const auto& c : ctx.pooled) peak_term = std::max(peak_term, std::abs(term(c.z, c.zd)));
          restarted += (restarted.empty() ? "" : ", ") + term.pretty() + " from " + format_digits(v);
          v = peak_term > 0.0 ? kRestartShare * peak_force / peak_term : 0.0;
        }
        t.start.push_back({term.name(), term.pretty(), v, se, kNaN, kNaN});
        members.push_back(family_parameter(term.name()));
        start.*law_member(term.name()) = v;
      }
      if (dof_rows <= static_cast<Eigen::Index>(cols.size()) || std::any_of(t.start.begin(), t.start.end(), [](const term_estimate& e) { return !(e.value > 0.0); })) {
        t.report.status = "not fitted: no positive start from the weak form's rows";
        trials.push_back(std::move(t));
        continue;
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
        t.report.bic = fit.final_chi2 * static_cast<double>(fit.residuals - fit.unknowns) +
                       static_cast<double>(fit.unknowns) * std::log(static_cast<double>(fit.residuals));
      t.fit = fit;
      trials.push_back(std::move(t));
    }
    std::stable_sort(trials.begin(), trials.end(), [](const trial& a, const trial& b) {
      const bool fa = std::isfinite(a.report.bic), fb = std::isfinite(b.report.bic);
      return fa != fb ? fa : fa && a.report.bic < b.report.bic;
    });
    return trials;
  };
  // Times not on one shaft angle (the contact-free dwells' test): each cycle's phase searched from
  // the start. Otherwise searched only when the cycles' given phases leave no fit within the noise
  // (no convergence, or chi^2 above its limit): the dwells in contact may not be on the linear
  // part's shaft angle (no keyphasor, t_s not shaft-synchronous), and the search changes only the
  // start, so the same model's lower chi^2 decides.
  const bool unknown_angle = !ctx.retimed_touching.empty();
  id.phases_searched = unknown_angle;
  std::vector<trial> trials = fit_structures(unknown_angle ? kPhaseSearch : 0);
  const auto within_noise = [](const std::vector<trial>& ts) {
    return std::isfinite(ts.front().report.bic) && ts.front().fit->final_chi2 <= orbit_fit_chi2_limit(*ts.front().fit);
  };
  if (!unknown_angle && !within_noise(trials)) {
    std::vector<trial> searched = fit_structures(kPhaseSearch);
    const bool better = std::isfinite(searched.front().report.bic) &&
                        (!std::isfinite(trials.front().report.bic) || searched.front().report.bic < trials.front().report.bic);
    id.notes.push_back(std::string("orbit fit: the cycles' forcing phases from the linear part left no fit within the noise; with each "
                                   "cycle's phase searched (") + std::to_string(kPhaseSearch) + " starts) the fits " +
                       (better ? "improved and are reported (the dwells in contact were not on the linear part's shaft angle)"
                               : "did not improve, and the first are reported"));
    if (better) trials = std::move(searched), id.phases_searched = true;
  }
  for (const auto& t : trials) id.structures.push_back(t.report);

  // The weak form's own selection, when the orbit fit could not choose (or it is outside the family).
  const auto same = [&](const std::vector<std::string>& terms) {
    std::vector<std::string> a = terms, b = weak_terms;
    std::sort(a.begin(), a.end()), std::sort(b.begin(), b.end());
    return a == b;
  };
  const trial* best = std::isfinite(trials.front().report.bic) ? &trials.front() : nullptr;
  id.weak_estimates = id.estimates;
  id.weak_mu = id.mu;
  id.weak_mu_standard_error = id.mu_standard_error;
  if (!best) {
    for (const auto& t : trials)
      if (t.fit && same(t.report.terms)) id.orbit = *t.fit;  // for its warning
    id.structure_reason = "no structure's orbit fit converged: the weak form's selection " + structure_text(weak_terms, ctx.library) + " and estimates stand";
    return;
  }
  id.orbit = *best->fit;
  // Decisive when no rival comes within kDecisiveBic; a superset of the chosen terms is no rival
  // (it trails by ~ln(residuals) minus what its extra term explains: the term is not needed).
  const auto superset = [&](const std::vector<std::string>& terms) {
    return std::all_of(best->report.terms.begin(), best->report.terms.end(),
                       [&](const std::string& t) { return std::find(terms.begin(), terms.end(), t) != terms.end(); });
  };
  const trial* rival = nullptr;
  for (std::size_t k = 1; k < trials.size() && !rival; ++k)
    if (std::isfinite(trials[k].report.bic) && !superset(trials[k].report.terms)) rival = &trials[k];
  const double gap = rival ? rival->report.bic - best->report.bic : kNaN;
  id.structure_decisive = !rival || gap >= kDecisiveBic;
  id.structure_reason = "orbit fit: " + structure_text(best->report.terms, ctx.library) + " has the lowest BIC (chi^2/dof " +
                        format_digits(best->report.chi2_per_dof) + ")" +
                        (rival ? "; the nearest rival that is not a superset of it, " + structure_text(rival->report.terms, ctx.library) +
                                     ", is " + format_digits(gap) + " above" +
                                     (id.structure_decisive ? "" : " (within " + format_digits(kDecisiveBic) + ": not decisive)")
                               : std::string("; no rival that is not a superset of it was fitted"));
  if (!same(best->report.terms))
    id.notes.push_back("structure: the orbit fit chose " + structure_text(best->report.terms, ctx.library) + " over the weak form's selection " +
                       structure_text(weak_terms, ctx.library) + " (every structure's BIC: identification.json, structures)");
  // The chosen structure's estimates: the orbit fit's values and normal 95 % intervals.
  const orbit_fit_result& fit = *id.orbit;
  id.estimates.clear();
  ctx.kept_terms.clear();
  ctx.kept_coef.clear();
  for (std::size_t j = 0; j < best->start.size(); ++j) {
    const auto& p = fit.parameters[j];
    const auto& st = best->start[j];
    id.estimates.push_back({st.name, st.pretty, p.value, p.standard_error, p.value - kInterval95 * p.standard_error,
                            p.value + kInterval95 * p.standard_error});
    for (const auto& c : ctx.library)
      if (c.name() == st.name) ctx.kept_terms.push_back(c);
    ctx.kept_coef.push_back(p.value);
  }
  id.weak_estimates = best->start;
  const auto& mu = fit.parameters[best->start.size()];
  id.mu = mu.value;
  id.mu_standard_error = mu.standard_error;
  // The shares and the pull check (shares_and_pull) see the chosen law's own f_N.
  for (auto& c : ctx.pooled) c.fn = ctx.law(c.z, c.zd);
  for (auto& d : ctx.per_dwell)
    for (auto& c : d) c.fn = ctx.law(c.z, c.zd);
}

// The output-error re-identification of Eq. 5's family (reidentify).
void reidentify_law(law_context& ctx) {
  identification& id = ctx.id;
  const identify_settings& s = ctx.s;
  const auto& forces = ctx.forces;
  parameters start = ctx.output_error_start();
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
  id.reid = reidentify(forces, start, id.linear.phase, rs);
}


// The law (docs/identification.md): the linear part, the route, the contact forces, the
// regression, FROLS's terms, their intervals by the route's own means, and the orbit fit and the
// re-identification where asked for. Each step is one function above.
identification identify_law_by(const std::vector<dwell>& dwells, const identify_settings& s, bool first_pass = true);

// Where the orbit fit had to search the touching dwells' forcing phases, the weak form ran on
// times it then found wrong, and its law (the orbit fit's start, and the structures' starts) with
// them. The dwells are put on the angles the orbit fit found (as if timed by a keyphasor) and
// everything runs again once, the notes of the first pass kept.
identification again_on_the_orbits_angles(const law_context& ctx, const std::vector<dwell>& dwells) {
  std::vector<dwell> timed = dwells;
  const auto& phase = ctx.id.orbit->phase;
  std::size_t cycle = 0;
  for (std::size_t k = 0; k < ctx.touching.size(); ++k) {
    if (!ctx.averaged[k]) continue;
    const dwell& used = *ctx.touching[k];  // as the first pass had it (1X-shifted, perhaps)
    dwell& d = timed[ctx.touching_index[k]];
    const double shift = used.t.front() - d.t.front() + std::remainder(phase[cycle++] - ctx.id.linear.phase, 2.0 * std::numbers::pi) / d.omega();
    for (double& t : d.t) t += shift;
    d.timing_sigma = 0.0;  // timed by the first pass's orbit fit
  }
  identification id = identify_law_by(timed, ctx.s, false);
  std::vector<std::string> notes = ctx.id.notes;
  notes.push_back("the dwells in contact were put on the shaft angles the orbit fit found and identified again (the notes below are that pass's)");
  for (const auto& n : id.notes)
    if (std::find(ctx.id.notes.begin(), ctx.id.notes.end(), n) == ctx.id.notes.end()) notes.push_back(n);
  id.notes = std::move(notes);
  return id;
}

identification identify_law_by(const std::vector<dwell>& dwells, const identify_settings& s, bool first_pass) {
  identification id;
  law_context ctx(id, s);
  linear_part_and_touching(ctx, dwells);
  decide_averaging(ctx);
  choose_route(ctx);
  contact_forces_of(ctx);
  pool_contacts(ctx);
  regression_rows(ctx);
  select_terms(ctx);
  if (ctx.weak) weak_form_estimates(ctx);
  else samples_estimates(ctx);
  refine_by_orbits(ctx);
  if (first_pass && id.phases_searched && id.orbit && id.orbit->converged) return again_on_the_orbits_angles(ctx, dwells);
  shares_and_pull(ctx);
  if (s.reidentify) reidentify_law(ctx);
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
  if (!id.structures.empty() && !id.orbit)
    w.push_back("orbit fit: " + id.structure_reason + " (statuses in identification.json, structure)");
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
