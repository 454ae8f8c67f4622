// A simulated PROFIBUS line: up to N DP-V0 slaves (slave.hpp) as the mock_peer of a
// mock_serial whose session is a DP master. Every slave hears the master's telegrams; the
// one addressed answers min TSDR after the request; the slaves do not hear each other. The
// fault knobs of sim_line (drop, corrupt, delay the next replies) act on any slave's reply.
#pragma once

#include <cstddef>

#include "ferrule/sim/line.hpp"
#include "ferrule/profibus/slave.hpp"

namespace ferrule::profibus::sim {

template <std::size_t N>
class bus final : public sim_line<slave, N> {
public:
    // A slave at the end of the line; nullptr when all N places are taken.
    slave* add(const slave_config& cfg) { return this->place(slave(cfg)); }
};

} // namespace ferrule::profibus::sim
