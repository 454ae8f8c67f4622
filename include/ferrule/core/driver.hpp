// Drivers: bring I/O to any master session or station, once for all protocols.
//   run()            blocking: drives one transaction to its end over a byte_stream
//   poll_driver      non-blocking: one step per call, for super-loops and scan cycles
//   station_driver   non-blocking: one step per call, for a super-loop serving a station
#pragma once

#include <array>
#include <cstdint>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/station.hpp"

namespace ferrule {

namespace detail {
template <class S>
void discard(S& stream) {
    if constexpr (discards_input<S>) stream.discard_input();
}
} // namespace detail

// Runs the session's current transaction to completion. Returns the transaction's
// outcome (the session's error()), or the transport error that ended it.
template <session_stream S, master_session M>
ferrule::error run(S& stream, M& session) {
    std::array<std::uint8_t, 64> buf;
    for (;;) {
        const session_action a = session.next(stream.now());
        switch (a.what) {
        case session_action::kind::idle: return {};
        case session_action::kind::done: return session.error();
        case session_action::kind::send: {
            if (a.discard_input) detail::discard(stream);
            const io_result w = stream.write(a.bytes);
            if (w.ec) {
                session.on_transport_error(w.ec);
                return w.ec;
            }
            break;
        }
        case session_action::kind::wait: {
            const io_result r = stream.read_some(buf, a.deadline);
            if (r.bytes > 0)
                session.on_receive(std::span<const std::uint8_t>(buf.data(), r.bytes),
                                   stream.now());
            else if (r.ec && r.ec != errc::timeout) {
                session.on_transport_error(r.ec);
                return r.ec;
            }
            break;
        }
        }
    }
}

// For a main loop that must never block: each step() does at most one write and one
// non-blocking read (read_some with deadline = now), then returns what the session
// is doing; kind::done while a finished transaction's result waits to be read.
template <session_stream S, master_session M>
class poll_driver {
public:
    poll_driver(S& stream, M& session) noexcept : stream_(stream), session_(session) {}

    session_action::kind step() {
        const session_action a = session_.next(stream_.now());
        ferrule::error ec;
        switch (a.what) {
        case session_action::kind::send:
            if (a.discard_input) detail::discard(stream_);
            ec = stream_.write(a.bytes).ec;
            break;
        case session_action::kind::wait: {
            const io_result r = stream_.read_some(buf_, stream_.now());
            if (r.bytes > 0)
                session_.on_receive(std::span<const std::uint8_t>(buf_.data(), r.bytes),
                                    stream_.now());
            else if (r.ec != errc::timeout)
                ec = r.ec;
            break;
        }
        case session_action::kind::idle:
        case session_action::kind::done: break;
        }
        if (ec) session_.on_transport_error(ec);
        return a.what;
    }

private:
    S& stream_;
    M& session_;
    std::array<std::uint8_t, 64> buf_{};
};

// The device side's poll_driver: each step() hands the station what has arrived (one read
// that does not wait), then puts on the line what the station has to send now, at most one
// reply. Returns the transport error of the step, or {}; the station itself never fails.
// An application-in-the-loop slave is asked between steps (has_request(), respond()).
template <session_stream S, station St>
class station_driver {
public:
    station_driver(S& stream, St& station) noexcept : stream_(stream), station_(station) {}

    ferrule::error step() {
        const io_result r = stream_.read_some(buf_, stream_.now());
        if (r.bytes > 0)
            station_.on_receive(std::span<const std::uint8_t>(buf_.data(), r.bytes), stream_.now());
        else if (r.ec && r.ec != errc::timeout)
            return r.ec;
        const session_action a = station_.next(stream_.now());
        if (a.what != session_action::kind::send) return {};
        return stream_.write(a.bytes).ec;
    }

private:
    S& stream_;
    St& station_;
    std::array<std::uint8_t, 64> buf_{};
};

} // namespace ferrule
