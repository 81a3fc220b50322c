// The virtual rig (ref/rig/): its truth model against closed forms and the paper's model, and
// its probes against their own definitions.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <random>

#include "ref/base/errors.hpp"
#include "ref/model/closed_form.hpp"
#include "ref/rig/rig.hpp"
#include "test_support.hpp"

namespace rubref::testing {
namespace {

using rig_state = std::array<double, 6>;

// Two integrations of the same motion at rtol 1e-12: the same to ~1e-12 of the orbit.
constexpr double kSameMotionRelTol = 1e-9;
// Closed forms against rkf78 at rtol 1e-13 (the reference stepper), as tests/closed_form_test.cpp.
constexpr double kClosedFormRelTol = 1e-9;
constexpr double kNoContactClearance = 1.0;  // m: never reached

struct rig_trajectory {
  std::vector<double> t;
  std::vector<rig_state> s;
  std::vector<basic_contact_event<rig_state>> events;
  template <class System>
  void on_sample(double time, const rig_state& x, const System&) {
    t.push_back(time);
    s.push_back(x);
  }
  void on_event(const basic_contact_event<rig_state>& e) { events.push_back(e); }
};

template <class Law>
rig_trajectory run_rig_model(const rotor_with_effects<Law>& model, double t_end, const sample_grid& grid) {
  rig_trajectory out;
  integrate_hybrid(model, start_state(model, rig_state{}, 0.0), t_end, reference_options(), grid, out);
  return out;
}

// With every effect off, the truth model is the paper's model, for every compliant variant.
template <class V>
class rig_without_effects : public ::testing::Test {};
using compliant_variants = ::testing::Types<piecewise_linear, piecewise_nonlinear, identified>;
TYPED_TEST_SUITE(rig_without_effects, compliant_variants, variant_name);

TYPED_TEST(rig_without_effects, is_the_papers_model) {
  static_assert(contact_system<rotor_with_effects<TypeParam>>, "the rig's truth is a ContactSystem");
  const parameters p;
  const double omega = rpm_to_rad_s(1600.0), period = 2.0 * std::numbers::pi / omega;
  const sample_grid grid{20 * period, period / 64, 128};
  const rig_trajectory rig = run_rig_model(rotor_with_effects<TypeParam>(p, effect_parameters{}, omega), 22 * period, grid);
  const trajectory paper = run(rotor_system<TypeParam>(p, omega), state_type{}, 22 * period, reference_options(), grid);
  ASSERT_EQ(rig.s.size(), paper.s.size());
  ASSERT_EQ(rig.events.size(), paper.events.size());
  ASSERT_FALSE(paper.events.empty());
  double worst = 0.0, scale = 0.0;
  for (std::size_t i = 0; i < rig.s.size(); ++i)
    for (int c = 0; c < 2; ++c) {
      worst = std::max(worst, std::abs(rig.s[i][c] - paper.s[i][c]));
      scale = std::max(scale, std::abs(paper.s[i][c]));
    }
  EXPECT_LE(worst, kSameMotionRelTol * scale);
  for (const auto& s : rig.s) EXPECT_EQ(s[idx::w], 0.0);  // a rigid stator never moves
}

// One model (ref/model/rotor_model.hpp): Eq. 1 is written once, so with every effect off the model
// with effect terms evaluates the paper's right-hand side and Jacobian to the bit, in every phase
// and at any state, time and (signed) speed. Exact equality, not a tolerance: a second Eq. 1 that
// drifted from the first by one rounding would fail here.
TYPED_TEST(rig_without_effects, evaluates_the_papers_equations_to_the_bit) {
  const parameters p;
  std::mt19937_64 rng(20261125);
  std::uniform_real_distribution<double> pos(-4e-4, 4e-4), vel(-0.3, 0.3), time(0.0, 2.0), rpm(-2200.0, 2200.0);
  for (int trial = 0; trial < 200; ++trial) {
    const double omega = rpm_to_rad_s(rpm(rng)), t = time(rng);
    const state_type s{pos(rng), pos(rng), vel(rng), vel(rng)};
    const rig_state sw{s[0], s[1], s[2], s[3], 0.0, 0.0};
    for (const contact_phase ph : {contact_phase::free, contact_phase::contact, contact_phase::by_penetration}) {
      const rotor_system<TypeParam> paper(p, omega, ph);
      const rotor_with_effects<TypeParam> with(p, effect_parameters{}, omega, {}, ph);
      state_type d{};
      rig_state dw{};
      paper(s, d, t);
      with(sw, dw, t);
      for (std::size_t i = 0; i < 4; ++i) ASSERT_EQ(dw[i], d[i]) << "component " << i << ", trial " << trial;
      EXPECT_EQ(dw[idx::w], 0.0);
      EXPECT_EQ(dw[idx::vw], 0.0);
      EXPECT_EQ(with.contact_force(sw), paper.contact_force(s));
      EXPECT_EQ(with.penetration(sw), paper.penetration(s));
      const auto J = paper.jacobian(s);
      const auto Jw = with.jacobian(sw);
      for (std::size_t r = 0; r < 4; ++r)
        for (std::size_t c = 0; c < 4; ++c) ASSERT_EQ(Jw[6 * r + c], J[4 * r + c]) << "J(" << r << ", " << c << ")";
    }
  }
}

// Without contact the truth is linear: a bow b at phi_b is a 1X force (k_x b, k_y b) e^{j(wt + phi_b)}
// and misalignment a 2X force F2 e^{j(2wt + phi2)}; their steady responses are closed form, like
// the unbalance's (ref/model/closed_form.hpp).
TEST(rig_truth, bow_and_misalignment_have_closed_form_responses) {
  parameters p;
  p.clearance = kNoContactClearance;
  p.e = 0.0;
  effect_parameters fx;
  fx.bow = 5e-5;
  fx.bow_phase = 1.0;
  fx.misalignment_force = 5.0;
  fx.misalignment_phase = 0.7;
  const double w = rpm_to_rad_s(1500.0), period = 2.0 * std::numbers::pi / w;
  using namespace std::complex_literals;
  const auto response = [&](double k, double c, std::complex<double> force, double freq) {
    return force / std::complex<double>(k - p.m * freq * freq, c * freq);
  };
  // x(t) = Re(X1 e^{jwt} + X2 e^{2jwt}), y(t) = Re(Y1 e^{jwt} + Y2 e^{2jwt}).
  const auto X1 = response(p.k_x, p.c_x, p.k_x * fx.bow * std::exp(1i * fx.bow_phase), w);
  const auto Y1 = response(p.k_y, p.c_y, -1i * p.k_y * fx.bow * std::exp(1i * fx.bow_phase), w);
  const auto X2 = response(p.k_x, p.c_x, fx.misalignment_force * std::exp(1i * fx.misalignment_phase), 2 * w);
  const auto Y2 = response(p.k_y, p.c_y, -1i * fx.misalignment_force * std::exp(1i * fx.misalignment_phase), 2 * w);
  const double decay = 2.0 * p.m / std::min(p.c_x, p.c_y), t0 = 40 * decay;  // e^-40 of the transient left
  const rig_trajectory tr = run_rig_model(rotor_with_effects<identified>(p, fx, w), t0 + period, sample_grid{t0, period / 32, 32});
  const double scale = std::abs(X1) + std::abs(X2) + std::abs(Y1) + std::abs(Y2);
  for (std::size_t i = 0; i < tr.t.size(); ++i) {
    const std::complex<double> r1 = std::exp(1i * (w * tr.t[i])), r2 = r1 * r1;
    EXPECT_NEAR(tr.s[i][idx::x], (X1 * r1 + X2 * r2).real(), kClosedFormRelTol * scale) << "t = " << tr.t[i];
    EXPECT_NEAR(tr.s[i][idx::y], (Y1 * r1 + Y2 * r2).real(), kClosedFormRelTol * scale) << "t = " << tr.t[i];
  }
}

// A preload and cross-coupled stiffness without unbalance: the rotor settles where
// [[k_x, k_xy], [k_yx, k_y]] r = F. (The skew part (k_xy - k_yx) / 2 feeds forward whirl; it
// must stay below ~c w_n = 2400 N/m for the rotor to settle at all: 1.5e3 N/m decays at ~2/s.)
TEST(rig_truth, preload_and_cross_coupling_give_the_static_deflection) {
  parameters p;
  p.clearance = kNoContactClearance;
  p.e = 0.0;
  effect_parameters fx;
  fx.preload_x = 2.0;
  fx.preload_y = -3.0;
  fx.k_xy = 1.5e3;
  fx.k_yx = -1.5e3;
  const double det = p.k_x * p.k_y - fx.k_xy * fx.k_yx;
  const double x = (p.k_y * fx.preload_x - fx.k_xy * fx.preload_y) / det, y = (p.k_x * fx.preload_y - fx.k_yx * fx.preload_x) / det;
  const double t_end = 60 * 2.0 * p.m / std::min(p.c_x, p.c_y);
  const rig_trajectory tr = run_rig_model(rotor_with_effects<identified>(p, fx, rpm_to_rad_s(1500.0)), t_end, sample_grid{t_end, 0.0, 1});
  ASSERT_EQ(tr.s.size(), 1u);
  EXPECT_NEAR(tr.s[0][idx::x], x, kClosedFormRelTol * std::hypot(x, y));
  EXPECT_NEAR(tr.s[0][idx::y], y, kClosedFormRelTol * std::hypot(x, y));
}

// The contact normal turned by theta: contact begins where n.(x, y) = delta, and the penetration
// and the law follow that direction.
TEST(rig_truth, contact_angle_turns_the_contact_normal) {
  parameters p;
  effect_parameters fx;
  fx.contact_angle = 0.3;
  const rotor_with_effects<identified> model(p, fx, rpm_to_rad_s(1600.0));
  const double period = model.period();
  const rig_trajectory tr = run_rig_model(model, 30 * period, sample_grid{});
  ASSERT_FALSE(tr.events.empty());
  const double nx = std::sin(0.3), ny = std::cos(0.3);
  constexpr double kLocated = 1e-12;  // m: events are located to |z| <= 1e-12 m (docs/model.md)
  for (const auto& e : tr.events) EXPECT_NEAR(nx * e.state[idx::x] + ny * e.state[idx::y], p.clearance, kLocated);
  // The law along the normal: z = 10 um inside, moving in at 0.05 m/s.
  const double z = 1e-5, zd = 0.05;
  rig_state s{};
  s[idx::x] = nx * (p.clearance + z);
  s[idx::y] = ny * (p.clearance + z);
  s[idx::vx] = nx * zd;
  s[idx::vy] = ny * zd;
  EXPECT_NEAR(model.with_phase(contact_phase::contact).contact_force(s), identified::from(p).normal_force(z, zd), 1e-9);
}

// Hertz and Hunt-Crossley add their terms to the law; friction falls with the sliding speed.
TEST(rig_truth, contact_effects_add_their_forces) {
  parameters p;
  effect_parameters fx;
  fx.hertz_k = 3e8;
  fx.hc_lambda = 5e9;
  fx.hc_exponent = 1.5;
  fx.mu_static = 0.6;
  fx.slip_decay_speed = 0.5;
  fx.shaft_radius = 5e-3;
  const double omega = rpm_to_rad_s(1600.0);
  const rotor_with_effects<identified> model(p, fx, omega, {}, contact_phase::contact);
  const double z = 1e-5, zd = -0.03, vx = -0.1;
  const rig_state s{vx * 0.0, p.clearance + z, vx, zd, 0.0, 0.0};
  const double want = identified::from(p).normal_force(z, zd) + fx.hertz_k * std::pow(z, 1.5) + fx.hc_lambda * std::pow(z, 1.5) * zd;
  EXPECT_NEAR(model.contact_force(s), want, 1e-12 * std::abs(want));
  const double slip = fx.shaft_radius * omega - vx;  // the top moves to -x at R w; the rotor at vx
  EXPECT_NEAR(model.friction_coefficient(s), p.mu + (fx.mu_static - p.mu) * std::exp(-slip / fx.slip_decay_speed), 1e-15);
}

// A compliant stator gives way: in contact the protrusion moves out (and a stator never touched
// stays at rest, checked above); as it stiffens, the orbit tends to the rigid stator's, at first
// order in 1 / k_s (the spring in series adds ~f_N / k_s to the penetration).
TEST(rig_truth, compliant_stator_moves_and_stiffens_to_the_rigid_one) {
  const parameters p;
  const double omega = rpm_to_rad_s(1600.0), period = 2.0 * std::numbers::pi / omega;
  const sample_grid grid{20 * period, period / 256, 512};
  const auto orbit = [&](double k_s) {
    effect_parameters fx;
    fx.stator_k = k_s;
    fx.stator_m = 1.0;
    fx.stator_c = std::sqrt(k_s * fx.stator_m);  // damping ratio 1/2: rings down between contacts
    return run_rig_model(rotor_with_effects<piecewise_nonlinear>(p, fx, omega), 22 * period, grid);
  };
  const rig_trajectory rigid = orbit(0.0), soft = orbit(1e9), stiff = orbit(1e10);
  const auto distance = [&](const rig_trajectory& a) {
    double d = 0.0;
    for (std::size_t i = 0; i < a.s.size(); ++i)
      d = std::max(d, std::hypot(a.s[i][idx::x] - rigid.s[i][idx::x], a.s[i][idx::y] - rigid.s[i][idx::y]));
    return d;
  };
  double w_max = 0.0;
  for (const auto& s : soft.s) w_max = std::max(w_max, s[idx::w]);
  EXPECT_GT(w_max, 1e-8);  // f_N ~ 100 N on 1e9 N/m: ~0.1 um
  ASSERT_EQ(soft.s.size(), rigid.s.size());
  const double ratio = distance(soft) / distance(stiff);
  // First order: a tenfold stiffer stator, a tenfold smaller difference (measured: 7.3 from 1e7
  // to 1e8 N/m, 4.1 from 1e8 to 1e9 where the stator's own dynamics still show, 8.5 and 9.6 from
  // 1e9 to 1e10 and 1e10 to 1e11); the band allows for what remains of those dynamics.
  EXPECT_GT(ratio, 5.0);
  EXPECT_LT(ratio, 20.0);
}

rig_request quiet_rig() {
  rig_request req;
  req.speeds_rpm = {1600.0};
  req.settle_revs = 50;
  req.record_revs = 4;
  req.probes.noise = 0.0;
  req.probes.quantisation = 0.0;
  return req;
}

// The probes: misorientation turns, runout adds the surface profile, one keyphasor pulse a
// revolution, noise of the set size, quantisation on its grid, the same seed the same bits.
TEST(rig_probes, measure_what_they_are_defined_to) {
  const rig_request clean = quiet_rig();
  const rig_output a = run_rig(clean);
  rig_request turned = clean;
  turned.effects.misorientation = 0.1;
  turned.effects.runout_1x = 5e-6;
  turned.effects.runout_1x_phase = 0.5;
  turned.effects.runout_2x = 3e-6;
  turned.effects.runout_2x_phase = 1.2;
  const rig_output b = run_rig(turned);
  const auto& x = a.measurement.column("x_m");
  const auto& y = a.measurement.column("y_m");
  const auto& kp = a.measurement.column("keyphasor");
  const auto& t = a.measurement.column("t_s");
  const double w = rpm_to_rad_s(1600.0), t0 = clean.settle_revs * 2.0 * std::numbers::pi / w;
  const auto runout = [&](double psi) { return 5e-6 * std::cos(psi + 0.5) + 3e-6 * std::cos(2 * psi + 1.2); };
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double psi = w * (t0 + t[i]);
    EXPECT_NEAR(b.measurement.column("x_m")[i], std::cos(0.1) * x[i] + std::sin(0.1) * y[i] + runout(psi), 1e-15);
    EXPECT_NEAR(b.measurement.column("y_m")[i], -std::sin(0.1) * x[i] + std::cos(0.1) * y[i] + runout(psi - std::numbers::pi / 2), 1e-15);
  }
  double pulses = 0.0;
  for (const double k : kp) pulses += k;
  EXPECT_NEAR(pulses, clean.record_revs, 1.0);  // one a revolution (the first may fall outside)
  // A pulse is the first sample at or after a whole turn: the angle past it is in [0, w dt).
  for (std::size_t i = 0; i < kp.size(); ++i)
    if (kp[i] == 1.0) {
      const double past = std::remainder(w * (t0 + t[i]), 2.0 * std::numbers::pi);
      EXPECT_GT(past, -1e-9);
      EXPECT_LT(past, w / clean.probes.sample_rate + 1e-9);
    }

