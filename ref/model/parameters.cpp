#include "ref/model/parameters.hpp"

#include <cmath>
#include <sstream>

#include "ref/base/errors.hpp"

namespace rubref {

std::string_view describe(constraint rule) {
  switch (rule) {
    case constraint::positive: return "> 0";
    case constraint::non_negative: return ">= 0";
    case constraint::unit_interval: return "in [0, 1]";
    case constraint::finite: return "any real";
  }
  return "?";
}

namespace {
bool satisfies(double v, constraint rule) {
  switch (rule) {
    case constraint::positive: return v > 0.0;
    case constraint::non_negative: return v >= 0.0;
    case constraint::unit_interval: return v >= 0.0 && v <= 1.0;
    case constraint::finite: return true;  // finiteness is checked for every parameter
  }
  return false;
}
}  // namespace

std::string violation(const parameter_info& info, double v) {
  if (std::isfinite(v) && satisfies(v, info.rule)) return {};
  std::ostringstream msg;
  msg.precision(17);
  msg << "parameter " << info.key << " must be finite";
  if (info.rule != constraint::finite) msg << " and " << describe(info.rule);
  msg << " (got " << v << ")";
  return msg.str();
}

void validate(const parameters& p) {
  for (const auto& info : parameter_table)
    if (const std::string why = violation(info, p.*info.member); !why.empty()) throw input_error(why);
}

}  // namespace rubref
