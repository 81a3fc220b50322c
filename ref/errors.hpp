#pragma once
// The two ways rubref refuses to produce a number: the input is wrong, or the numerics failed.
// Both carry a one-line message that names what is wrong; the CLI prints it and exits non-zero.

#include <stdexcept>
#include <string>

namespace rubref {

// Bad parameters, options, or a malformed file. Raised before any integration starts.
class input_error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
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
