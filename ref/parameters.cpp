#include "ref/parameters.hpp"

#include <cmath>
#include <sstream>

#include "ref/errors.hpp"

namespace rubref {

std::string_view describe(constraint rule) {
  switch (rule) {
    case constraint::positive: return "> 0";
    case constraint::non_negative: return ">= 0";
    case constraint::unit_interval: return "in [0, 1]";
  }
  return "?";
}

namespace {
bool satisfies(double v, constraint rule) {
  switch (rule) {
    case constraint::positive: return v > 0.0;
    case constraint::non_negative: return v >= 0.0;
    case constraint::unit_interval: return v >= 0.0 && v <= 1.0;
  }
  return false;
}
}  // namespace

void validate(const parameters& p) {
  for (const auto& info : parameter_table) {
    const double v = p.*info.member;
    if (!std::isfinite(v) || !satisfies(v, info.rule)) {
      std::ostringstream msg;
      msg.precision(17);
      msg << "parameter " << info.key << " must be finite and " << describe(info.rule) << " (got " << v << ")";
      throw input_error(msg.str());
    }
  }
}

}  // namespace rubref
