#pragma once
// Each subcommand registers itself on the app; its callback runs it.

#include <CLI/CLI.hpp>

namespace rubref::cli {

void add_simulate(CLI::App& app);
void add_sweep(CLI::App& app);
void add_reproduce(CLI::App& app);
void add_identify(CLI::App& app);

}  // namespace rubref::cli
