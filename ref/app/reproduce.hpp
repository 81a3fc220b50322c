#pragma once
// `rubref reproduce`: every figure of the paper's verification (Figs. 3, 6-12) from the paper's
// default parameters, the data behind them, and report.md comparing rubref with the paper.

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

namespace rubref {

struct reproduce_settings {
  std::filesystem::path out = "reproduce";
  unsigned threads = 0;  // 0: every core
  bool figures = true;   // draw the figures (python3-matplotlib); false: data and report only
  std::filesystem::path python;       // empty: the configured Debian python3 (RUBREF_PYTHON)
  std::filesystem::path plot_script;  // empty: scripts/plot_figures.py of this source tree
  std::function<void(std::string_view)> progress = [](std::string_view) {};
};

// Runs everything into a staged folder, moved onto `out` only when complete. Throws
// input_error / numerical_error; on failure nothing at `out` changes.
void reproduce(const reproduce_settings& s);

}  // namespace rubref
