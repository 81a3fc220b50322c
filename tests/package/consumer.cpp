// Uses the installed library through its one public include: a contact-free run of the paper's
// rotor must land on the closed-form unbalance response (Eq. 1 without contact is linear), and a
// run at a small clearance must rub. Exit 0 when both hold.
#include <rubref/rubref.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

int main() {
  rubref::run_request free_run;
  free_run.variant = "identified";
  free_run.params.clearance = 1.0;  // m: far above any orbit, so never touched
  free_run.rpm = 1200.0;
  const rubref::orbit o = rubref::simulate(free_run);
  const rubref::unbalance_response exact(free_run.params, free_run.rpm * 2.0 * std::numbers::pi / 60.0);
  double worst = 0.0, size = 0.0;
  for (const auto& s : o.samples) {
    const auto e = exact.at(s.t);
    worst = std::max({worst, std::abs(s.s[0] - e[0]), std::abs(s.s[1] - e[1])});
    size = std::max(size, std::hypot(e[0], e[1]));
  }
  // 200 settling revolutions at the paper's damping leave ~1e-9 of the transient; the stepper's
  // tolerance adds less.
  constexpr double kSettledRel = 1e-6;
  std::printf("rubref %s: contact-free orbit within %.2e of the closed form (orbit size %.3e m)\n",
              std::string(rubref::version()).c_str(), worst / size, size);
  if (!(worst <= kSettledRel * size)) return 1;

  rubref::run_request rub = free_run;
  rub.params.clearance = 0.2e-3;
  rub.rpm = 1600.0;
  const rubref::orbit_summary s = rubref::summarize(rubref::simulate(rub));
  std::printf("at 0.2 mm and 1600 rpm: %s, peak normal force %.1f N\n", std::string(rubref::to_string(s.regime)).c_str(), s.max_normal_force);
  return s.regime != rubref::contact_regime::no_contact && s.max_normal_force > 0.0 ? 0 : 1;
}
