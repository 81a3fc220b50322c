// The fuzzers' kept inputs (tests/fuzz/corpus/<reader>/: seeds and every input that once
// crashed, hung or broke a reader's contract) replayed through the same readers in every build,
// so a fixed finding stays fixed without clang (docs/robustness.md).

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include "tests/fuzz/untrusted_input.hpp"

namespace rubref::testing {
namespace {

namespace fs = std::filesystem;

// Feeds every kept input of `reader` to `read`; a finding aborts the test binary.
void replay(const std::string& reader, const std::function<void(std::string_view)>& read) {
  const fs::path dir = fs::path(RUBREF_FUZZ_CORPUS) / reader;
  ASSERT_TRUE(fs::is_directory(dir)) << dir;
  std::size_t n = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    std::ostringstream bytes;
    bytes << in.rdbuf();
    SCOPED_TRACE(entry.path().string());
    read(bytes.str());
    ++n;
  }
  EXPECT_GT(n, 0u) << "no kept inputs for " << reader;
}

TEST(fuzz_regression, parameter_file) { replay("parameter_file", fuzz::parameter_file); }
TEST(fuzz_regression, measurement) { replay("measurement", fuzz::measurement); }
TEST(fuzz_regression, golden) { replay("golden", fuzz::golden); }
TEST(fuzz_regression, candidate) { replay("candidate", fuzz::candidate); }
TEST(fuzz_regression, order_table) { replay("order_table", fuzz::order_table_file); }

// The contract itself: a refusal is one line that names the file.
TEST(fuzz_regression, refusals_are_one_line_and_name_the_file) {
  try {
    parse_record("# format: rubref-record 1\n# note: a\rb\nt_s,x_m\n", fuzz::kSource);
    FAIL() << "accepted a header without y_m";
  } catch (const input_error& e) {
    const std::string m = e.what();
    EXPECT_TRUE(m.starts_with("input.txt:3: ")) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  // Control characters quoted from the input are replaced, so the message stays one line.
  EXPECT_EQ(std::string(input_error("a\nb\rc\x1b").what()), "a?b?c?");
}

}  // namespace
}  // namespace rubref::testing
