#include "ref/atomic_output.hpp"

#include <fstream>
#include <system_error>
#include <unistd.h>

#include "ref/errors.hpp"

namespace rubref {

atomic_output::~atomic_output() {
  for (const auto& f : files_) {
    std::error_code ec;
    std::filesystem::remove(f.temp, ec);
  }
}

void atomic_output::stage(const std::filesystem::path& target, const std::string& content) {
  if (target.empty()) throw input_error("empty output path");
  const auto dir = target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec))
    throw input_error(target.string() + ": directory " + dir.string() + " does not exist");
  if (std::filesystem::is_directory(target, ec)) throw input_error(target.string() + ": is a directory");
  auto temp = target;
  temp += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(files_.size());
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) throw input_error(target.string() + ": cannot write (" + temp.string() + ")");
    files_.push_back({temp, target});
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) throw input_error(target.string() + ": write failed");
  }
}

void atomic_output::commit() {
  for (const auto& f : files_) {
    std::error_code ec;
    std::filesystem::rename(f.temp, f.target, ec);
    if (ec) throw input_error(f.target.string() + ": cannot move into place: " + ec.message());
  }
  files_.clear();
}

}  // namespace rubref
