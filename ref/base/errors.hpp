#pragma once
// The two ways rubref refuses to produce a number: the input is wrong, or the numerics failed.
// Both carry a one-line message that names what is wrong; the CLI prints it and exits non-zero.

#include <algorithm>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

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

// A library setting named in a message: `field`, the name of the request's field (from_rpm,
// clearance, ...). Each front end shows it in its own spelling: the command line as its flag
// (ref/cli/options.cpp, with_flags), Python as its keyword argument (python/rubref_module.cpp).
inline std::string setting(std::string_view field) { return "`" + std::string(field) + "`"; }

// "; did you mean 'x'?" for the candidate nearest `word` in edits (insertions, deletions,
// substitutions, adjacent swaps), when it is within a third of the word's length (at least 1);
// "" when none is that close. For names typed by hand: variants, effects, steppers, commands.
inline std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates) {
  const auto distance = [](std::string_view a, std::string_view b) {
    std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
    for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
    for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i)
      for (std::size_t j = 1; j <= b.size(); ++j) {
        d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
        if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
      }
    return d[a.size()][b.size()];
  };
  const std::string* best = nullptr;
  std::size_t best_d = std::max<std::size_t>(1, word.size() / 3) + 1;
  for (const auto& c : candidates)
    if (const std::size_t dist = distance(word, c); dist < best_d) best = &c, best_d = dist;
  return best ? "; did you mean '" + *best + "'?" : "";
}

// Throws input_error(what) unless ok: the one-line check every validator is made of.
inline void require(bool ok, const std::string& what) {
  if (!ok) throw input_error(what);
}

}  // namespace rubref
