// A simulated MOVILINK multi-drop line: up to N stations, each a movilink::slave session
// with a simulated MOVITRAC B behind it, as the mock_peer of a mock_serial.
//
//   * every station hears the master's bytes with their wire timing; the addressed one's
//     drive handles the request when its BCC has arrived, and its slave puts the reply on
//     the line after the start pause (plus the slave's processing_time)
//   * the stations do not hear each other's replies
//   * fault knobs act on the next k replies, whichever station sends them: drop the reply
//     (the master sees a timeout), flip bits of one byte, or send it later
#pragma once

#include <cstddef>

#include "ferrule/sim/line.hpp"
#include "ferrule/movilink/sim/station.hpp"

namespace ferrule::movilink::sim {

// Fault knobs (drop / corrupt / delay the next replies): see ferrule::reply_faults.
template <std::size_t N>
class bus final : public sim_line<station, N> {
public:
    // A station at the end of the line; nullptr when all N places are taken. The drive's
    // P810 / P811 follow the slave's addresses.
    station* add(const slave_config& slave_cfg = {}, const movitrac_b_config& drive_cfg = {}) {
        return this->place(station(slave_cfg, drive_cfg));
    }
};

} // namespace ferrule::movilink::sim
