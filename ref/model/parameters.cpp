#include "ref/model/parameters.hpp"

#include <string>
#include <vector>

#include "ref/base/errors.hpp"

namespace rubref {

std::string violation(const parameter_info& info, double v) {
  return violation(*info.row, v, "parameter " + std::string(info.key));
}

void validate(const parameters& p) {
  for (const auto& info : parameter_table)
    if (const std::string why = violation(info, p.*info.member); !why.empty()) throw input_error(why);
}

double parameters::*parameter_member(std::string_view name) {
  std::string names;
  for (const auto& info : parameter_table) {
    if (info.row->name == name) return info.member;
    names += (names.empty() ? "" : ", ") + std::string(info.row->name);
  }
  std::vector<std::string> candidates;
  for (const auto& info : parameter_table) candidates.emplace_back(info.row->name);
  throw input_error("unknown parameter '" + std::string(name) + "'" + did_you_mean(name, candidates) + " (" + names + ")");
}

}  // namespace rubref
