#include "ref/python_script.hpp"

#include <spawn.h>
#include <sys/wait.h>

#include <string>
#include <vector>

#include "ref/errors.hpp"

extern char** environ;

namespace rubref {

std::filesystem::path default_python() { return RUBREF_PYTHON; }
std::filesystem::path script_path(const char* name) { return std::filesystem::path(RUBREF_SCRIPTS_DIR) / name; }

void run_python_script(const std::filesystem::path& python, const std::filesystem::path& script, const std::filesystem::path& folder) {
  const std::string py = python.string(), sc = script.string(), dir = folder.string();
  std::vector<char*> argv{const_cast<char*>(py.c_str()), const_cast<char*>(sc.c_str()), const_cast<char*>(dir.c_str()), nullptr};
  pid_t pid = 0;
  if (posix_spawn(&pid, py.c_str(), nullptr, nullptr, argv.data(), environ) != 0)
    throw input_error("cannot run " + py + " for the figures (is python3-matplotlib installed? scripts/setup installs it)");
  int status = 0;
  if (waitpid(pid, &status, 0) < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw input_error("drawing the figures failed: " + py + " " + sc + " " + dir);
}

}  // namespace rubref
