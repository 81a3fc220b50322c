#pragma once
// The inverse of `setting` (ref/base/errors.hpp): a front end spells each `field` of a library
// message its own way (the CLI as a flag, Python as a keyword argument).

#include <string>
#include <string_view>

namespace rubref {

// `message` with every `field` replaced by spell(field).
template <class Spell>
std::string spell_settings(std::string_view message, Spell&& spell) {
  std::string out;
  for (std::size_t i = 0; i < message.size();) {
    const std::size_t open = message.find('`', i), close = open == std::string_view::npos ? open : message.find('`', open + 1);
    if (close == std::string_view::npos) {
      out += message.substr(i);
      break;
    }
    out += message.substr(i, open - i);
    out += spell(message.substr(open + 1, close - open - 1));
    i = close + 1;
  }
  return out;
}

}  // namespace rubref
