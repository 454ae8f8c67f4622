// The `ferrule` subcommands; each registers itself on the app and sets the exit status.
#pragma once

#include <CLI/CLI.hpp>

namespace ferrule::cli {

void add_movilink(CLI::App& app, int& exit_status);
void add_dimetix(CLI::App& app, int& exit_status);
void add_lecom(CLI::App& app, int& exit_status);
void add_modbus(CLI::App& app, int& exit_status);
void add_profibus(CLI::App& app, int& exit_status);
void add_memobus(CLI::App& app, int& exit_status);
void add_decode(CLI::App& app, int& exit_status);
void add_demo(CLI::App& app, int& exit_status);

} // namespace ferrule::cli
