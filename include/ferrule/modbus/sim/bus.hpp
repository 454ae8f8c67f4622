// A simulated Modbus RTU (RS-485) line: up to N stations, each a modbus::server with a
// simulated VFD behind it, as the mock_peer of a mock_serial (the gateway paper's set-up,
// seeds/002: a PLC's requests reach VFDs over Modbus RTU).
//
//   * every station hears the client's bytes; the addressed one executes the request when its
//     last character has arrived and puts the reply on the line t3.5 + processing_time later
//     (Modbus over Serial Line V1.02 §2.5.1.1); a broadcast is executed by all, answered by
//     none
//   * the stations do not hear each other's replies
//   * fault knobs act on the next k replies, whichever station sends them: drop the reply
//     (the client sees a timeout), flip bits of one byte (a CRC error), or send it later
#pragma once

#include <cstddef>

#include "ferrule/sim/line.hpp"
#include "ferrule/modbus/sim/station.hpp"

namespace ferrule::modbus::sim {

// Fault knobs (drop / corrupt / delay the next replies): see ferrule::reply_faults.
template <std::size_t N>
class bus final : public sim_line<station, N> {
public:
    // A station at the end of the line answering `cfg.units`; nullptr when all N places are
    // taken.
    station* add(const server_config& cfg = {}) { return this->place(station(cfg)); }
};

} // namespace ferrule::modbus::sim
