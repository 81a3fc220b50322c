// Identification (paper §4): derivatives, FROLS, the linear part, and the honest checks of the
// issue on records rubref simulates itself, where the truth is known.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <map>
#include <random>

#include "ref/base/errors.hpp"
#include "ref/identification/identify.hpp"
#include "ref/identification/term_library.hpp"
#include "ref/identification/weak_form.hpp"
#include "ref/model/closed_form.hpp"
#include "ref/rig/rig.hpp"
#include "ref/sweep/sweep_io.hpp"
#include "tests/sanitized.hpp"

namespace rubref {
namespace {

// ---------------------------------------------------------------- derivatives

// A degree-4 local polynomial reproduces any quartic exactly, centred or shifted at the ends.
TEST(derivatives, exact_on_quartics_everywhere) {
  const double dt = 1e-3;
  std::vector<double> v;
  for (int i = 0; i < 50; ++i) {
    const double t = i * dt;
    v.push_back(2.0 - 3.0 * t + 5.0 * t * t + 7.0 * t * t * t - 11.0 * t * t * t * t);
  }
  const auto d = differentiate(v, dt, {4, 4});
  for (int i = 0; i < 50; ++i) {
    const double t = i * dt;
    EXPECT_NEAR(d.d1[i], -3.0 + 10.0 * t + 21.0 * t * t - 44.0 * t * t * t, 1e-8) << i;
    EXPECT_NEAR(d.d2[i], 10.0 + 42.0 * t - 132.0 * t * t, 1e-4) << i;  // 1e-4 of 10: rounding / dt^2
  }
}

// The documented accuracy on a sinusoid sampled N times per period (docs/identification.md),
// for the default window (h = 4, degree 4): interior errors of order (w dt)^4; the h samples at
// each end use shifted windows, and their second derivative is one order less accurate.
TEST(derivatives, sinusoid_error_follows_the_sampling) {
  for (const int per_period : {128, 256, 512}) {
    const double dt = 1.0 / per_period, w = 2.0 * std::numbers::pi;
    const int n = 3 * per_period, h = derivative_settings{}.half_width;
    std::vector<double> v;
    for (int i = 0; i < n; ++i) v.push_back(std::sin(w * i * dt));
    const auto d = differentiate(v, dt, {});
    double inner1 = 0.0, inner2 = 0.0, end1 = 0.0, end2 = 0.0;
    for (int i = 0; i < n; ++i) {
      const double e1 = std::abs(d.d1[i] - w * std::cos(w * i * dt)) / w;
      const double e2 = std::abs(d.d2[i] + w * w * std::sin(w * i * dt)) / (w * w);
      const bool end = i < h || i >= n - h;
      (end ? end1 : inner1) = std::max(end ? end1 : inner1, e1);
      (end ? end2 : inner2) = std::max(end ? end2 : inner2, e2);
    }
    const double h4 = std::pow(w * dt, 4);
    SCOPED_TRACE(per_period);
    const double h3 = std::pow(w * dt, 3);
    // Measured: interior 0.66 and 0.38 (w dt)^4; ends 3.1 (w dt)^4 and, one-sided, 6.5 (w dt)^3 for
    // the second derivative. Bounds: 1.5 times those.
    EXPECT_LT(inner1, 1.0 * h4);
    EXPECT_LT(inner2, 0.6 * h4);
    EXPECT_LT(end1, 4.7 * h4);
    EXPECT_LT(end2, 10.0 * h3);
  }
}

// Windows split at a segment boundary keep a jump in the second derivative sharp.
TEST(derivatives, segments_keep_a_kink_sharp) {
  const double dt = 1e-3;
  std::vector<double> v;
  std::vector<int> seg;
  for (int i = -30; i <= 30; ++i) {
    const double t = i * dt;
    v.push_back(t < 0 ? t * t : 3.0 * t * t);  // v'' jumps from 2 to 6 at t = 0
    seg.push_back(t < 0 ? 0 : 1);
  }
  const auto split = differentiate(v, dt, {4, 4}, seg);
  const auto blurred = differentiate(v, dt, {4, 4});
  for (int k = 0; k < 61; ++k) EXPECT_NEAR(split.d2[k], k < 30 ? 2.0 : 6.0, 1e-6) << k;
  EXPECT_GT(std::abs(blurred.d2[29] - 2.0), 0.5);  // without the split the jump smears
}

TEST(derivatives, synchronous_average_divides_noise_by_sqrt_revolutions) {
  dwell d;
  d.rpm = 600.0;  // 10 Hz
  d.dt = 0.1 / 64;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 1e-6);
  const int revs = 64;
  for (int i = 0; i < revs * 64; ++i) {
    d.t.push_back(i * d.dt);
    d.x.push_back(1e-4 * std::cos(2 * std::numbers::pi * 10 * i * d.dt) + noise(rng));
    d.y.push_back(1e-4 * std::sin(2 * std::numbers::pi * 10 * i * d.dt) + noise(rng));
  }
  const auto a = synchronous_average(d);
  EXPECT_EQ(a.revolutions, revs);  // every whole revolution, the last one (ending a step before the next) included
  EXPECT_EQ(a.cycle.size(), 64u);
  double err = 0.0;
  for (std::size_t k = 0; k < 64; ++k) err += std::pow(a.cycle.x[k] - 1e-4 * std::cos(2 * std::numbers::pi * 10 * a.cycle.t[k]), 2) / 64;
  // The mean of 63 revolutions: noise 1e-6 / sqrt(63) ~ 1.3e-7; 2x for the scatter of 64 bins.
  EXPECT_LT(std::sqrt(err), 2.0 * 1e-6 / std::sqrt(63.0));
  EXPECT_NEAR(a.spread, 1e-6, 0.1e-6);  // the revolutions scatter by the noise
}

// ---------------------------------------------------------------- FROLS and the library

// A dwell's noise is its own, never below its rounding q / sqrt(12). A noise-free orbit that moves
// less than a step per sample has 4th differences of ~0 and reads q / sqrt(12); one that moves
// many steps per sample rounds like uniform noise, which the Gaussian-scaled median reads ~23 %
// high; with white noise well above q the 4th differences rule.
TEST(dwells, noise_per_dwell_counts_the_quantisation_step) {
  constexpr double kStep = 6.1e-8;  // m, the rig's default ADC step
  dwell d;
  d.rpm = 1500;
  d.dt = 1e-4;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> white(0.0, 1e-6);
  const auto quantise = [](double v) { return kStep * std::round(v / kStep); };
  dwell noisy = d;
  for (int i = 0; i < 4000; ++i) {
    const double t = i * d.dt, w = d.omega();
    d.t.push_back(t), noisy.t.push_back(t);
    d.x.push_back(quantise(1e-4 * std::cos(w * t))), d.y.push_back(quantise(1e-4 * std::sin(w * t)));
    noisy.x.push_back(quantise(1e-4 * std::cos(w * t) + white(rng))), noisy.y.push_back(quantise(1e-4 * std::sin(w * t) + white(rng)));
  }
  // The step exactly (to rounding); the fast orbit (~100 steps per sample) reads its rounding
  // within 30 % above q / sqrt(12) (measured +23 %), never below.
  EXPECT_NEAR(quantisation_step(d.x) / kStep, 1.0, 1e-9);
  const dwell_noise clean = estimate_dwell_noise(d);
  EXPECT_NEAR(clean.quantisation / kStep, 1.0, 1e-9);
  EXPECT_GE(clean.sigma, kStep / std::sqrt(12.0));
  EXPECT_LE(clean.sigma, 1.3 * kStep / std::sqrt(12.0));
  // A slow orbit (0.3 um: ~0.03 steps per sample): 4th differences ~0, the floor q / sqrt(12).
  dwell slow = d;
  for (std::size_t i = 0; i < slow.t.size(); ++i)
    slow.x[i] = quantise(3e-7 * std::cos(d.omega() * slow.t[i])), slow.y[i] = quantise(3e-7 * std::sin(d.omega() * slow.t[i]));
  const dwell_noise still = estimate_dwell_noise(slow);
  EXPECT_LT(still.white, 0.1 * still.sigma);
  EXPECT_DOUBLE_EQ(still.sigma, kStep / std::sqrt(12.0) * (still.quantisation / kStep));
  // 1 um white noise: the 4th differences' estimate (5 %: its sampling error at 2 x 3996
  // differences is ~2 %), the step still seen.
  const dwell_noise n = estimate_dwell_noise(noisy);
  EXPECT_NEAR(n.sigma / 1e-6, 1.0, 0.05);
  EXPECT_NEAR(n.quantisation / kStep, 1.0, 1e-9);
  // Samples on no grid: no step.
  std::vector<double> off(d.x);
  off[7] += 0.3 * kStep;
  EXPECT_EQ(quantisation_step(off), 0.0);
}

TEST(frols, selects_the_generating_terms_and_is_scale_invariant) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 400;
  Eigen::MatrixXd P(n, 4);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    P.row(i) << u(rng), u(rng), u(rng), u(rng);
    y[i] = 2.0 * P(i, 0) + 3.0 * P(i, 3);
  }
  const auto r = frols(P, y, {});
  ASSERT_EQ(r.kept.size(), 2u);
  double sum = 0.0;
  for (const auto& st : r.order) {
    EXPECT_GE(st.err, 0.0);
    EXPECT_LE(st.err, 1.0);
    sum += st.err;
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);  // exact data: everything explained
  const std::vector<std::size_t> want{0, 3};
  std::vector<std::size_t> kept = r.kept;
  std::sort(kept.begin(), kept.end());
  EXPECT_EQ(kept, want);
  // Rescaling a regressor by 1e-12 changes neither ERR nor the selection (units of z: m vs um).
  Eigen::MatrixXd Q = P;
  Q.col(3) *= 1e-12;
  const auto s = frols(Q, y, {});
  for (std::size_t k = 0; k < r.order.size(); ++k) {
    EXPECT_EQ(s.order[k].candidate, r.order[k].candidate);
    EXPECT_NEAR(s.order[k].err, r.order[k].err, 1e-10);
  }
}