  rig_request noisy = clean;
  noisy.probes.noise = 1e-6;
  const rig_output n1 = run_rig(noisy), n2 = run_rig(noisy);
  EXPECT_EQ(n1.measurement.column("x_m"), n2.measurement.column("x_m"));  // same seed, same bits
  double sum = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) sum += std::pow(n1.measurement.column("x_m")[i] - x[i], 2);
  constexpr double kNoiseStdTol = 0.05;  // ~2000 samples: the sample standard deviation is good to ~3 %
  EXPECT_NEAR(std::sqrt(sum / static_cast<double>(x.size())), 1e-6, kNoiseStdTol * 1e-6);

  rig_request coarse = clean;
  coarse.probes.quantisation = 1e-6;
  const rig_output quantised = run_rig(coarse);  // kept: a range-for over run_rig(...).column() read freed memory (ASan)
  for (const double v : quantised.measurement.column("y_m")) EXPECT_NEAR(v / 1e-6, std::round(v / 1e-6), 1e-6);
}

// The record tells what a lab would write down, and nothing of the effects; the truth file does.
TEST(rig_output, states_clearance_and_rate_but_not_the_effects) {
  rig_request req = quiet_rig();
  apply_effect(req.effects, "hertz_contact:k_h=1e9");
  const rig_output o = run_rig(req);
  EXPECT_EQ(o.measurement.number("clearance_m"), req.params.clearance);
  EXPECT_EQ(o.measurement.number("sample_rate_hz"), 1e4);
  for (const auto& [key, value] : o.measurement.metadata) {
    EXPECT_EQ(key.find("hertz"), std::string::npos) << key;
    EXPECT_EQ(value.find("hertz"), std::string::npos) << value;
  }
  ASSERT_EQ(o.truth["effects"].size(), 1u);
  EXPECT_EQ(o.truth["effects"][0]["name"], "hertz_contact");
  EXPECT_EQ(o.truth["effects"][0]["params"]["k_h"], 1e9);
}

