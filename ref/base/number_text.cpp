#include "ref/base/number_text.hpp"

#include <charconv>
#include <cstdio>

namespace rubref {

std::string format_number(double v) {
  char buf[64];
  const auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, ptr);
}

std::string format_number_17(double v) {
  char buf[64];
  const auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::scientific, 16);
  return std::string(buf, ptr);
}

std::string format_digits(double v, int digits) {
  char buf[64];
  const auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, digits);
  return std::string(buf, ptr);
}

std::string format_fixed(double v, int decimals) {
  char buf[400];  // %.*f of 1e308 with a few decimals
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace rubref
