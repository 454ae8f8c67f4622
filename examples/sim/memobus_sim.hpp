// ferrule-sim memobus: a simulated MP2310 / 218IFA controller serving Extended MEMOBUS to
// several PCs at once over TCP (and UDP), each on its own transmission buffer channel
// (protocols/memobus.md §6, seeds/004).
#pragma once

#include <CLI/CLI.hpp>

#include <atomic>

namespace ferrule::sim_app {

// Registers the subcommand; its callback serves until `stop` and sets `rc`.
void add_memobus(CLI::App& app, const std::atomic<bool>& stop, int& rc);

} // namespace ferrule::sim_app
