// One simulated station on a MOVILINK line: a movilink::slave session with a simulated
// MOVITRAC B behind it, sans-I/O. Bytes heard on the line go in with on_receive(); next()
// says when the reply is due and hands it out, as movilink::slave does. sim::bus runs
// stations on a mock_serial line; ferrule-sim runs them on a pseudo-terminal.
#pragma once

#include <cstdint>
#include <span>

#include "ferrule/core/session.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/movilink/sim/movitrac_b.hpp"
#include "ferrule/movilink/slave.hpp"

namespace ferrule::movilink::sim {

struct station {
    movilink::slave session{};
    movitrac_b drive{};

    station() = default;
    // The drive's P810 / P811 follow the slave's addresses.
    explicit station(const slave_config& slave_cfg,
                     const movitrac_b_config& drive_cfg = {}) noexcept
        : session(slave_cfg), drive(drive_cfg) {
        drive.preset(parameter_index::p810_rs485_address, slave_cfg.address);
        drive.preset(parameter_index::p811_rs485_group_address, slave_cfg.group);
    }

    // Bytes on the line, the last one ending at `end`. A request for this station is handled
    // by the drive at once; its reply waits in the session until it is due.
    void on_receive(std::span<const std::uint8_t> bytes, time_point end) noexcept {
        session.on_receive(bytes, end);
        if (!session.has_request()) return;
        const telegram reply = drive.handle(session.request(), session.request_end());
        if (session.response_expected())
            (void)session.respond(reply);
        else
            session.consume(); // group and broadcast: processed, never answered
    }

    session_action next(time_point now) noexcept { return session.next(now); }
    time_point wake_at() const noexcept { return session.wake_at(); }
    void advance(time_point now) noexcept { drive.advance(now); }
};

static_assert(ferrule::station<station>);

} // namespace ferrule::movilink::sim
