#include "ref/model/settings.hpp"

#include <cmath>
#include <sstream>

#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"

namespace rubref {

std::string describe(const valid_range& r) {
  const bool has_lo = std::isfinite(r.lo), has_hi = std::isfinite(r.hi);
  std::string out = r.integer ? "a whole number " : "";
  const auto number = [](double v) { return format_number(v); };
  if (has_lo && has_hi)
    out += std::string("in ") + (r.lo_open ? "(" : "[") + number(r.lo) + ", " + number(r.hi) + (r.hi_open ? ")" : "]");
  else if (has_lo)
    out += (r.lo_open ? "> " : ">= ") + number(r.lo);
  else if (has_hi)
    out += (r.hi_open ? "< " : "<= ") + number(r.hi);
  else
    out += r.integer ? "" : "any real";
  if (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

namespace {
bool within(const valid_range& r, double v) {
  if (!std::isfinite(v)) return false;
  if (r.integer && v != std::floor(v)) return false;
  if (r.lo_open ? !(v > r.lo) : !(v >= r.lo)) return false;
  if (r.hi_open ? !(v < r.hi) : !(v <= r.hi)) return false;
  return true;
}
}  // namespace

std::string violation(const setting_info& s, double v, std::string_view named_as) {
  if (within(s.range, v)) return {};
  std::ostringstream msg;
  msg.precision(17);
  const std::string rule = describe(s.range);
  msg << (named_as.empty() ? setting(s.name) : std::string(named_as)) << " must be ";
  if (s.range.integer)
    msg << rule;  // a whole number is finite
  else
    msg << "finite" << (rule == "any real" ? "" : " and " + rule);
  if (!s.unit.empty() && s.unit != "-") msg << " " << s.unit;
  msg << " (got " << v << "): " << s.reason;
  return msg.str();
}

void check(setting_key key, double v) {
  if (std::string why = violation(*key.row, v); !why.empty()) throw input_error(why);
}

const setting_info* setting_with_name(std::string_view name) {
  for (const auto& s : settings_registry)
    if (s.name == name) return &s;
  return nullptr;
}

}  // namespace rubref
