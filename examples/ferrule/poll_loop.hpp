// Drives a session that never finishes (lecom::poller) over a blocking stream, handing
// control back every `refresh` so the caller can show what it has, until it says stop.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <system_error>

#include "ferrule/core/driver.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/session.hpp"

namespace ferrule::cli {

// `tick()` runs at the start and then every `refresh`; polling stops when it returns false.
// Returns the transport error that ended it, or {}.
template <session_stream S, master_session P, class Tick>
std::error_code run_poller(S& line, P& p, duration refresh, Tick&& tick) {
    std::array<std::uint8_t, 64> buf{};
    time_point next_tick = line.now();
    for (;;) {
        const time_point now = line.now();
        if (now >= next_tick) {
            if (!tick()) return {};
            next_tick = now + refresh;
        }
        const session_action a = p.next(now);
        if (a.what == session_action::kind::send) {
            if (a.discard_input) detail::discard(line);
            const io_result w = line.write(a.bytes);
            if (w.ec) {
                p.on_transport_error(w.ec);
                return w.ec;
            }
        } else if (a.what == session_action::kind::wait) {
            const io_result r = line.read_some(buf, std::min(a.deadline, next_tick));
            if (r.bytes > 0)
                p.on_receive({buf.data(), r.bytes}, line.now());
            else if (r.ec && r.ec != make_error_code(errc::timeout)) {
                p.on_transport_error(r.ec);
                return r.ec;
            }
        }
    }
}

} // namespace ferrule::cli
