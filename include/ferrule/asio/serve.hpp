// serve(): runs the device side of a line — a Modbus server, a LECOM or MOVILINK slave, any
// station with on_receive(bytes, end) and next(now) -> session_action — on a blocking byte
// stream such as host::serial_stream over a real serial port, until `stop` is set.
// (pty_server does the same for simulators on a pseudo-terminal it creates itself.)
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <system_error>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/session.hpp"

namespace ferrule::host {

// Returns the transport error that ended it, or {} when stopped. `stop` is looked at least
// every `poll_interval`.
template <session_stream S, class Station>
std::error_code serve(S& line, Station& station, const std::atomic<bool>& stop,
                      duration poll_interval = std::chrono::milliseconds(50)) {
    std::array<std::uint8_t, 256> buf{};
    while (!stop.load(std::memory_order_relaxed)) {
        const time_point now = line.now();
        const session_action a = station.next(now);
        if (a.what == session_action::kind::send) {
            if (const io_result w = line.write(a.bytes); w.ec) return w.ec;
            continue;
        }
        time_point until = now + poll_interval;
        if (a.what == session_action::kind::wait) until = std::min(until, a.deadline);
        const io_result r = line.read_some(buf, until);
        if (r.bytes > 0)
            station.on_receive({buf.data(), r.bytes}, line.now());
        else if (r.ec && r.ec != make_error_code(errc::timeout))
            return r.ec;
    }
    return {};
}

} // namespace ferrule::host