TEST(term_library, parses_the_papers_library_and_extensions) {
  const auto lib = parse_library("z1..4,zd1..4,abszd1*zd1,z1.5,const");
  ASSERT_EQ(lib.size(), 11u);
  EXPECT_EQ(lib[0].name(), "z1");
  EXPECT_EQ(lib[5].name(), "zd2");
  EXPECT_EQ(lib[8].pretty(), "|ż|·ż");
  EXPECT_DOUBLE_EQ(lib[8](0.0, -2.0), -4.0);
  EXPECT_DOUBLE_EQ(lib[9](4.0, 0.0), 8.0);
  EXPECT_DOUBLE_EQ(lib[10](3.0, 5.0), 1.0);
  EXPECT_DOUBLE_EQ(lib[6](0.0, -2.0), -8.0);  // integer powers keep the sign: z_dot^3
  EXPECT_THROW(parse_library("z1,,z2"), input_error);
  EXPECT_THROW(parse_library("w2"), input_error);
  EXPECT_THROW(parse_library("z1,z1"), input_error);
  EXPECT_THROW(parse_library("z1..x"), input_error);
}

// The noise-unbiased form: E[He-scaled (v + n)^p] = v^p for Gaussian n of variance s^2.
TEST(term_library, unbiased_powers_remove_the_noise_moments) {
  const auto lib = parse_library("zd1,zd2,zd3,z2,abszd2,z1*zd2");
  const double v = 0.3, var = 0.04, z = 2.0;
  EXPECT_DOUBLE_EQ(lib[0].unbiased(z, v, var), v);
  EXPECT_DOUBLE_EQ(lib[1].unbiased(z, v, var), v * v - var);          // E[(v + n)^2] = v^2 + s^2
  EXPECT_DOUBLE_EQ(lib[2].unbiased(z, v, var), v * v * v - 3 * var * v);  // E[(v + n)^3] = v^3 + 3 s^2 v
  EXPECT_DOUBLE_EQ(lib[3].unbiased(z, v, var), z * z);                // z is not corrected
  EXPECT_DOUBLE_EQ(lib[4].unbiased(z, v, var), v * v);                // |z_dot|^p has no such polynomial
  EXPECT_DOUBLE_EQ(lib[5].unbiased(z, v, var), z * (v * v - var));
  EXPECT_DOUBLE_EQ(lib[1].unbiased(z, v, 0.0), v * v);
  // Monte Carlo: the mean over 2e5 draws within 4 standard errors of v^3.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, std::sqrt(var));
  double mean = 0.0, sq = 0.0;
  constexpr int kDraws = 200000;
  for (int i = 0; i < kDraws; ++i) {
    const double u = lib[2].unbiased(z, v + n(rng), var);
    mean += u / kDraws;
    sq += u * u / kDraws;
  }
  EXPECT_NEAR(mean, v * v * v, 4.0 * std::sqrt((sq - mean * mean) / kDraws));
}

