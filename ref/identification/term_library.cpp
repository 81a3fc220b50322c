#include "ref/identification/term_library.hpp"

#include <charconv>
#include <cmath>

#include "ref/base/errors.hpp"
#include "ref/format/record.hpp"

namespace rubref {

namespace {

std::string factor_name(const term_factor& f) {
  return std::string(f.absolute ? "abs" : "") + (f.of == term_factor::variable::z ? "z" : "zd") + format_number(f.power);
}

std::string superscript(double p) {
  static const char* digits[] = {"⁰", "¹", "²", "³", "⁴", "⁵", "⁶", "⁷", "⁸", "⁹"};
  if (p == 1.0) return "";
  if (p == std::floor(p) && p >= 0 && p < 10) return digits[static_cast<int>(p)];
  return "^" + format_number(p);
}

double parse_number(std::string_view s, std::string_view token) {
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size() || !(v > 0.0) || !std::isfinite(v))
    throw input_error("library term '" + std::string(token) + "': expected a positive power after the variable");
  return v;
}

term_factor parse_factor(std::string_view f, std::string_view token) {
  term_factor out{term_factor::variable::z, 1.0, false};
  if (f.starts_with("abs")) {
    out.absolute = true;
    f.remove_prefix(3);
  }
  if (f.starts_with("zd")) {
    out.of = term_factor::variable::z_dot;
    f.remove_prefix(2);
  } else if (f.starts_with("z")) {
    f.remove_prefix(1);
  } else {
    throw input_error("library term '" + std::string(token) + "': factors are z<p>, zd<p>, absz<p>, abszd<p> or const");
  }
  out.power = parse_number(f, token);
  return out;
}

}  // namespace

candidate_term::candidate_term(std::vector<term_factor> factors) : factors_(std::move(factors)) {
  if (factors_.empty()) {
    name_ = "const";
    return;
  }
  for (std::size_t i = 0; i < factors_.size(); ++i) name_ += (i ? "*" : "") + factor_name(factors_[i]);
}

double candidate_term::operator()(double z, double z_dot) const {
  double v = 1.0;
  for (const auto& f : factors_) {
    double base = f.of == term_factor::variable::z ? z : z_dot;
    if (f.absolute) base = std::abs(base);
    v *= f.power == std::floor(f.power) ? std::pow(base, static_cast<int>(f.power)) : std::pow(base, f.power);
  }
  return v;
}

double candidate_term::unbiased(double z, double z_dot, double var_zd) const {
  double v = 1.0;
  for (const auto& f : factors_) {
    if (f.of == term_factor::variable::z_dot && !f.absolute && f.power == std::floor(f.power) && var_zd > 0.0) {
      // H_0 = 1, H_1 = v, H_{n+1} = v H_n - n sigma^2 H_{n-1}: E[H_n(v + noise)] = v^n.
      double h0 = 1.0, h1 = z_dot;
      for (int n = 1; n < static_cast<int>(f.power); ++n) {
        const double h2 = z_dot * h1 - n * var_zd * h0;
        h0 = h1;
        h1 = h2;
      }
      v *= h1;
    } else {
      double base = f.of == term_factor::variable::z ? z : z_dot;
      if (f.absolute) base = std::abs(base);
      v *= f.power == std::floor(f.power) ? std::pow(base, static_cast<int>(f.power)) : std::pow(base, f.power);
    }
  }
  return v;
}

std::string candidate_term::pretty() const {
  if (factors_.empty()) return "1";
  std::string out;
  for (std::size_t i = 0; i < factors_.size(); ++i) {
    const auto& f = factors_[i];
    const std::string v = f.of == term_factor::variable::z ? "z" : "ż";
    out += (i ? "·" : "") + (f.absolute ? "|" + v + "|" : v) + superscript(f.power);
  }
  return out;
}

std::vector<candidate_term> parse_library(std::string_view text) {
  std::vector<candidate_term> out;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    const std::string_view token = text.substr(pos, comma - pos);
    pos = comma + 1;
    if (token.empty()) throw input_error("library: empty term in '" + std::string(text) + "'");
    if (token == "const") {
      out.emplace_back(std::vector<term_factor>{});
    } else if (const auto dots = token.find(".."); dots != std::string_view::npos) {
      // A range of integer powers of one variable: z1..4, zd1..4.
      const term_factor lo = parse_factor(token.substr(0, dots), token);
      int hi = 0;
      const std::string_view hs = token.substr(dots + 2);
      const auto [ptr, ec] = std::from_chars(hs.data(), hs.data() + hs.size(), hi);
      if (ec != std::errc() || ptr != hs.data() + hs.size() || lo.power != std::floor(lo.power) || hi < lo.power || hi > 12)
        throw input_error("library range '" + std::string(token) + "': expected e.g. z1..4 (integer powers up to 12)");
      for (int p = static_cast<int>(lo.power); p <= hi; ++p) out.emplace_back(std::vector<term_factor>{{lo.of, double(p), lo.absolute}});
    } else {
      std::vector<term_factor> factors;
      std::size_t fpos = 0;
      while (fpos <= token.size()) {
        const std::size_t star = std::min(token.find('*', fpos), token.size());
        factors.push_back(parse_factor(token.substr(fpos, star - fpos), token));
        fpos = star + 1;
      }
      out.emplace_back(std::move(factors));
    }
    if (comma >= text.size()) break;
  }
  for (std::size_t i = 0; i < out.size(); ++i)
    for (std::size_t j = i + 1; j < out.size(); ++j)
      if (out[i].name() == out[j].name()) throw input_error("library: term '" + out[i].name() + "' given twice");
  return out;
}

}  // namespace rubref
