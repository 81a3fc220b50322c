// libFuzzer target: the candidate reader on arbitrary bytes (tests/fuzz/untrusted_input.hpp).
#include <cstddef>
#include <cstdint>

#include "tests/fuzz/untrusted_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  rubref::fuzz::candidate(std::string_view(reinterpret_cast<const char*>(data), size));
  return 0;
}
