// Chatter and sticking at every scale (docs/model.md, "Chatter"; issue 45): the paper's rotor
// run up from rest at random clearances 0.5 um - 1 mm, speeds 100 - 3000 rpm and unbalances
// 0.1 - 10 times the paper's e (a larger one presses the rotor on the face, where chatter ends
// in sticking), every law, with the free flight in closed form (the default) and integrated
// (dopri5). Every run ends without error at its end time, with events in time order; for the
// restitution law every impact is on approach, on the face, with |y'+| = r |y'-| and no energy
// gained, the rotor never sits above the face beyond the location bound, and stuck samples sit
// exactly on it.

#include <gtest/gtest.h>
#include <rapidcheck/gtest.h>

#include <cmath>
#include <limits>
#include <ostream>
#include <string>

#include "props/generators.hpp"
#include "props/prop_support.hpp"

namespace rubref::props {
namespace {

// A sample above the face beyond this is a missed impact. An impact is located to 1e-13 s at
// speeds below ~1 m/s (1e-13 m) and puts y on the face exactly; between impacts the free flight
// is searched so that no excursion deeper than its resolution (rounding, or the stepper's
// rtol |y| + atol with rtol 1e-10) is passed over. 1e-9 of the clearance is 10x the stepper's
// resolution at the orbit sizes met here; 1e-15 m covers the rounding of y at 0.5 um.
constexpr double kAboveFaceRel = 1e-9;
constexpr double kAboveFaceAbs = 1e-15;  // m
// The impact map is one multiplication, y'+ = -r y'-: a few ulps.
constexpr double kMapRounding = 4.0 * std::numeric_limits<double>::epsilon();
constexpr int kRevolutions = 20;  // from rest: enough to reach the face and settle into chatter

struct chatter_case {
  int variant = 0;  // index into all_variants
  double clearance = 0.0;  // m
  double rpm = 0.0;
  double e_scale = 1.0;  // of the paper's unbalance
  bool integrated = false;  // free flight by the stepper instead of in closed form
};

void showValue(const chatter_case& c, std::ostream& os) {
  os << "variant " << c.variant << ", clearance " << c.clearance << " m, " << c.rpm << " rpm, e x " << c.e_scale
     << (c.integrated ? ", free flight integrated" : ", exact free flight");
}

rc::Gen<chatter_case> chatter_cases() {
  return rc::gen::apply(
      [](int v, double clearance, double rpm, double e, bool integrated) { return chatter_case{v, clearance, rpm, e, integrated}; },
      rc::gen::inRange(0, static_cast<int>(variant_name_list().size())), log_uniform(0.5e-6, 1e-3), uniform(100.0, 3000.0),
      log_uniform(0.1, 10.0), rc::gen::arbitrary<bool>());
}

template <class Law>
void check(const chatter_case& c) {
  parameters p;
  p.clearance = c.clearance;
  p.e *= c.e_scale;
  const rotor_system<Law> model(p, rpm_to_rad_s(c.rpm));
  integration_options opt;  // the defaults: dopri5, exact free flight
  opt.exact_free_flight = !c.integrated;
  const double period = model.period(), t_end = kRevolutions * period;
  testing::trajectory tr;
  try {
    tr = testing::run(model, state_type{}, t_end, opt, {0.0, period / 512, 512 * kRevolutions});
  } catch (const std::exception& e) {
    RC_FAIL(std::string("the run failed: ") + e.what());
  }
  RC_ASSERT(tr.end.t == t_end);
  bool stuck = false;
  for (const auto& ev : tr.events) stuck = stuck || ev.kind == event_kind::stick;
  RC_CLASSIFY(!tr.events.empty(), "contact");
  RC_CLASSIFY(stuck, "sticking");
  for (std::size_t i = 1; i < tr.events.size(); ++i) RC_ASSERT(tr.events[i].t >= tr.events[i - 1].t);
  if constexpr (!compliant_law<Law>) {
    for (const auto& ev : tr.events) {
      if (ev.kind != event_kind::impact && ev.kind != event_kind::stick) continue;
      const double v = ev.approach_velocity;
      RC_ASSERT(ev.state[idx::y] == p.clearance);
      if (ev.kind == event_kind::impact) {
        if (v > 0.0) {
          RC_ASSERT(std::abs(ev.state[idx::vy] + p.r * v) <= kMapRounding * p.r * v);  // on approach
        } else {
          RC_ASSERT(ev.state[idx::vy] == 0.0);  // at rest to the flight's resolution: a touch, never a push off
        }
      } else {
        RC_ASSERT(ev.state[idx::vy] == 0.0);
      }
      // Energy never grows across an impact: the vertical kinetic energy after is r^2 (or 0)
      // times the one before, at the same position.
      RC_ASSERT(ev.state[idx::vy] * ev.state[idx::vy] <= v * v * (1.0 + kMapRounding));
    }
    for (std::size_t i = 0; i < tr.t.size(); ++i) {
      const double above = tr.s[i][idx::y] - p.clearance;
      if (!(above <= kAboveFaceRel * p.clearance + kAboveFaceAbs))
        RC_FAIL("above the face by " + std::to_string(above) + " m at t = " + std::to_string(tr.t[i]) + " s");
      if (tr.phase[i] == contact_phase::stuck) RC_ASSERT(tr.s[i][idx::y] == p.clearance);
    }
  }
}

RC_GTEST_PROP(chatter, every_law_chatters_and_sticks_without_error_at_any_scale, ()) {
  const chatter_case c = *chatter_cases();
  int index = 0;
  for_each_variant_type([&]<class Law>() {
    if (index++ == c.variant) check<Law>(c);
  });
}

}  // namespace
}  // namespace rubref::props
