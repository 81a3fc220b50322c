#pragma once
// Outputs appear whole or not at all: every file is written to a temporary beside its target and
// renamed into place only when all files of a command are complete, so an interrupted or failed
// run never leaves a half-written result nor replaces an existing one.

#include <filesystem>
#include <string>
#include <vector>

namespace rubref {

// Whether an existing file was written by rubref: a record or table (a "# format: rubref-" or
// "# generator: rubref" header line) or JSON with "generator": "rubref ..." near its top.
bool written_by_rubref(const std::filesystem::path& file);

// Checks an output file before any work is done: its folder exists, it is not a folder nor one of
// `inputs`, and, if it exists, rubref wrote it (or `force`). input_error naming the problem.
void check_output_file(const std::filesystem::path& target, const std::vector<std::filesystem::path>& inputs, bool force);

class atomic_output {
 public:
  atomic_output() = default;
  atomic_output(const atomic_output&) = delete;
  atomic_output& operator=(const atomic_output&) = delete;
  ~atomic_output();  // removes staged files that were not committed

  // Writes `content` to a temporary file next to `target`; input_error if it cannot.
  void stage(const std::filesystem::path& target, const std::string& content);
  // Renames every staged file onto its target.
  void commit();

 private:
  struct staged {
    std::filesystem::path temp, target;
  };
  std::vector<staged> files_;
};

}  // namespace rubref

namespace rubref {

// An output directory that appears whole or not at all. Files are written under `path()`, a
// fresh sibling of the target; commit() swaps it into place. An existing target is replaced only
// if rubref made it (it holds the marker file kOutputMarker) or it is empty, and never when it
// holds the current folder (`--out .`). A failed run leaves an existing target as it was.
class staged_directory {
 public:
  static constexpr const char* kOutputMarker = ".rubref-output";

  explicit staged_directory(std::filesystem::path target);  // input_error if the target is unusable
  staged_directory(const staged_directory&) = delete;
  staged_directory& operator=(const staged_directory&) = delete;
  ~staged_directory();  // removes the staging folder unless committed

  const std::filesystem::path& path() const { return staging_; }
  const std::filesystem::path& target() const { return target_; }
  void write(const std::string& relative, const std::string& content);  // input_error on failure
  void commit();

 private:
  std::filesystem::path target_, staging_;
  bool committed_ = false;
};

}  // namespace rubref