// Records of the kind another lab or code writes: no keyphasor, shaft-synchronous time, only the
// three metadata lines rubref reads, and dwells that settle from the previous one (a run-up).
TEST(rig_output, writes_records_as_from_elsewhere) {
  rig_request req = quiet_rig();
  req.params.clearance = 0.01;  // no contact: one attractor, so run-up and from-rest orbits agree
  req.speeds_rpm = {1200.0, 1500.0, 1650.0};
  req.settle_revs = 60;
  const rig_output from_rest = run_rig(req);
  req.probes.keyphasor = false;
  req.time_base = rig_time_base::shaft;
  req.carry_over = true;
  req.minimal_header = true;
  const rig_output o = run_rig(req);
  std::vector<std::string> keys;
  for (const auto& [key, value] : o.measurement.metadata) keys.push_back(key);
  EXPECT_EQ(keys, (std::vector<std::string>{"description", "clearance_m", "sample_rate_hz"}));
  EXPECT_EQ(std::find(o.measurement.columns.begin(), o.measurement.columns.end(), "keyphasor"), o.measurement.columns.end());
  const auto& t = o.measurement.column("t_s");
  const auto& rpm = o.measurement.column("speed_rpm");
  const auto& y = o.measurement.column("y_m");
  const auto& y_rest = from_rest.measurement.column("y_m");
  ASSERT_EQ(t.size(), y_rest.size());
  // Shaft-synchronous: the shaft angle w t_s of sample j of a dwell is w (settle + j dt) up to
  // whole turns; time still increases across the file.
  const double dt = 1.0 / req.probes.sample_rate;
  std::size_t j = 0;
  for (std::size_t i = 0; i < t.size(); ++i, ++j) {
    if (i > 0) {
      EXPECT_GT(t[i], t[i - 1]);
      if (rpm[i] != rpm[i - 1]) j = 0;
    }
    const double period = 60.0 / rpm[i];
    constexpr double kAngleTol = 1e-9;  // rad: rounding of t_s ~ 1e-15 s times w ~ 170 rad/s, with room
    const double turns = (t[i] - (req.settle_revs * period + static_cast<double>(j) * dt)) / period;
    EXPECT_NEAR(2.0 * std::numbers::pi * (turns - std::round(turns)), 0.0, kAngleTol) << i;
    // The first dwell starts from rest in both; later ones from the previous orbit. What is
    // left of the start after the settle revolutions decays as exp(-c t / 2m) from at most the
    // orbits' size (< 1 mm here): ~7 nm at 1500 rpm, 60 revolutions.
    const double decay = std::exp(-std::min(req.params.c_x, req.params.c_y) / (2.0 * req.params.m) * req.settle_revs * period);
    const double kSettledTol = 1e-3 * decay;  // m
    EXPECT_NEAR(y[i], y_rest[i], kSettledTol) << i;
  }
  EXPECT_EQ(o.truth["time_base"], "shaft");
  EXPECT_EQ(o.truth["carry_over"], true);
}

