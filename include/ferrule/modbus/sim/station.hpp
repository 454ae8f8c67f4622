// One simulated station on a Modbus RTU line: a modbus::server session with a simulated VFD
// (vfd.hpp) as its data model, sans-I/O. Bytes heard on the line go in with on_receive();
// next() says when the reply is due and hands it out, as server does. sim::bus runs stations
// on a mock_serial line.
#pragma once

#include <cstdint>
#include <span>

#include "ferrule/core/session.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/modbus/server.hpp"
#include "ferrule/modbus/sim/vfd.hpp"

namespace ferrule::modbus::sim {

struct station {
    server<vfd> session{};

    station() = default;
    explicit station(const server_config& cfg) noexcept : session(cfg) {}

    // Bytes on the line, the last one ending at `end`. The drive's speed model runs up to
    // `end` first, so a request reads the drive as it is when the request has arrived.
    void on_receive(std::span<const std::uint8_t> bytes, time_point end) noexcept {
        session.model().advance(end);
        session.on_receive(bytes, end);
    }

    // A request that ends by silence (an unknown function code) is executed here, at `now`.
    session_action next(time_point now) noexcept {
        session.model().advance(now);
        return session.next(now);
    }
    time_point wake_at() const noexcept { return session.wake_at(); }
    void advance(time_point now) noexcept { session.model().advance(now); }

    vfd& drive() noexcept { return session.model(); }
    const vfd& drive() const noexcept { return session.model(); }
};

static_assert(ferrule::station<server<vfd>>);
static_assert(ferrule::station<station>);

} // namespace ferrule::modbus::sim
