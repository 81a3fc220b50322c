#pragma once
// What `rubref validate` says when a candidate fails: causes from a fixed vocabulary
// (docs/validation.md, "Causes"), in the order of diagnosis, each confirmed or likely.
//  - confirmed: re-simulating the case with the fitted change (or applying the fitted transform
//    to the golden orbit) reproduces the candidate within the case's orbit tolerance;
//  - likely: the evidence points there (the change cuts the error at least kLikelyReduction
//    times, or a heuristic holds), but the candidate is not reproduced.

#include <array>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace rubref {

enum class cause_code {
  coverage,
  header_mismatch,
  other_attractor,
  non_periodic,
  units,
  mirrored_axis,
  rotation_sense,
  time_origin_or_unbalance_phase,
  static_offset,
  clearance,
  friction_sign,
  friction_coefficient,
  contact_law_coefficient,
  contact_law_form,
  unbalance,
  missed_events,
  coarse_step,
  none_found,
};

struct cause_info {
  cause_code code;
  std::string_view name;     // the JSON `code`
  std::string_view meaning;  // one line, for docs/validation.md and --help
};

inline constexpr std::array<cause_info, 18> cause_table{{
    {cause_code::coverage, "coverage", "the candidate spans less than one period of the case"},
    {cause_code::header_mismatch, "header_mismatch", "the candidate's own header names another variant, speed or parameter value"},
    {cause_code::other_attractor, "other_attractor", "the candidate settled on another stable orbit of the same model (another start)"},
    {cause_code::non_periodic, "non_periodic", "the candidate does not repeat where the case's orbit does (not settled, or chaotic)"},
    {cause_code::units, "units", "the candidate's displacements are in mm, um, mils or inches, not m"},
    {cause_code::mirrored_axis, "mirrored_axis", "x or y points the other way, or x and y are swapped"},
    {cause_code::rotation_sense, "rotation_sense", "the shaft or the unbalance turns clockwise (x towards -y)"},
    {cause_code::time_origin_or_unbalance_phase, "time_origin_or_unbalance_phase",
     "the candidate is the golden orbit shifted in time: another time origin or unbalance phase"},
    {cause_code::static_offset, "static_offset", "a constant offset or static load (gravity) moves the orbit"},
    {cause_code::clearance, "clearance", "another clearance delta"},
    {cause_code::friction_sign, "friction_sign", "friction on the rotor points the other way (f_x = -mu f_N)"},
    {cause_code::friction_coefficient, "friction_coefficient", "another friction coefficient mu"},
    {cause_code::contact_law_coefficient, "contact_law_coefficient", "another k1, k3, c2 or r"},
    {cause_code::contact_law_form, "contact_law_form", "another form of the contact law (e.g. c2 |z_dot| z_dot for c2 z_dot^2)"},
    {cause_code::unbalance, "unbalance", "another unbalance m e"},
    {cause_code::missed_events, "missed_events", "contact events missed or detected late (samples inside a rigid stator, "
                                                 "missing or deeper contact episodes)"},
    {cause_code::coarse_step, "coarse_step", "a fixed step too coarse for the contact: rubref's rk4 at that step reproduces it"},
    {cause_code::none_found, "none_found", "no single cause explains the difference"},
}};

std::string_view to_string(cause_code c);

enum class cause_confidence { confirmed, likely };
std::string_view to_string(cause_confidence c);

// A change cuts the RMS difference at least this many times to be called a likely cause: a
// wrong guess leaves it within a factor of ~2, a right one with the candidate's own numerical
// error on top (up to ~1e-2 of the fault's effect in the faults tested) still cuts it tenfold.
inline constexpr double kLikelyReduction = 10.0;

struct cause {
  cause_code code = cause_code::none_found;
  cause_confidence confidence = cause_confidence::likely;
  std::string detail;                                       // one line for the engineer
  nlohmann::ordered_json fitted = nlohmann::ordered_json::object();  // the fitted change, SI units
};

nlohmann::ordered_json to_json(const cause& c);

}  // namespace rubref
