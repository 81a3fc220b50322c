#include "ref/app/python_script.hpp"

#include <spawn.h>
#include <sys/wait.h>

#include <string>
#include <vector>

#include "ref/base/errors.hpp"
#include "ref/base/interrupt.hpp"

extern char** environ;

namespace rubref {

std::filesystem::path default_python() { return RUBREF_PYTHON; }
std::filesystem::path script_path(const char* name) {
  namespace fs = std::filesystem;
  std::vector<fs::path> where;
  std::error_code ec;
  if (const fs::path exe = fs::read_symlink("/proc/self/exe", ec); !ec) where.push_back(exe.parent_path() / RUBREF_SCRIPTS_FROM_BIN);
  where.emplace_back(RUBREF_SCRIPTS_DIR);
  where.emplace_back(RUBREF_INSTALLED_SCRIPTS_DIR);
  for (const fs::path& dir : where)
    if (fs::is_regular_file(dir / name, ec)) return (dir / name).lexically_normal();
  std::string looked;
  for (const fs::path& dir : where) looked += (looked.empty() ? "" : ", ") + dir.lexically_normal().string();
  throw input_error(std::string("cannot find the plot script ") + name + " (looked in " + looked + ")");
}

void run_python_script(const std::filesystem::path& python, const std::filesystem::path& script, const std::filesystem::path& folder) {
  const std::string py = python.string(), sc = script.string(), dir = folder.string();
  std::vector<char*> argv{const_cast<char*>(py.c_str()), const_cast<char*>(sc.c_str()), const_cast<char*>(dir.c_str()), nullptr};
  // The child gets the signals rubref waits for back at their default action and unblocked
  // (ref/base/interrupt.hpp): Ctrl-C ends the figures too.
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none, handled = interrupt_signals();
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setsigdefault(&attr, &handled);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, py.c_str(), nullptr, &attr, argv.data(), environ);
  posix_spawnattr_destroy(&attr);
  if (spawned != 0)
    throw input_error("cannot run " + py + " for the figures (is python3-matplotlib installed? scripts/setup installs it)");
  register_child(pid);
  int status = 0;
  const pid_t waited = waitpid(pid, &status, 0);
  unregister_child(pid);
  if (waited < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw input_error("drawing the figures failed: " + py + " " + sc + " " + dir);
}

}  // namespace rubref