// ---------------------------------------------------------------- on rubref's own records

// Runs of one variant at 1500-1700 rpm, 0.3 mm, as one multi-dwell record.
record simulated(const std::string& variant, parameters p, int samples_per_rev, double from = 1500, double to = 1700,
                 double step = 50, int revs = 12) {
  sweep_settings s;
  s.variant = variant;
  s.params = p;
  s.from_rpm = from;
  s.to_rpm = to;
  s.step_rpm = step;
  s.samples_per_rev = samples_per_rev;
  s.record_revs = revs;
  s.keep_orbits = true;
  return dwell_record(s, run_branch(s, sweep_direction::up));
}

void add_noise(record& r, double share, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (const char* col : {"x_m", "y_m"}) {
    auto& v = r.data[col == std::string("x_m") ? 1 : 2];
    double rms = 0.0;
    for (double x : v) rms += x * x / v.size();
    rms = std::sqrt(rms);
    for (double& x : v) x += share * rms * n(rng);
  }
}

identify_settings knowing(const parameters& p) {
  identify_settings s;
  s.linear = p;
  s.reference = p;
  return s;
}

const term_estimate* estimate_of(const identification& id, const std::string& term) {
  for (const auto& e : id.estimates)
    if (e.name == term) return &e;
  return nullptr;
}

// The structure choice's reason (its verdict's), for a failure's message.
std::string reason_of(const identification& id) { return id.structure && !id.structure->reasons.empty() ? id.structure->reasons.front() : std::string(); }

std::vector<std::string> kept_names(const identification& id) {
  std::vector<std::string> out;
  for (const auto& e : id.estimates) out.push_back(e.name);
  std::sort(out.begin(), out.end());
  return out;
}

// Table 2's law, no noise: z and z_dot^2 carry the force, z^3 is invisible at 6-16 um.
TEST(identification, identified_law_gives_z_and_zdot2_and_not_z3) {
  const parameters paper;
  identify_settings s = knowing(paper);
  s.law_route = law_method::samples;  // the paper's route (its Table 1-2 and Fig. 5 claims)
  const identification id = identify({{simulated("identified", paper, 1024), "identified.csv"}}, s);
  EXPECT_EQ(kept_names(id), (std::vector<std::string>{"z1", "zd2"}));
  constexpr double kPaperTermTol = 0.005;  // the 0.5 %
  EXPECT_NEAR(estimate_of(id, "z1")->value / paper.k1, 1.0, kPaperTermTol);
  EXPECT_NEAR(estimate_of(id, "zd2")->value / paper.c2, 1.0, kPaperTermTol);
  constexpr double kMuTol = 0.001;  // the bound
  EXPECT_NEAR(id.mu_mean, paper.mu, kMuTol);
  for (const auto& d : id.dwells) {
    ASSERT_TRUE(d.friction.has_value());
    EXPECT_NEAR(d.friction->mean, paper.mu, kMuTol) << d.rpm;
    // k3 z^3 is below 1e-4 of the peak force at these penetrations: not identifiable.
    EXPECT_LT(d.reference_shares[1].peak_share, 1e-4) << d.rpm;
    EXPECT_LT(d.max_penetration, 20e-6) << d.rpm;
  }
  // z^3's ERR, once z is in, is at the level of the derivative error (far below 1 %).
  for (const auto& st : id.frols.order) {
    if (id.candidates[st.candidate] == "z3") {
      EXPECT_LT(st.err, 1e-6);
    }
  }
}

// A law where k1 z, k3 z^3 and c2 z_dot^2 each carry >= 10 % of the peak force. z^3 is nearly
// collinear with z over 0-25 um, so it adds only ~0.4 % ERR after z and z_dot^2: the paper's
// rho = 1 % and 1 % threshold would stop before it. With rho = 1e-4 and threshold 1e-3 it is found.
TEST(identification, all_three_terms_when_each_matters) {
  parameters p;
  p.k1 = 1e6;
  p.k3 = 1e15;
  identify_settings s = knowing(p);
  s.law_route = law_method::samples;  // the paper's route and its ERR thresholds
  s.frols.rho = 1e-4;
  s.frols.err_threshold = 1e-3;
  const identification id = identify({{simulated("identified", p, 1024), "three.csv"}}, s);
  double share[3] = {0, 0, 0};
  for (const auto& d : id.dwells)
    for (int j = 0; j < 3; ++j) share[j] = std::max(share[j], d.reference_shares[j].peak_share);
  ASSERT_GE(share[0], 0.1);
  ASSERT_GE(share[1], 0.1);
  ASSERT_GE(share[2], 0.1);
  EXPECT_EQ(kept_names(id), (std::vector<std::string>{"z1", "z3", "zd2"}));
  constexpr double kThreeTermTol = 0.01;  // the 1 %
  EXPECT_NEAR(estimate_of(id, "z1")->value / p.k1, 1.0, kThreeTermTol);
  EXPECT_NEAR(estimate_of(id, "z3")->value / p.k3, 1.0, kThreeTermTol);
  EXPECT_NEAR(estimate_of(id, "zd2")->value / p.c2, 1.0, kThreeTermTol);
}

TEST(identification, piecewise_linear_gives_z_alone) {
  const parameters paper;
  identify_settings s = knowing(paper);
  s.law_route = law_method::samples;  // the paper's route
  const identification id = identify({{simulated("piecewise-linear", paper, 1024), "pl.csv"}}, s);
  EXPECT_EQ(kept_names(id), (std::vector<std::string>{"z1"}));
  EXPECT_NEAR(estimate_of(id, "z1")->value / paper.k1, 1.0, 0.005);
}

