#pragma once
// Each subcommand registers itself on the app; its callback runs it.

#include <CLI/CLI.hpp>

namespace rubref::cli {

void add_simulate(CLI::App& app);
void add_orbit(CLI::App& app);
void add_continuation(CLI::App& app);
void add_sweep(CLI::App& app);
void add_reproduce(CLI::App& app);
void add_identify(CLI::App& app);
void add_rig(CLI::App& app);  // also `effects`
void add_loop(CLI::App& app);
void add_study(CLI::App& app);  // also `study-merge`
// Sets exit_status to 1 when a candidate fails; in directory mode, to 2 or 3 when a case could not
// be compared (bad input, numerical failure) after every case ran and the JSON was written.
void add_validate(CLI::App& app, int& exit_status);

// "; did you mean '...'?" for a mistyped subcommand or option in a parse error, else "".
std::string suggestion(CLI::App& app, const CLI::ParseError& e);

}  // namespace rubref::cli
