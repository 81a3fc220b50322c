#pragma once
// Outputs appear whole or not at all: every file is written to a temporary beside its target and
// renamed into place only when all files of a command are complete, so an interrupted or failed
// run never leaves a half-written result nor replaces an existing one.

#include <filesystem>
#include <string>
#include <vector>

namespace rubref {

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