// §3 from data: without contact Eq. 1 / m is linear in c/m, k/m and the unbalance.
TEST(identification, linear_part_from_records_without_contact) {
  parameters p;
  p.clearance = 1.0;  // no contact anywhere
  record r = simulated("identified", p, 256, 1400, 1700, 100);
  const auto dwells = split_dwells(r, "free.csv");
  std::vector<const dwell*> free;
  for (const auto& d : dwells) free.push_back(&d);
  const linear_fit fit = fit_linear_part(free, p.m, {});
  constexpr double kLinearTol = 1e-4;  // derivative error at 256 samples per revolution ~1e-7
  EXPECT_NEAR(fit.value.c_x / p.c_x, 1.0, kLinearTol);
  EXPECT_NEAR(fit.value.c_y / p.c_y, 1.0, kLinearTol);
  EXPECT_NEAR(fit.value.k_x / p.k_x, 1.0, kLinearTol);
  EXPECT_NEAR(fit.value.k_y / p.k_y, 1.0, kLinearTol);
  EXPECT_NEAR(fit.value.e / p.e, 1.0, kLinearTol);
  EXPECT_NEAR(fit.value.phase, 0.0, kLinearTol);
  EXPECT_THROW(fit_linear_part({free.front()}, p.m, {}), input_error);  // one speed cannot separate c, k, e
}

// The harmonic route (the default) balances Eq. 1 at 1X: no derivative of data, every sample
// averaging the noise. At 2 um probe noise (the eddy-current level), three 12-revolution
// dwells at 10 kHz (the sweep's dwells come in multiples of 6), c, k and e come within 1 %; the equation-error route on Savitzky-Golay
// derivatives is off by far more there (its second derivative's noise exceeds the signal).
TEST(identification, harmonic_linear_part_survives_probe_noise) {
  parameters p;
  p.clearance = 1.0;  // no contact anywhere
  constexpr int kSamplesPerRev = 400;  // the 10 kHz at 1500 rpm
  record r = simulated("identified", p, kSamplesPerRev, 1100, 1300, 100, 12);
  constexpr double kNoise = 2e-6;  // m
  {
    std::mt19937_64 rng(7);
    std::normal_distribution<double> n(0.0, kNoise);
    for (int col : {1, 2})
      for (double& v : r.data[static_cast<std::size_t>(col)]) v += n(rng);
  }
  const auto dwells = split_dwells(r, "free.csv");
  std::vector<const dwell*> free;
  for (const auto& d : dwells) free.push_back(&d);
  // The 4th-difference estimate of the noise: within 5 % (its own sampling error at 2 x 14 400
  // samples is ~1 %).
  EXPECT_NEAR(estimate_probe_noise(free) / kNoise, 1.0, 0.05);
  const linear_fit h = fit_linear_part(free, p.m, {}, linear_method::harmonic);
  // 1X coefficients from 4800 samples per dwell carry ~2e-6 sqrt(2/4800) = 4e-8 m of noise on
  // 30-90 um: the damping (the smallest term of the balance) within 1 %, the rest far better.
  constexpr double kNoisyLinearTol = 0.01;
  EXPECT_NEAR(h.value.c_x / p.c_x, 1.0, kNoisyLinearTol);
  EXPECT_NEAR(h.value.c_y / p.c_y, 1.0, kNoisyLinearTol);
  EXPECT_NEAR(h.value.k_x / p.k_x, 1.0, kNoisyLinearTol);
  EXPECT_NEAR(h.value.k_y / p.k_y, 1.0, kNoisyLinearTol);
  EXPECT_NEAR(h.value.e / p.e, 1.0, kNoisyLinearTol);
  for (double b : h.beyond_1x_rms) EXPECT_NEAR(b / kNoise, 1.0, 0.05);  // a steady dwell: noise alone beyond 1X
  // The equation-error route on the same data: damping off by more than 50 %.
  const linear_fit ee = fit_linear_part(free, p.m, {}, linear_method::equation_error);
  EXPECT_GT(std::abs(ee.value.c_x / p.c_x - 1.0), 0.5);
}

// Never a silent unphysical number: noisy records through the equation-error route give
// estimates the warnings name; clean records give none.
TEST(identification, unphysical_or_undetermined_estimates_are_warnings) {
  if (kSanitized) GTEST_SKIP() << "release builds only: its orbit fits are ~10x slower sanitized, and records_of_different_noise_each_their_own runs the same code there";
  const parameters paper;
  const identification clean = identify({{simulated("identified", paper, 1024), "identified.csv"}}, knowing(paper));
  EXPECT_TRUE(clean.warnings.empty()) << clean.warnings.front();
  record noisy = simulated("identified", paper, 400, 1500, 1700, 50, 12);
  add_noise(noisy, 0.03, 11);  // ~2 um on ~70 um orbits
  identify_settings samples_route = knowing(paper);
  samples_route.law_route = law_method::samples;  // second derivatives of noisy data
  const identification id = identify({{noisy, "noisy.csv"}}, samples_route);
  EXPECT_FALSE(id.warnings.empty());
  // Every kept term whose interval contains 0 is named.
  for (const auto& e : id.estimates) {
    const bool across = (std::isfinite(e.ci_low) && e.ci_low <= 0.0 && e.ci_high >= 0.0) || std::abs(e.value) <= 1.96 * e.standard_error;
    if (!across) continue;
    const bool named = std::any_of(id.warnings.begin(), id.warnings.end(),
                                   [&](const std::string& w) { return w.rfind("term " + e.name + " ", 0) == 0; });
    EXPECT_TRUE(named) << e.name;
  }
}

std::vector<dwell_forces> averaged_forces(const record& r, const parameters& p, std::vector<averaged_dwell>& keep) {
  keep.clear();
  for (const auto& d : split_dwells(r, "r.csv")) keep.push_back(synchronous_average(d));
  std::vector<dwell_forces> out;
  const linear_part lin{p.m, p.c_x, p.c_y, p.k_x, p.k_y, p.e, 0.0};
  for (const auto& a : keep) out.push_back(contact_forces(a.cycle, lin, a.cycle.clearance, {}));
  return out;
}

parameters thirty_percent_off(const parameters& truth) {
  parameters p = truth;
  p.k1 *= 1.3;
  p.k3 *= 1.3;
  p.c2 *= 0.7;
  p.mu *= 1.3;
  return p;
}

