// A class-1 master's cycle over several DP-V0 slaves, blocking, over any byte_stream: each
// pass brings up the slaves that are not exchanging data (FDL_Status, Slave_Diag, Set_Prm,
// Chk_Cfg, Slave_Diag until ready: bring_up()) and exchanges the I/O of the others, in
// list order. A DH reply makes the master read the slave's diagnosis at once (§B.3); a slave
// that no longer says it is ready, or whose exchange fails, is brought up again — at once
// after a failed exchange, `retry_after` after a failed bring-up.
#pragma once

#include <cstdint>
#include <span>
#include <system_error>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/master.hpp"
#include "ferrule/profibus/services.hpp"

namespace ferrule::profibus {

struct cycle_slave {
    std::uint8_t address = 0;
    prm_data prm{};
    std::span<const std::uint8_t> cfg{};
    std::span<const std::uint8_t> outputs{}; // sent every pass
    std::span<std::uint8_t> inputs{};        // written every pass

    // Kept by the cycle.
    bool exchanging = false;
    slave_diag diag{}; // the last diagnosis read (its extended part is not kept)
    std::error_code last_error{};
    time_point retry_at{};
    std::uint32_t exchanges = 0;
    std::uint32_t failures = 0; // failed exchanges and bring-ups
    std::uint32_t bring_ups = 0;
    std::uint32_t diag_reads = 0; // after DH
};

struct cycle_config {
    duration retry_after = std::chrono::seconds(1);
    unsigned diag_polls = 10;
};

// One pass; returns how many slaves exchanged data in it.
template <session_stream S>
std::size_t run_cycle(S& stream, master& m, std::span<cycle_slave> slaves,
                      const cycle_config& c = {}) {
    std::size_t exchanged = 0;
    for (cycle_slave& s : slaves) {
        if (!s.exchanging) {
            if (before(stream.now(), s.retry_at)) continue;
            ++s.bring_ups;
            if (const auto ec = bring_up(stream, m, s.address, s.prm, s.cfg, c.diag_polls)) {
                ++s.failures;
                s.last_error = ec;
                s.retry_at = stream.now() + c.retry_after;
                continue;
            }
            s.exchanging = true;
        }
        if (const auto ec = data_exchange(stream, m, s.address, s.outputs, s.inputs)) {
            ++s.failures;
            s.last_error = ec;
            s.exchanging = false;
            s.retry_at = stream.now();
            continue;
        }
        ++s.exchanges;
        ++exchanged;
        if (!m.data_high()) continue;
        slave_diag d;
        if (const auto ec = read_slave_diag(stream, m, s.address, d)) {
            s.last_error = ec;
            continue;
        }
        ++s.diag_reads;
        s.diag = d;
        s.diag.ext = {};
        if (!d.ready()) {
            s.exchanging = false;
            s.retry_at = stream.now();
        }
    }
    return exchanged;
}

} // namespace ferrule::profibus
