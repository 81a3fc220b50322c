// libFuzzer target: the order-tracked table reader on arbitrary bytes (tests/fuzz/untrusted_input.hpp).
#include <cstddef>
#include <cstdint>

#include "tests/fuzz/untrusted_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  rubref::fuzz::order_table_file(std::string_view(reinterpret_cast<const char*>(data), size));
  return 0;
}
