#pragma once
// The effect library (docs/loop.md): physical effects a real rotor kit has and the paper's model
// (Eq. 1-5) lacks. The virtual rig's truth model carries any set of them; the loop searches the
// same library for the one a residual points to. Every parameter is SI; an effect whose
// parameters are all at their `off` values is absent, and the model is then the paper's.

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace rubref {

// Every effect's parameters in one value type (a model carries all, most of them off). Shape
// parameters (exponents, masses, dampers, decay speeds) default to the library's typical values:
// where the virtual rig puts them unless told, and where the loop's fit of them starts.
struct effect_parameters {
  // hertz_contact: extra normal force k_h z^1.5 (Hertz point contact).
  double hertz_k = 0.0;  // N/m^1.5
  // hunt_crossley_damping: extra normal force lambda z^p z_dot (Hunt & Crossley 1975).
  double hc_lambda = 0.0;  // N s / m^(p+1)
  double hc_exponent = 1.5;  // -
  // contact_angle: the protrusion at angle theta from the top, towards +x; the contact normal is
  // (sin theta, cos theta) and the friction acts along (cos theta, -sin theta).
  double contact_angle = 0.0;  // rad
  // preload: a constant force on the rotor (gravity, a bearing offset).
  double preload_x = 0.0, preload_y = 0.0;  // N
  // misalignment_2x: a forward 2X force F2 (cos(2wt + phi2), sin(2wt + phi2)).
  double misalignment_force = 0.0;  // N
  double misalignment_phase = 0.0;  // rad
  // shaft_bow: a rotating bow b at angle phi_b: the shaft springs push towards it,
  // (k_x b cos(wt + phi_b), k_y b sin(wt + phi_b)): 1X, not growing with speed like unbalance.
  double bow = 0.0;        // m
  double bow_phase = 0.0;  // rad
  // probe_runout (measurement only): each probe reads the shaft surface profile
  // a1 cos(psi + phi1) + a2 cos(2 psi + phi2) at psi = wt minus the probe's angle (x: 0, y: 90 deg).
  double runout_1x = 0.0, runout_1x_phase = 0.0;  // m, rad
  double runout_2x = 0.0, runout_2x_phase = 0.0;  // m, rad
  // probe_misorientation (measurement only): the probes' axes turned by alpha from the model's.
  double misorientation = 0.0;  // rad
  // stator_compliance: the protrusion on its own spring and damper (mass m_s) along the normal.
  double stator_k = 0.0;     // N/m; 0: rigid stator
  double stator_c = 100.0;   // N s/m
  double stator_m = 1.0;     // kg (a housing segment; a light stator under the identified law's
                             // c2 z_dot^2, which pushes apart at exit too, is driven unstable)
  // velocity_dependent_friction: mu(v) = mu + (mu_s - mu) exp(-v / v_c) at the sliding speed
  // v = R |w| - sgn(w) (tangential rotor velocity); mu_s <= mu: off.
  double mu_static = 0.0;          // -
  double slip_decay_speed = 0.5;   // m/s
  double shaft_radius = 5e-3;      // m (the RK-4 kit's 10 mm shaft)
  // cross_coupling: stiffness k_xy (x force -k_xy y) and k_yx (y force -k_yx x).
  double k_xy = 0.0, k_yx = 0.0;  // N/m

  friend bool operator==(const effect_parameters&, const effect_parameters&) = default;
};

// One parameter of an effect: where it lives, its name and unit in files, whether it switches
// the effect on (an effect is present when any switch is away from its `off` value), a moderate
// level (what the tests inject), the range a fit may search, and, for a switch, the documented
// levels: the magnitudes the loop is specified for, which the randomized campaign draws from
// (docs/loop.md; either sign where `signed_level`); for a shape, the physical range it is drawn from.
struct effect_parameter_info {
  double effect_parameters::*member;
  std::string_view key;    // e.g. "k_h"
  std::string_view unit;   // e.g. "N/m^1.5"
  bool is_switch;          // false: a shape parameter with a default (an exponent, a mass)
  double off;              // the switch's value when the effect is absent; a shape's default
  double moderate;         // a clearly visible but moderate level
  double lo, hi;           // fit bounds
  double level_lo = 0.0, level_hi = 0.0;  // documented levels of a switch's magnitude; a shape's physical range
  bool signed_level = false;              // the level may take either sign
};

// How the loop fits one parameter of an effect (docs/loop.md, "The effect library"): every
// parameter is fitted, switches first, then the shape parameters (exponents, masses, dampers,
// decay speeds), each in the chart where the orbit depends on it most simply; a phase is fitted
// through its amplitude's pair.
enum class fit_form {
  value,           // the switch itself
  polar,           // an amplitude with the phase parameter after it, as (a cos phi, a sin phi): smooth through a = 0
  compliance,      // a stiffness as its compliance 1/k (0: rigid, smooth there); with the shapes below held as
                   // ring frequency and damping ratio
  excess_over_mu,  // a friction coefficient as its excess over the model's mu (<= 0: off)
  power_coefficient,  // a coefficient lambda of z^p as its value at a reference penetration, lambda z_ref^(p - p0), p0 the
                      // exponent's default: the force at the penetrations reached hardly moves when p does
  // Shapes:
  logarithm,       // a positive parameter as its logarithm (a decay speed, a radius)
  power_exponent,  // the exponent p of a power_coefficient, moved with the force at z_ref kept
  ring_frequency,  // a compliant part's mass m as log sqrt(k/m): its ringing makes the residual a comb of dips along it,
                   // so the trace searches them (ref/loop/search.hpp)
  damping_ratio,   // its damper c as log of c / (2 sqrt(k m))
};
// How a fit_form reads in the library's listings (`rubref effects --json`, docs/loop.md).
std::string_view to_string(fit_form f);

struct effect_fit {
  std::string_view key;        // the parameter (a switch, or a shape)
  fit_form form;
  double scale;                // the search's unit: the moderate level's order of magnitude
  // Trial values where the effect enters the orbit so nonlinearly that its linearisation at
  // "off" misleads (the contact normal's angle, the probes' orientation): the trace profiles it.
  std::vector<double> trials = {};
  // Shapes only: the physical range of the coordinate's own value (not its logarithm), over
  // which the loop profiles it to say whether the records determine it.
  double range_lo = 0.0, range_hi = 0.0;
  bool is_shape() const { return range_hi > range_lo; }
};

struct effect_info {
  std::string_view name;         // e.g. "hertz_contact"
  std::string_view model;        // one line: what it does to the equations
  std::string_view reference;    // where the model comes from
  bool measurement_only;         // acts on the probes, not on the rotor
  std::vector<effect_parameter_info> parameters;
  std::vector<effect_fit> fit;   // the loop's coordinates: the switches, then the shapes
};

// The pivot of a power law's chart (fit_form::power_coefficient): the penetration at which the
// loop keeps lambda z^p when p moves, and at which the documented levels of lambda hold for any p
// (lambda z_ref^(p - p0) is the level at the default exponent p0). Contacts of the paper's rotor
// reach ~1e-6..1e-4 m.
inline constexpr double power_reference_penetration = 1e-5;  // m

// The parts of the paper's own model (Eq. 1-2) that a table's base fit leaves out and its loop
// adds as it adds effects (docs/real-data.md): support stiffnesses that differ along x and y, the
// rub itself, and the run-up's own transient (the rotor swept through its speeds, not steady at
// each). With the library's names, the names a verdict on a table uses.
inline constexpr std::string_view anisotropy_part = "anisotropy";
inline constexpr std::string_view rub_part = "rub";
inline constexpr std::string_view sweep_transient_part = "sweep_transient";

// The library, in a fixed order (docs/loop.md).
const std::vector<effect_info>& effect_library();
const effect_info& find_effect(std::string_view name);  // input_error naming the known ones

// Whether the effect is present in `p` (a switch parameter away from `off`).
bool has_effect(const effect_parameters& p, const effect_info& e);

// Parses "name" or "name:key=value,key=value" (keys of effect_parameter_info) into p: every
// parameter at its moderate level unless given; input_error naming what is wrong otherwise.
void apply_effect(effect_parameters& p, std::string_view text);

// The values of one effect's parameters, in the order of its table.
std::vector<double> effect_values(const effect_parameters& p, const effect_info& e);

}  // namespace rubref
