#pragma once
// Candidate terms of the normal-force law f_N(z, z_dot) (Eq. 4 and user extensions). A term is a
// product of factors z^p, z_dot^p, |z|^p, |z_dot|^p, or the constant 1.
//
// Text form (CLI --library), comma-separated: `z3` = z^3, `zd2` = z_dot^2, `z1.5` = z^1.5,
// `absz1` = |z|, `abszd1*zd1` = |z_dot| z_dot, `z1*zd1` = z z_dot, `const` = 1, and ranges
// `z1..4`, `zd1..4` (Eq. 4 with L = 4 is `z1..4,zd1..4`, the default).

#include <string>
#include <string_view>
#include <vector>

namespace rubref {

struct term_factor {
  enum class variable { z, z_dot };
  variable of;
  double power;       // z^p: integer powers keep the sign; non-integer powers need z >= 0
  bool absolute;      // |v|^p
};

class candidate_term {
 public:
  explicit candidate_term(std::vector<term_factor> factors);  // empty: the constant 1
  double operator()(double z, double z_dot) const;
  // The term unbiased for zero-mean Gaussian noise of variance var_zd on a measured z_dot: each
  // factor z_dot^p with an integer p (not |z_dot|^p) becomes sigma^p He_p(z_dot / sigma), the
  // probabilists' Hermite polynomial, whose expectation over the noise is the noise-free z_dot^p
  // (z_dot^2 -> z_dot^2 - sigma^2). Other factors are evaluated as measured. var_zd = 0: the term.
  double unbiased(double z, double z_dot, double var_zd) const;
  const std::string& name() const { return name_; }            // canonical text form, e.g. "zd2"
  std::string pretty() const;                                  // e.g. "ż²", "|ż|·ż", "z^1.5"

 private:
  std::vector<term_factor> factors_;
  std::string name_;
};

// Parses the text form; input_error naming the bad token.
std::vector<candidate_term> parse_library(std::string_view text);

// The paper's library, Eq. 4 with L = 4.
inline constexpr std::string_view kPaperLibrary = "z1..4,zd1..4";

}  // namespace rubref
