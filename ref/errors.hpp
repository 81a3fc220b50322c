#pragma once
// The two ways rubref refuses to produce a number: the input is wrong, or the numerics failed.
// Both carry a one-line message that names what is wrong; the CLI prints it and exits non-zero.

#include <stdexcept>
#include <string>

namespace rubref {

// A message is one line whatever the input quoted in it holds: control characters (a newline
// or carriage return inside a value, a terminal escape) become '?'.
inline std::string one_line(std::string s) {
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return s;
}

// Bad parameters, options, or a malformed file. Raised before any integration starts.
class input_error : public std::runtime_error {
 public:
  explicit input_error(const std::string& what) : std::runtime_error(one_line(what)) {}
};

// The integration could not produce a trustworthy answer (step-size underflow, non-finite
// state, an accumulation of events that does not terminate). Never caught to return a result.
class numerical_error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws input_error(what) unless ok: the one-line check every validator is made of.
inline void require(bool ok, const std::string& what) {
  if (!ok) throw input_error(what);
}

}  // namespace rubref
