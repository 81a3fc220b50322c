#pragma once
// Figures are drawn by matplotlib scripts in scripts/, run by Debian's python3 (RUBREF_PYTHON):
// `python script folder` reads its data from the folder and writes PNGs there.

#include <filesystem>

namespace rubref {

// The configured interpreter, and a plot script (e.g. "plot_figures.py"): next to an installed
// rubref (<prefix>/share/rubref/scripts), else in the source tree it was built from, else where
// it was installed; input_error if none has it.
std::filesystem::path default_python();
std::filesystem::path script_path(const char* name);

// Runs `python script folder`; input_error naming the command if it cannot start or fails.
void run_python_script(const std::filesystem::path& python, const std::filesystem::path& script, const std::filesystem::path& folder);

}  // namespace rubref