// NLopt from 30 % away: every identifiable parameter within 1 %, k3 reported not identifiable.
TEST(reidentification, recovers_identifiable_parameters_from_30_percent_off) {
  const parameters truth;
  std::vector<averaged_dwell> keep;
  const auto forces = averaged_forces(simulated("identified", truth, 256, 1550, 1650, 50), truth, keep);
  const reid_result r = reidentify(forces, thirty_percent_off(truth), 0.0, {});
  EXPECT_LT(r.final_rms, 1e-3 * r.initial_rms);
  for (const auto& p : r.parameters) {
    SCOPED_TRACE(p.name);
    if (p.name == "k3") {
      EXPECT_FALSE(p.identifiable);
      continue;
    }
    EXPECT_TRUE(p.identifiable);
    const double want = p.name == "k1" ? truth.k1 : p.name == "c2" ? truth.c2 : truth.mu;
    EXPECT_NEAR(p.value / want, 1.0, 0.01);  // the 1 %
  }
}

// 1 % white noise (of the RMS displacement, ~2 um against 6-16 um penetrations): the bounds
// measured and stated in docs/identification.md. Output error on the averaged cycles holds up;
// see the docs for what equation-error FROLS does at this level.
TEST(reidentification, one_percent_noise_within_measured_bounds) {
  const parameters truth;
  record r = simulated("identified", truth, 256, 1500, 1700, 50, 24);
  add_noise(r, 0.01, 11);
  std::vector<averaged_dwell> keep;
  const auto forces = averaged_forces(r, truth, keep);
  reid_settings rs;
  rs.fit = {"k1", "c2", "mu"};
  const reid_result res = reidentify(forces, thirty_percent_off(truth), 0.0, rs);
  // Relative bounds stated in docs/identification.md; measured with this seed: k1 -0.77 %,
  // c2 +3.4 %, mu -0.025 %, each inside its standard error (1.5 %, 8.6 %, 0.02 %).
  const std::map<std::string, double> bound{{"k1", 0.03}, {"c2", 0.1}, {"mu", 0.002}};
  for (const auto& p : res.parameters) {
    SCOPED_TRACE(p.name);
    const double want = p.name == "k1" ? truth.k1 : p.name == "c2" ? truth.c2 : truth.mu;
    EXPECT_NEAR(p.value / want, 1.0, bound.at(p.name));
    EXPECT_LT(std::abs(p.value - want), 3.0 * p.standard_error);  // the stated uncertainty covers the error
  }
}

// Equation error (FROLS) under 0.1 % noise with synchronous averaging: the bounds measured.
TEST(identification, one_permille_noise_averaged_within_measured_bounds) {
  const parameters paper;
  record r = simulated("identified", paper, 512, 1500, 1700, 50, 96);
  add_noise(r, 0.001, 5);
  identify_settings s = knowing(paper);
  s.average = averaging::always;
  s.derivative.half_width = 8;
  const identification id = identify({{r, "noisy.csv"}}, s);
  ASSERT_NE(estimate_of(id, "z1"), nullptr);
  ASSERT_NE(estimate_of(id, "zd2"), nullptr);
  // Bounds stated in docs/identification.md; measured with this seed: k1 -0.05 %, c2 +1.3 %,
  // pooled mu 0.2416 (the per-speed mean, 0.263, suffers more from small forces).
  EXPECT_NEAR(estimate_of(id, "z1")->value / paper.k1, 1.0, 0.03);
  EXPECT_NEAR(estimate_of(id, "zd2")->value / paper.c2, 1.0, 0.08);
  EXPECT_NEAR(id.mu_slope, paper.mu, 0.02);
}

TEST(identification, refuses_unusable_input) {
  parameters far;
  far.clearance = 1.0;
  const record no_contact = simulated("identified", far, 64, 1500, 1600, 50);
  EXPECT_THROW(identify({{no_contact, "free.csv"}}, knowing(far)), input_error);
  record unknown_clearance = no_contact;
  std::erase_if(unknown_clearance.metadata, [](const auto& kv) { return kv.first == "clearance_m"; });
  EXPECT_THROW(identify({{unknown_clearance, "x.csv"}}, knowing(far)), input_error);
}

