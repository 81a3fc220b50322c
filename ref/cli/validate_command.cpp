#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>

#include "ref/atomic_output.hpp"
#include "ref/cli/commands.hpp"
#include "ref/errors.hpp"
#include "ref/validation.hpp"

namespace rubref::cli {

namespace fs = std::filesystem;

namespace {

struct validate_state {
  std::string case_path, candidate_path, json;
};

struct pairing {
  fs::path golden, candidate;
};

// Which golden files meet which candidate files. A directory of cases validates every golden
// file that has a candidate of the same name; the others are listed as skipped.
std::vector<pairing> pair_up(const fs::path& cases, const fs::path& candidates, std::vector<std::string>& skipped) {
  if (!fs::exists(cases)) throw input_error(cases.string() + ": no such case file or directory");
  if (!fs::exists(candidates)) throw input_error(candidates.string() + ": no such candidate file or directory");
  std::vector<pairing> out;
  if (fs::is_directory(cases)) {
    if (!fs::is_directory(candidates))
      throw input_error(candidates.string() + ": with a directory of cases the candidate must be a directory of files of the same names");
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(cases))
      if (e.is_regular_file() && e.path().extension() == ".csv") files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      const fs::path c = candidates / f.filename();
      if (fs::exists(c))
        out.push_back({f, c});
      else
        skipped.push_back(f.filename().string());
    }
    if (out.empty()) throw input_error(candidates.string() + ": holds no file named like a case in " + cases.string());
  } else {
    out.push_back({cases, fs::is_directory(candidates) ? candidates / cases.filename() : candidates});
    if (!fs::exists(out.back().candidate)) throw input_error(out.back().candidate.string() + ": no such candidate file");
  }
  return out;
}

}  // namespace

void add_validate(CLI::App& app, int& exit_status) {
  auto st = std::make_shared<validate_state>();
  auto* sub = app.add_subcommand("validate",
                                 "compare another implementation's output with golden cases (docs/validation.md); exit 1 if any fails");
  sub->add_option("--case", st->case_path, "golden case file, or a directory of them (golden/)")->required();
  sub->add_option("--candidate", st->candidate_path,
                  "the other implementation's record (t_s,x_m,y_m,speed_rpm[,vx_m_s,vy_m_s]), or a directory of files named as the cases")
      ->required();
  sub->add_option("--json", st->json, "also write the results as JSON to this file");
  sub->callback([st, &exit_status] {
    std::vector<std::string> skipped;
    const auto pairs = pair_up(st->case_path, st->candidate_path, skipped);
    // Read and compare everything first: a bad file stops the command before any output.
    std::vector<validation_result> results;
    for (const auto& p : pairs) {
      const golden_case g = read_golden_case(read_record(p.golden), p.golden.filename().string());
      results.push_back(validate_candidate(g, read_record(p.candidate), p.candidate.string()));
    }
    const auto failed = std::count_if(results.begin(), results.end(), [](const validation_result& r) { return !r.pass; });
    if (!st->json.empty()) {
      nlohmann::ordered_json j;
      j["cases"] = nlohmann::ordered_json::array();
      for (const auto& r : results) j["cases"].push_back(to_json(r));
      j["skipped"] = skipped;
      j["passed"] = results.size() - static_cast<std::size_t>(failed);
      j["failed"] = failed;
      atomic_output files;
      files.stage(st->json, j.dump(2) + "\n");
      files.commit();
    }
    for (const auto& r : results) std::cout << to_text(r) << "\n";
    std::cout << "validated " << results.size() << " case(s): " << results.size() - static_cast<std::size_t>(failed) << " passed, "
              << failed << " failed";
    if (!skipped.empty()) std::cout << ", " << skipped.size() << " without a candidate (skipped)";
    std::cout << "\n";
    if (failed > 0) exit_status = 1;
  });
}

}  // namespace rubref::cli