TEST(rig_input, bad_settings_are_named) {
  const auto rejects = [](auto&& mutate, const char* what) {
    rig_request req = quiet_rig();
    mutate(req);
    try {
      run_rig(req);
      ADD_FAILURE() << "accepted: " << what;
    } catch (const input_error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  rejects([](rig_request& r) { r.variant = "restitution"; }, "impact map");
  rejects([](rig_request& r) { r.speeds_rpm = {}; }, "at least one speed");
  rejects([](rig_request& r) { r.probes.noise = -1.0; }, "`noise` must be finite and >= 0");
  rejects([](rig_request& r) { r.effects.hertz_k = -1.0; }, "hertz_contact");
  rejects([](rig_request& r) { r.params.m = 0.0; }, "m_kg");
  rejects([](rig_request& r) { r.probes.keyphasor = false; }, "shaft-synchronous");
  effect_parameters p;
  EXPECT_THROW(apply_effect(p, "gravity_waves"), input_error);
  EXPECT_THROW(apply_effect(p, "hertz_contact:k=3"), input_error);
  EXPECT_THROW(apply_effect(p, "hertz_contact:k_h=abc"), input_error);
  EXPECT_THROW(apply_effect(p, "hertz_contact:k_h=1e20"), input_error);
}

}  // namespace
}  // namespace rubref::testing
