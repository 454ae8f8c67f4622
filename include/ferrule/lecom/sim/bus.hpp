// A simulated LECOM-B (RS-485) line: up to N stations, each a lecom::slave session with a
// simulated Lenze drive behind it, as the mock_peer of a mock_serial (the LECOM paper's PLC
// polls six 4900 drives on one line; S3: 31 drives per segment).
//
//   * every station hears the master's bytes; the addressed one's drive handles the request
//     when its last character has arrived, and its slave puts the reply on the line
//     processing_time later (S3: t3 = 20 ms)
//   * the stations do not hear each other's replies
//   * fault knobs act on the next k replies, whichever station sends them: drop the reply
//     (the master sees a timeout), flip bits of one byte, or send it later
#pragma once

#include <cstddef>

#include "ferrule/sim/line.hpp"
#include "ferrule/lecom/sim/station.hpp"

namespace ferrule::lecom::sim {

// Fault knobs (drop / corrupt / delay the next replies): see ferrule::reply_faults.
template <std::size_t N>
class bus final : public sim_line<station, N> {
public:
    // A station at the end of the line; nullptr when all N places are taken.
    station* add(const slave_config& slave_cfg = {}, const drive_config& drive_cfg = {}) {
        return this->place(station(slave_cfg, drive_cfg));
    }
};

} // namespace ferrule::lecom::sim
