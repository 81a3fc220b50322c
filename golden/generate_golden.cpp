// Makes the golden files (docs/validation.md, "Golden files"). Nobody edits them by hand; they
// are made here, with the careful method of ref/validation/golden.hpp, and only on purpose:
//
//   RUBREF_REGENERATE_GOLDEN=1 build/golden/generate_golden [DIR]     (default: the source golden/)
//
// Review the data diff in its own commit. Without the switch the tool refuses and writes nothing.

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <string>

#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/validation/golden.hpp"

namespace {

std::string today_utc() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[16];
  std::strftime(buf, sizeof buf, "%Y-%m-%d", &tm);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace rubref;
  const char* on = std::getenv("RUBREF_REGENERATE_GOLDEN");
  if (!on || std::string(on) != "1") {
    std::cerr << "generate_golden: refusing to overwrite the golden files; set RUBREF_REGENERATE_GOLDEN=1 to regenerate them\n";
    return 2;
  }
  const std::filesystem::path dir = argc > 1 ? argv[1] : RUBREF_GOLDEN_DIR;
  if (!std::filesystem::is_directory(dir)) {
    std::cerr << "generate_golden: " << dir.string() << " is not a directory\n";
    return 2;
  }
  try {
    const auto specs = golden_matrix();
    const std::string date = today_utc();
    std::vector<std::string> files(specs.size());
    std::vector<record> records(specs.size());
    parallel_for(specs.size(), 0, [&](std::size_t i) { records[i] = make_golden(specs[i], date); });
    atomic_output out;
    for (std::size_t i = 0; i < specs.size(); ++i) {
      const std::string name = golden_file_name(specs[i]);
      out.stage(dir / name, to_csv(records[i], number_format::significant_17));
      const record& r = records[i];
      std::cout << name << ": " << *r.find("comparison") << ", period " << *r.find("period_revs") << " rev, cross-check "
                << *r.find("cross_check_max_difference_m") << " m";
      if (const std::string* tol = r.find("tolerance_orbit_m")) std::cout << ", tolerance " << *tol << " m";
      std::cout << ", " << *r.find("coexisting_attractors") << " coexisting attractor(s)";
      std::cout << "\n";
    }
    out.commit();
    std::cout << "wrote " << specs.size() << " golden files to " << dir.string() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "generate_golden: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
