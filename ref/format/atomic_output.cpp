#include "ref/format/atomic_output.hpp"

#include <fstream>
#include <system_error>
#include <unistd.h>

#include "ref/base/errors.hpp"
#include "ref/base/interrupt.hpp"

namespace rubref {

bool written_by_rubref(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string head(4096, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  const auto header_line = [&](const std::string& prefix) {
    return head.rfind(prefix, 0) == 0 || head.find("\n" + prefix) != std::string::npos;
  };
  return header_line("# format: rubref-") || header_line("# generator: rubref") || head.find("\"generator\": \"rubref") != std::string::npos;
}

void check_output_file(const std::filesystem::path& target, const std::vector<std::filesystem::path>& inputs, bool force) {
  namespace fs = std::filesystem;
  if (target.empty()) throw input_error("empty output path");
  std::error_code ec;
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec)) throw input_error(target.string() + ": directory " + dir.string() + " does not exist");
  if (fs::is_directory(target, ec)) throw input_error(target.string() + ": is a directory");
  if (!fs::exists(target, ec)) return;
  for (const auto& in : inputs)
    if (!in.empty() && fs::exists(in, ec) && fs::equivalent(target, in, ec))
      throw input_error(target.string() + ": is also an input of this run (" + in.string() + "); choose another output file");
  if (!force && !written_by_rubref(target))
    throw input_error(target.string() + ": exists and was not written by rubref; refusing to replace it (force to override)");
}

atomic_output::~atomic_output() {
  for (const auto& f : files_) {
    std::error_code ec;
    std::filesystem::remove(f.temp, ec);
    unregister_staging(f.temp);
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
  bool opened = false, written = false;
  while_not_interrupted([&] {  // registered and created with no clean-up in between
    register_staging(temp);
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) {
      unregister_staging(temp);
      return;
    }
    opened = true;
    files_.push_back({temp, target});
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    written = static_cast<bool>(out);
  });
  if (!opened) throw input_error(target.string() + ": cannot write (" + temp.string() + ")");
  if (!written) throw input_error(target.string() + ": write failed");
}

void atomic_output::commit() {
  for (const auto& f : files_) {
    std::error_code ec;
    std::filesystem::rename(f.temp, f.target, ec);
    if (ec) throw input_error(f.target.string() + ": cannot move into place: " + ec.message());
    unregister_staging(f.temp);
  }
  files_.clear();
}

}  // namespace rubref

namespace rubref {

namespace fs = std::filesystem;

staged_directory::staged_directory(fs::path target) : target_(std::move(target)) {
  if (target_.empty()) throw input_error("empty output directory");
  std::error_code ec;
  target_ = fs::absolute(target_).lexically_normal();
  if (target_.filename().empty()) target_ = target_.parent_path();
  if (fs::exists(target_, ec)) {
    if (!fs::is_directory(target_, ec)) throw input_error(target_.string() + ": exists and is not a directory");
    // An empty folder (one made for the output) is replaced whole, as rubref's own output is:
    // nothing in it can be lost. Anything else rubref did not make is refused.
    if (!fs::exists(target_ / kOutputMarker, ec)) {
      const bool empty = fs::is_empty(target_, ec) && !ec;
      if (!empty)
        throw input_error(target_.string() + ": exists, is not empty and was not made by rubref; choose another output folder, or empty or remove it");
      // The final rename replaces an empty folder, not a link to one.
      if (fs::is_symlink(fs::symlink_status(target_, ec)))
        throw input_error(target_.string() + ": is a link to an empty folder; give the folder itself, or a new one");
    }
    // Replacing the folder the process runs in (or one holding it) would leave the shell in a
    // deleted folder that looks empty: the output would seem lost.
    const fs::path here = fs::current_path(ec);
    const fs::path inside = ec ? fs::path() : here.lexically_relative(fs::weakly_canonical(target_, ec));
    if (!ec && !inside.empty() && *inside.begin() != "..")
      throw input_error(target_.string() + ": holds the current folder, which the output would replace; run from elsewhere, or give a new folder");
  }
  if (!fs::is_directory(target_.parent_path(), ec))
    throw input_error(target_.string() + ": parent directory " + target_.parent_path().string() + " does not exist");
  staging_ = target_;
  staging_ += ".tmp-" + std::to_string(::getpid());
  fs::remove_all(staging_, ec);
  bool created = false;
  while_not_interrupted([&] {  // registered and created with no clean-up in between
    register_staging(staging_);
    created = fs::create_directory(staging_, ec);
    if (!created) unregister_staging(staging_);
  });
  if (!created) throw input_error(staging_.string() + ": cannot create (" + ec.message() + ")");
  write(kOutputMarker, "made by rubref; the whole folder is replaced by the next run writing here\n");
}

staged_directory::~staged_directory() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(staging_, ec);
    unregister_staging(staging_);
  }
}

void staged_directory::write(const std::string& relative, const std::string& content) {
  const fs::path file = staging_ / relative;
  bool opened = false, written = false;
  // create_directories would re-create the staging folder itself if a clean-up had just removed it.
  while_not_interrupted([&] {
    std::error_code ec;
    fs::create_directories(file.parent_path(), ec);
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    if (!out) return;
    opened = true;
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    written = static_cast<bool>(out);
  });
  if (!opened) throw input_error(file.string() + ": cannot write");
  if (!written) throw input_error(file.string() + ": write failed");
}

void staged_directory::commit() {
  std::error_code ec;
  fs::path old;
  // rubref's own output is moved aside first; an empty folder is replaced by the rename itself,
  // atomically, and the rename fails (nothing replaced) if something was put in it meanwhile.
  if (fs::exists(target_ / kOutputMarker, ec)) {
    old = target_;
    old += ".old-" + std::to_string(::getpid());
    fs::rename(target_, old, ec);
    if (ec) throw input_error(target_.string() + ": cannot move the previous output aside: " + ec.message());
  }
  fs::rename(staging_, target_, ec);
  if (ec) {
    const std::string why = ec.message();
    if (!old.empty()) fs::rename(old, target_, ec);
    throw input_error(target_.string() + ": cannot move the new output into place: " + why);
  }
  committed_ = true;
  unregister_staging(staging_);
  if (!old.empty()) fs::remove_all(old, ec);
}

}  // namespace rubref