// Millimetres in columns that say metres (an orbit of tens of centimetres) are refused where every
// record enters identify, the loop and the order tracker (split_dwells), with the conversion;
// identify used to report a missing contact-free dwell instead.
TEST(identification, refuses_displacements_that_are_not_metres) {
  const auto circle = [](double radius) {
    record r;
    r.set("clearance_m", 3e-4);
    std::vector<double> t, x, y, rpm;
    for (int i = 0; i < 64; ++i) {
      const double angle = 2.0 * std::numbers::pi * i / 64.0;
      t.push_back(i * 1e-4);
      x.push_back(radius * std::cos(angle));
      y.push_back(radius * std::sin(angle));
      rpm.push_back(1500.0);
    }
    for (auto& [name, v] : {std::pair{"t_s", t}, std::pair{"x_m", x}, std::pair{"y_m", y}, std::pair{"speed_rpm", rpm}}) r.add_column(name, v);
    return r;
  };
  const auto refusal = [](const auto& call) {
    try {
      call();
    } catch (const input_error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NO_THROW(split_dwells(circle(0.4e-3), "m.csv"));  // the paper's orbit, in metres
  EXPECT_NO_THROW(split_dwells(circle(0.99 * kImplausibleDisplacement), "m.csv"));
  // Row 0 is file line 3 of a record made in memory (one metadata line, the header).
  const std::string mm = "mm.csv:3: x_m reaches 0.4 m, and no rotor kit's shaft moves 10 mm or more: if the file holds millimetres, divide x_m and y_m by 1000";
  EXPECT_EQ(refusal([&] { split_dwells(circle(0.4), "mm.csv"); }), mm);
  EXPECT_EQ(refusal([&] { identify({{circle(0.4), "mm.csv"}}, identify_settings{}); }), mm);
  EXPECT_NE(refusal([&] { split_dwells(circle(400.0), "um.csv"); }).find("if the file holds micrometres, divide x_m and y_m by 1e6"), std::string::npos);
}


// ---------------------------------------------------------------- the weak form (§5, noisy data)

// On a noise-free record the weak form's rows hold the law: int f_N psi = sum theta_j int phi_j psi
// up to the quadrature (trapezoid rule on 10 kHz samples; measured 0.2 % of the rows' norm).
TEST(weak_form, rows_hold_the_law_on_noise_free_records) {
  const parameters paper;
  rig_request req;
  req.speeds_rpm = {1500, 1600, 1700};
  req.record_revs = 4;
  req.probes.noise = 0.0;
  req.probes.quantisation = 0.0;
  req.probes.keyphasor = false;
  req.time_base = rig_time_base::shaft;
  const record r = run_rig(req).measurement;
  const linear_part lin{paper.m, paper.c_x, paper.c_y, paper.k_x, paper.k_y, paper.e, paper.unbalance_phase};
  const auto library = parse_library("z1,z3,zd2");
  std::vector<dwell> dwells = split_dwells(r, "rig.csv");
  std::vector<dwell_forces> forces;
  for (const auto& d : dwells) forces.push_back(contact_forces(d, lin, d.clearance, {8, 4}));
  std::vector<weak_form_input> in;
  for (const auto& f : forces) in.push_back({&f, 0.0});
  const weak_form_system sys = weak_form(in, lin, library);
  EXPECT_GE(sys.episodes, 10u);
  const Eigen::Vector3d theta(paper.k1, paper.k3, paper.c2);
  constexpr double kQuadratureTol = 0.01;  // 5x the measured 0.2 %
  EXPECT_LT((sys.b - sys.A * theta).norm(), kQuadratureTol * sys.b.norm());
  // Friction: int f_x psi = mu int f_N psi on every row.
  EXPECT_NEAR(sys.bx.dot(sys.b) / sys.b.squaredNorm(), paper.mu, kQuadratureTol * paper.mu);
}

// Records of `rubref rig` (acquisition clock, keyphasor), five dwells 1500-1700 rpm, 10 kHz, 10
// revolutions, and a contact-free record at 1100-1300 rpm: the scenario.
std::pair<record, record> rig_records(const std::string& variant, double noise, unsigned seed) {
  rig_request req;
  req.variant = variant;
  req.speeds_rpm = {1500, 1550, 1600, 1650, 1700};
  req.record_revs = 10;
  req.probes.noise = noise;
  req.probes.seed = seed;
  rig_request free = req;
  free.speeds_rpm = {1100, 1200, 1300};
  free.probes.seed = seed + 1000;
  return {run_rig(req).measurement, run_rig(free).measurement};
}

// With no options, at 0.5 um probe noise: the weak form is chosen, {z, z_dot^2} selected, the
// values within the targets. Tolerances are ~4 standard deviations of a 30-seed campaign
// (scripts/identification-campaign: k1 1.1 %, c2 5 %, mu 0.002), so a correct estimator fails
// them with ~1e-4 odds; three seeds.
TEST(identification, weak_form_by_default_at_probe_noise) {
  const parameters truth;
  constexpr double kK1Tol = 0.05, kC2Tol = 0.2, kMuTol = 0.01;  // the targets
  // One seed under the sanitizers (their runs are ~10x slower; the code paths are the same).
  for (const unsigned seed : kSanitized ? std::vector<unsigned>{1u} : std::vector<unsigned>{1u, 2u, 3u}) {
    const auto [rub, free] = rig_records("identified", 0.5e-6, seed);
    const identification id = identify({{rub, "rub.csv"}, {free, "free.csv"}}, identify_settings{});
    EXPECT_EQ(id.law_route, law_method::weak_form) << id.law_route_reason;
    EXPECT_EQ(kept_names(id), (std::vector<std::string>{"z1", "zd2"})) << seed;
    if (const auto* k1 = estimate_of(id, "z1")) {
      EXPECT_NEAR(k1->value / truth.k1, 1.0, kK1Tol) << seed;
    }
    if (const auto* c2 = estimate_of(id, "zd2")) {
      EXPECT_NEAR(c2->value / truth.c2, 1.0, kC2Tol) << seed;
    }
    EXPECT_NEAR(id.mu, truth.mu, kMuTol) << seed;
    ASSERT_TRUE(id.weak);
    EXPECT_GT(id.weak->noise, 0.0);
    EXPECT_TRUE(id.warnings.empty()) << seed << ": " << id.warnings.front();
    // Every dwell steady, so averaged: 10 revolutions, 9 where 10 T is not a whole number of
    // samples and the record ends inside the tenth.
    for (const auto& d : id.dwells) EXPECT_GE(d.averaged_revolutions, 9) << d.rpm;
  }
}

// At 2 um with no options: the weak form selects {z, z_dot^2}, the orbit fit refines it to the
// issue's targets, leaves a chi^2 the noise explains, refits the free record's linear part, and
// its intervals are honest: every estimate within 4 of its standard errors of the truth (a
// correct estimator fails that with ~1e-4 odds per estimate).
TEST(identification, orbit_fit_at_two_micrometres_meets_the_targets) {
  const parameters truth;
  constexpr double kK1Tol = 0.05, kC2Tol = 0.2, kMuTol = 0.01;  // the targets
  constexpr double kStandardErrors = 4.0;
  // The refitted linear part: within 1 % (measured ~0.3 % on c_y, 0.01 % on k; the free record's
  // own c is 3-4 % low, docs/identification.md §5).
  constexpr double kLinearTol = 0.01;
  for (const unsigned seed : kSanitized ? std::vector<unsigned>{4u} : std::vector<unsigned>{4u, 5u}) {
    const auto [rub, free] = rig_records("identified", 2e-6, seed);
    const identification id = identify({{rub, "rub.csv"}, {free, "free.csv"}}, identify_settings{});
    EXPECT_EQ(id.law_route, law_method::weak_form);
    ASSERT_EQ(kept_names(id), (std::vector<std::string>{"z1", "zd2"})) << seed;
    ASSERT_TRUE(id.orbit);
    EXPECT_TRUE(id.orbit->converged) << id.orbit->status;
    EXPECT_TRUE(id.warnings.empty()) << seed << ": " << id.warnings.front();
    EXPECT_EQ(id.weak_estimates.size(), 2u);  // the weak form's start is kept
    const auto* k1 = estimate_of(id, "z1");
    const auto* c2 = estimate_of(id, "zd2");
    EXPECT_NEAR(k1->value / truth.k1, 1.0, kK1Tol) << seed;
    EXPECT_NEAR(c2->value / truth.c2, 1.0, kC2Tol) << seed;
    EXPECT_NEAR(id.mu, truth.mu, kMuTol) << seed;
    EXPECT_NEAR(k1->value, truth.k1, kStandardErrors * k1->standard_error) << seed;
    EXPECT_NEAR(c2->value, truth.c2, kStandardErrors * c2->standard_error) << seed;
    EXPECT_NEAR(id.mu, truth.mu, kStandardErrors * id.mu_standard_error) << seed;
    for (const auto& e : id.estimates) {
      EXPECT_LE(e.ci_low, e.value);
      EXPECT_GE(e.ci_high, e.value);
    }
    const std::map<std::string, double> linear{{"c_x", truth.c_x}, {"c_y", truth.c_y}, {"k_x", truth.k_x}, {"k_y", truth.k_y}};
    for (const auto& p : id.orbit->parameters) {
      if (linear.count(p.name)) {
        EXPECT_NEAR(p.value / linear.at(p.name), 1.0, kLinearTol) << p.name;
      }
    }
  }
}

// The records: a rub record at 2 um and a contact-free one at 0.5 um, shaft-synchronous
// without a keyphasor. Each dwell's noise is its own (a pooled estimate gives ~1.1 um for the rub
// dwells and judges them unsteady), every rub dwell is averaged with its reason, the orbit fit
// runs, and the defaults meet the targets.
std::pair<record, record> two_noise_records(unsigned seed) {
  rig_request req;
  req.variant = "identified";
  req.speeds_rpm = {1500, 1550, 1600, 1650, 1700};
  req.record_revs = 10;
  req.probes.keyphasor = false;
  req.time_base = rig_time_base::shaft;
  req.probes.noise = 2e-6;
  req.probes.seed = seed;
  rig_request free = req;
  free.speeds_rpm = {1100, 1150, 1200, 1250, 1300};
  free.probes.noise = 0.5e-6;
  free.probes.seed = seed + 1000;
  return {run_rig(req).measurement, run_rig(free).measurement};
}

TEST(identification, records_of_different_noise_each_their_own) {
  const parameters truth;
  constexpr double kK1Tol = 0.05, kC2Tol = 0.2, kMuTol = 0.01;  // the targets
  constexpr double kNoiseTol = 0.05;  // the 4th differences' sampling error at 2 x ~4000 samples is ~2 %
  const auto [rub, free] = two_noise_records(7);
  const identification id = identify({{rub, "rub.csv"}, {free, "free.csv"}}, identify_settings{});
  ASSERT_EQ(id.dwells.size(), 5u);
  for (const auto& d : id.dwells) {
    EXPECT_NEAR(d.noise.sigma / 2e-6, 1.0, kNoiseTol) << d.rpm;
    EXPECT_EQ(d.averaging.rfind("averaged: ", 0), 0u) << d.averaging;
    EXPECT_GE(d.averaged_revolutions, 9) << d.rpm;
  }
  ASSERT_EQ(id.free_noise.size(), 5u);
  for (const auto& n : id.free_noise) EXPECT_NEAR(n.sigma / 0.5e-6, 1.0, kNoiseTol);
  ASSERT_TRUE(id.orbit);
  EXPECT_TRUE(id.orbit->converged) << id.orbit->status;
  EXPECT_EQ(kept_names(id), (std::vector<std::string>{"z1", "zd2"})) << reason_of(id);
  EXPECT_NEAR(estimate_of(id, "z1")->value / truth.k1, 1.0, kK1Tol);
  EXPECT_NEAR(estimate_of(id, "zd2")->value / truth.c2, 1.0, kC2Tol);
  EXPECT_NEAR(id.mu, truth.mu, kMuTol);
  EXPECT_TRUE(id.warnings.empty()) << id.warnings.front();
}

// Times not on one shaft angle (an acquisition clock without a keyphasor, against
// docs/data-format.md): every dwell of both records shifted by a seeded fraction of its period.
// The contact-free dwells' one-phase test finds it (chi^2 ~1e8 against a limit of ~26 here), they
// and the rub dwells are re-timed and the orbit fit searches each cycle's phase: the estimates are
// those of the unshifted records within the targets. Unshifted, the test passes.
TEST(identification, times_not_on_one_shaft_angle_are_found_and_put_on_one) {
  const parameters truth;
  constexpr double kK1Tol = 0.05, kC2Tol = 0.2, kMuTol = 0.01;  // the targets
  auto [rub, free] = two_noise_records(7);
  if (!kSanitized) {  // release builds: the unshifted records pass the test (records_of_different_noise runs them sanitized)
    const identification plain = identify({{rub, "rub.csv"}, {free, "free.csv"}}, identify_settings{});
    ASSERT_TRUE(plain.linear_fitted);
    EXPECT_LE(plain.linear_fitted->phase_chi2, plain.linear_fitted->phase_limit);
  }
  std::mt19937_64 rng(11);
  for (record* r : {&rub, &free}) {
    auto& t = r->data[0];
    const auto& rpm = r->data[3];
    double shift = 0.0;
    for (std::size_t i = 0; i < t.size(); ++i) {
      if (i == 0 || rpm[i] != rpm[i - 1]) shift = std::uniform_real_distribution<double>(0.0, 60.0 / rpm[i])(rng);
      t[i] += shift;
    }
  }
  const identification id = identify({{rub, "rub.csv"}, {free, "free.csv"}}, identify_settings{});
  ASSERT_TRUE(id.linear_fitted);
  EXPECT_TRUE(std::any_of(id.notes.begin(), id.notes.end(), [](const std::string& n) { return n.rfind("linear part: the contact-free dwells' 1X phases disagreed", 0) == 0; }));
  EXPECT_LE(id.linear_fitted->phase_chi2, id.linear_fitted->phase_limit);  // after re-timing
  EXPECT_TRUE(std::any_of(id.notes.begin(), id.notes.end(), [](const std::string& n) { return n.rfind("the dwells in contact were put on the shaft angles the orbit fit found", 0) == 0; }));
  EXPECT_NEAR(id.linear.c_y / truth.c_y, 1.0, 0.02);  // c from amplitudes and x-y phases: measured -0.5 %
  EXPECT_EQ(kept_names(id), (std::vector<std::string>{"z1", "zd2"})) << reason_of(id);
  EXPECT_NEAR(estimate_of(id, "z1")->value / truth.k1, 1.0, kK1Tol);
  EXPECT_NEAR(estimate_of(id, "zd2")->value / truth.c2, 1.0, kC2Tol);
  EXPECT_NEAR(id.mu, truth.mu, kMuTol);
}

// Structure by the orbits: on the three-term law of all_three_terms_when_each_matters, noise-free,
// the weak form's significance test keeps {z, z_dot^2} (k1 then +26 %); the orbit fit's BIC
// chooses {z, z^3, z_dot^2}, decisively, with every value within 1 %.
TEST(identification, orbits_choose_the_structure_the_weak_form_misses) {
  if (kSanitized) GTEST_SKIP() << "release builds only: the structure comparison runs sanitized in records_of_different_noise_each_their_own";
  parameters p;
  p.k1 = 1e6;
  p.k3 = 1e15;
  const identification id = identify({{simulated("identified", p, 1024), "three.csv"}}, knowing(p));
  EXPECT_EQ(id.law_route, law_method::weak_form);
  std::vector<std::string> weak;
  for (const auto& e : id.weak_estimates) weak.push_back(e.name);
  EXPECT_EQ(kept_names(id), (std::vector<std::string>{"z1", "z3", "zd2"})) << reason_of(id);
  EXPECT_TRUE(id.structure && id.structure->rival.empty()) << reason_of(id);
  EXPECT_TRUE(std::any_of(id.notes.begin(), id.notes.end(), [](const std::string& n) { return n.rfind("structure: the orbit fit chose", 0) == 0; }));
  ASSERT_GE(id.structures.size(), 2u);
  EXPECT_LT(id.structures[0].bic, id.structures[1].bic);
  constexpr double kThreeTermTol = 0.01;  // the 1 %
  EXPECT_NEAR(estimate_of(id, "z1")->value / p.k1, 1.0, kThreeTermTol);
  EXPECT_NEAR(estimate_of(id, "z3")->value / p.k3, 1.0, kThreeTermTol);
  EXPECT_NEAR(estimate_of(id, "zd2")->value / p.c2, 1.0, kThreeTermTol);
}

// The orbit fit can be turned off: the weak form's estimates are then reported as they are.
TEST(identification, weak_form_alone_without_the_orbit_fit) {
  const auto [rub, free] = rig_records("identified", 0.5e-6, 2);
  identify_settings s;
  s.orbit_fit = false;
  const identification id = identify({{rub, "rub.csv"}, {free, "free.csv"}}, s);
  EXPECT_FALSE(id.orbit);
  EXPECT_EQ(kept_names(id), (std::vector<std::string>{"z1", "zd2"}));
  const auto* k1 = estimate_of(id, "z1");
  EXPECT_NEAR(k1->value / parameters{}.k1, 1.0, 0.05);  // the weak form's own spread is ~1 % here
}

// A library without the law's z_dot^2: the weak form's residual test names the gap (at 0.5 um the
// residual is ~30x what the noise leaves, measured; the limit is ~2x).
TEST(identification, weak_form_residual_test_flags_a_missing_term) {
  const auto [rub, free] = rig_records("identified", 0.5e-6, 1);
  identify_settings s;
  s.library = "z1,z2,z3";
  const identification id = identify({{rub, "rub.csv"}, {free, "free.csv"}}, s);
  ASSERT_TRUE(id.weak);
  EXPECT_GT(id.weak->chi2_per_dof, id.weak->chi2_limit);
  EXPECT_TRUE(std::any_of(id.warnings.begin(), id.warnings.end(), [](const std::string& w) { return w.rfind("weak form: the residual", 0) == 0; }));
}

// The piecewise-linear law at 0.5 um: z alone.
TEST(identification, weak_form_piecewise_linear_gives_z_alone) {
  if (kSanitized) GTEST_SKIP() << "release builds only: its orbit fits are ~10x slower sanitized, and records_of_different_noise_each_their_own runs the same code there";
  const parameters truth;
  const auto [rub, free] = rig_records("piecewise-linear", 0.5e-6, 7);
  const identification id = identify({{rub, "rub.csv"}, {free, "free.csv"}}, identify_settings{});
  EXPECT_EQ(id.law_route, law_method::weak_form);
  EXPECT_EQ(kept_names(id), std::vector<std::string>{"z1"});
  if (const auto* k1 = estimate_of(id, "z1")) {
    EXPECT_NEAR(k1->value / truth.k1, 1.0, 0.05);  // the target (measured within 1 %)
  }
}

// Noise-free records of `rubref simulate` keep the paper's route (Table 1's ERRs are per sample).
// Automatic: the weak form wherever its rows rank the library (even on a noise-free record,
// where the orbits then choose {z, z_dot^2} among Eq. 5's family), the samples where they cannot
// (one revolution of one dwell: one contact episode, 6 rows for 8 terms), each with its reason.
TEST(identification, automatic_route_is_the_weak_form_where_its_rows_rank_the_library) {
  if (kSanitized) GTEST_SKIP() << "release builds only: its orbit fits are ~10x slower sanitized, and records_of_different_noise_each_their_own runs the same code there";
  const parameters paper;
  const identification clean = identify({{simulated("identified", paper, 1024), "identified.csv"}}, knowing(paper));
  EXPECT_EQ(clean.law_route, law_method::weak_form) << clean.law_route_reason;
  EXPECT_NE(clean.law_route_reason.find("rank the library"), std::string::npos) << clean.law_route_reason;
  EXPECT_EQ(kept_names(clean), (std::vector<std::string>{"z1", "zd2"})) << reason_of(clean);
  ASSERT_FALSE(clean.structures.empty());
  EXPECT_TRUE(clean.structure && clean.structure->rival.empty()) << reason_of(clean);
  record short_record = simulated("identified", paper, 1024, 1600, 1600, 50, 6);
  for (auto& column : short_record.data) column.resize(1024);  // one revolution
  const identification one = identify({{short_record, "one.csv"}}, knowing(paper));
  EXPECT_EQ(one.law_route, law_method::samples) << one.law_route_reason;
  EXPECT_NE(one.law_route_reason.find("cannot rank"), std::string::npos) << one.law_route_reason;
  EXPECT_FALSE(one.weak);
}

}  // namespace
}  // namespace rubref
