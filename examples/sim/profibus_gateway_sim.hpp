// ferrule-sim profibus-gateway: gateway::core (gateway.hpp) as a PROFIBUS-DP slave on a pty
// whose drive line is a serial port: by default a second pty on which simulated VFDs answer
// (as `ferrule-sim modbus` serves them), or --drive-port PATH (a real RS-485 adapter, or the
// pty of a `ferrule-sim modbus` started separately).
#pragma once

#include <CLI/CLI.hpp>

#include <atomic>

namespace ferrule::sim_app {

// Registers the subcommand; its callback serves until `stop` and sets `rc`.
void add_profibus_gateway(CLI::App& app, const std::atomic<bool>& stop, int& rc);

} // namespace ferrule::sim_app
