// serve(): runs a station (core/station.hpp) on a blocking byte stream such as
// host::serial_stream over a real serial port, until `stop` is set.
// serve_while(): the same, for as long as a check the caller gives says so; it also runs a
// master session that starts its own transactions and is never done (lecom::poller).
// (pty_server does the same for simulators on a pseudo-terminal it creates itself.)
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <system_error>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/station.hpp"

namespace ferrule::host {

// keep_going() is asked at the start and then every `check_interval` (reads never wait
// past the next check); serving ends when it returns false. Returns the transport error
// that ended it (also handed to a master session's on_transport_error()), or {}.
template <session_stream S, class Session, class KeepGoing>
requires station<Session> || master_session<Session> std::error_code
serve_while(S& line, Session& session, duration check_interval, KeepGoing&& keep_going) {
    const auto fail = [&](std::error_code ec) {
        if constexpr (requires { session.on_transport_error(ec); }) session.on_transport_error(ec);
        return ec;
    };
    std::array<std::uint8_t, 256> buf{};
    time_point next_check = line.now();
    for (;;) {
        const time_point now = line.now();
        if (now >= next_check) {
            if (!keep_going()) return {};
            next_check = now + check_interval;
        }
        const session_action a = session.next(now);
        if (a.what == session_action::kind::send) {
            if (a.discard_input) ferrule::detail::discard(line);
            if (const io_result w = line.write(a.bytes); w.ec) return fail(w.ec);
            continue;
        }
        time_point until = next_check;
        if (a.what == session_action::kind::wait) until = std::min(until, a.deadline);
        const io_result r = line.read_some(buf, until);
        if (r.bytes > 0)
            session.on_receive({buf.data(), r.bytes}, line.now());
        else if (r.ec && r.ec != errc::timeout)
            return fail(r.ec);
    }
}

// Until `stop` is set; it is looked at least every `poll_interval`.
template <session_stream S, station Station>
std::error_code serve(S& line, Station& station, const std::atomic<bool>& stop,
                      duration poll_interval = std::chrono::milliseconds(50)) {
    return serve_while(line, station, poll_interval,
                       [&stop] { return !stop.load(std::memory_order_relaxed); });
}

} // namespace ferrule::host
