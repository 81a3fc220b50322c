#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

#include "ref/base/errors.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/validation/validate.hpp"

namespace rubref::cli {

namespace fs = std::filesystem;

namespace {

struct validate_state {
  std::string case_path, candidate_path, json;
  bool strict = false;
};

struct pairing {
  fs::path golden, candidate;
};

struct batch {
  std::vector<pairing> pairs;
  std::vector<std::string> skipped;    // cases without a candidate file
  std::vector<std::string> unmatched;  // candidate files named like no case
};

std::vector<fs::path> csv_files(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() == ".csv") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

// Which golden files meet which candidate files. A directory of cases validates every golden
// file that has a candidate of the same name; the others are listed as skipped, and candidate
// files that match no case as unmatched.
batch pair_up(const fs::path& cases, const fs::path& candidates) {
  if (!fs::exists(cases)) throw input_error(cases.string() + ": no such case file or directory");
  if (!fs::exists(candidates)) throw input_error(candidates.string() + ": no such candidate file or directory");
  batch out;
  if (fs::is_directory(cases)) {
    if (!fs::is_directory(candidates))
      throw input_error(candidates.string() + ": with a directory of cases the candidate must be a directory of files of the same names");
    const auto golden = csv_files(cases);
    for (const auto& f : golden) {
      const fs::path c = candidates / f.filename();
      if (fs::exists(c))
        out.pairs.push_back({f, c});
      else
        out.skipped.push_back(f.filename().string());
    }
    for (const auto& c : csv_files(candidates))
      if (!fs::exists(cases / c.filename())) out.unmatched.push_back(c.filename().string());
    if (out.pairs.empty()) throw input_error(candidates.string() + ": holds no file named like a case in " + cases.string());
  } else {
    out.pairs.push_back({cases, fs::is_directory(candidates) ? candidates / cases.filename() : candidates});
    if (!fs::exists(out.pairs.back().candidate)) throw input_error(out.pairs.back().candidate.string() + ": no such candidate file");
  }
  return out;
}

// One case of a batch: its result, or why it could not be compared.
struct outcome {
  pairing pair;
  std::optional<validation_result> result;
  std::string error;  // one line, when no result
  int error_status = 0;  // 2 input, 3 numerical
};

outcome run_case(const pairing& p) {
  outcome o{p, std::nullopt, "", 0};
  try {
    const golden_case g = read_golden_case(read_record(p.golden), p.golden.filename().string());
    o.result = validate_candidate(g, read_record(p.candidate), p.candidate.string());
  } catch (const input_error& e) {
    o.error = e.what();
    o.error_status = 2;
  } catch (const numerical_error& e) {
    o.error = e.what();
    o.error_status = 3;
  }
  return o;
}

}  // namespace

void add_validate(CLI::App& app, int& exit_status) {
  auto st = std::make_shared<validate_state>();
  auto* sub = app.add_subcommand("validate",
                                 "compare another implementation's output with golden cases and diagnose a failure (docs/validation.md); "
                                 "exit 1 if any fails");
  sub->add_option("--case", st->case_path, "golden case file, or a directory of them (golden/)")->required();
  sub->add_option("--candidate", st->candidate_path,
                  "the other implementation's record (t_s,x_m,y_m,speed_rpm[,vx_m_s,vy_m_s]), or a directory of files named as the cases")
      ->required();
  sub->add_option("--json", st->json, "also write the results (with machine-readable causes) as JSON to this file");
  sub->add_flag("--strict", st->strict, "directories: fail (exit 1) when a candidate file matches no case");
  add_threads_option(*sub);
  sub->callback([st, &exit_status] {
    const batch b = pair_up(st->case_path, st->candidate_path);
    const bool single = b.pairs.size() == 1 && !fs::is_directory(st->case_path);
    std::vector<outcome> outcomes;
    for (const auto& p : b.pairs) {
      if (single) {
        // One file: bad input stops the command before any output.
        const golden_case g = read_golden_case(read_record(p.golden), p.golden.filename().string());
        outcomes.push_back({p, validate_candidate(g, read_record(p.candidate), p.candidate.string()), "", 0});
      } else {
        // A directory: a malformed file is its case's error, and the batch goes on.
        outcomes.push_back(run_case(p));
      }
    }
    std::size_t passed = 0, failed = 0, errors = 0;
    int error_status = 0;
    for (const auto& o : outcomes) {
      if (!o.result) {
        ++errors;
        error_status = error_status == 2 ? 2 : o.error_status;
      } else if (o.result->pass) {
        ++passed;
      } else {
        ++failed;
      }
    }
    if (!st->json.empty()) {
      nlohmann::ordered_json j;
      j["cases"] = nlohmann::ordered_json::array();
      for (const auto& o : outcomes) {
        if (o.result) {
          j["cases"].push_back(to_json(*o.result));
        } else {
          j["cases"].push_back({{"case", o.pair.golden.filename().string()},
                                {"candidate", o.pair.candidate.string()},
                                {"error", o.error},
                                {"error_kind", o.error_status == 2 ? "input" : "numerical"},
                                {"pass", false}});
        }
      }
      j["skipped"] = b.skipped;
      j["unmatched"] = b.unmatched;
      j["passed"] = passed;
      j["failed"] = failed;
      j["errors"] = errors;
      atomic_output files;
      files.stage(st->json, j.dump(2) + "\n");
      files.commit();
    }
    for (const auto& o : outcomes) {
      if (o.result)
        std::cout << to_text(*o.result) << "\n";
      else
        std::cout << "case      " << o.pair.golden.filename().string() << "\nerror     " << o.error << "\nresult    ERROR\n\n";
    }
    std::cout << "validated " << outcomes.size() << " case(s): " << passed << " passed, " << failed << " failed";
    if (errors > 0) std::cout << ", " << errors << " could not be compared";
    if (!b.skipped.empty()) std::cout << ", " << b.skipped.size() << " without a candidate (skipped)";
    std::cout << "\n";
    if (!b.unmatched.empty()) {
      std::cout << "unmatched " << b.unmatched.size() << " candidate file(s) named like no case" << (st->strict ? " (--strict: FAIL)" : "") << ":";
      for (const auto& u : b.unmatched) std::cout << " " << u;
      std::cout << "\n";
    }
    if (failed > 0 || (st->strict && !b.unmatched.empty())) exit_status = 1;
    if (errors > 0) exit_status = error_status;
  });
}

}  // namespace rubref::cli
