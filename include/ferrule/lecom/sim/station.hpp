// One simulated station on a LECOM line: a lecom::slave session with a simulated Lenze drive
// behind it, sans-I/O. Bytes heard on the line go in with on_receive(); next() says when the
// reply is due and hands it out, as lecom::slave does. sim::bus runs stations on a
// mock_serial line; ferrule-sim runs them on a pseudo-terminal.
#pragma once

#include <cstdint>
#include <span>

#include "ferrule/core/session.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/lecom/frame.hpp"
#include "ferrule/lecom/sim/drive.hpp"
#include "ferrule/lecom/slave.hpp"

namespace ferrule::lecom::sim {

struct station {
    lecom::slave session{};
    sim::drive drive{};

    station() = default;
    // The drive's C0009 is the slave's address.
    explicit station(const slave_config& slave_cfg, const drive_config& drive_cfg = {}) noexcept
        : session(slave_cfg), drive(at_address(drive_cfg, slave_cfg.address)) {}

    // Bytes on the line, the last one ending at `end`. A request for this station is handled
    // by the drive at once; its reply waits in the session until it is due. A write to C0009
    // moves the station for the telegrams after it.
    void on_receive(std::span<const std::uint8_t> bytes, time_point end) noexcept {
        session.on_receive(bytes, end);
        while (session.has_request()) {
            const frame& request = session.request();
            if (!session.response_expected() && request.kind == frame_kind::receive) {
                session.consume(); // a RECEIVE to 00 / x0: nothing to do, nothing to say
                continue;
            }
            const frame reply = drive.handle(request, session.request_end());
            session.set_address(drive.address());
            if (!session.response_expected() || session.respond(reply))
                session.consume(); // 00 / x0: applied, never answered
        }
    }

    session_action next(time_point now) noexcept { return session.next(now); }
    time_point wake_at() const noexcept { return session.wake_at(); }
    void advance(time_point now) noexcept { drive.advance(now); }

private:
    static drive_config at_address(drive_config cfg, std::uint8_t address) noexcept {
        cfg.address = address;
        return cfg;
    }
};

static_assert(ferrule::station<station>);

} // namespace ferrule::lecom::sim
