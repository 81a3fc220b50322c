#pragma once
// Figures are drawn by matplotlib scripts in scripts/, run by Debian's python3 (RUBREF_PYTHON):
// `python script folder` reads its data from the folder and writes PNGs there.

#include <filesystem>

namespace rubref {

// The configured interpreter and this source tree's scripts/ folder.
std::filesystem::path default_python();
std::filesystem::path script_path(const char* name);  // e.g. "plot_figures.py"

// Runs `python script folder`; input_error naming the command if it cannot start or fails.
void run_python_script(const std::filesystem::path& python, const std::filesystem::path& script, const std::filesystem::path& folder);

}  // namespace rubref
