// serve_gateway(): runs a gateway::core (gateway/gateway.hpp) on its two lines from one
// thread, so the core, which is not thread-safe, needs no lock. It waits with one ppoll() on
// both lines until bytes come or the core's next deadline (a DP reply due, the DP watchdog, a
// Modbus response timeout), hands what came to the core and writes what it says to send.
//
// The DP line is a descriptor to read and a writer (`dp_write(bytes)`): the simulator's end
// of a pty or a serial port; the drive line a serial_stream over a serial port.
#pragma once

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <span>

#include "ferrule/gateway/gateway.hpp"
#include "ferrule/host/serial_stream.hpp"

namespace ferrule::host {

// Serves until `stop` (looked at least every 50 ms); false when the drive line hung up (a
// port whose other end has gone).
template <class DpWrite>
bool serve_gateway(gateway::core& gw, int dp_fd, DpWrite&& dp_write, serial_stream& drive,
                   int drive_fd, const std::atomic<bool>& stop) {
    std::array<std::uint8_t, 256> buf{};
    while (!stop.load(std::memory_order_relaxed)) {
        const time_point now = steady_now();
        for (session_action a = gw.next_dp(now); a.what == session_action::kind::send;
             a = gw.next_dp(now))
            dp_write(a.bytes);
        session_action m = gw.next_modbus(now);
        for (; m.what == session_action::kind::send; m = gw.next_modbus(now)) {
            if (m.discard_input) drive.discard_input();
            if (const io_result w = drive.write(m.bytes); w.ec) gw.on_modbus_error(w.ec);
        }
        time_point until = std::min(now + std::chrono::milliseconds(50), gw.dp_wake_at());
        if (m.what == session_action::kind::wait) until = std::min(until, m.deadline);
        const auto wait = std::max(until - now, duration::zero()).count();
        const ::timespec ts{static_cast<::time_t>(wait / 1'000'000'000),
                            static_cast<long>(wait % 1'000'000'000)};
        std::array<::pollfd, 2> fds{{{dp_fd, POLLIN, 0}, {drive_fd, POLLIN, 0}}};
        if (::ppoll(fds.data(), fds.size(), &ts, nullptr) <= 0) continue;
        if (fds[0].revents & POLLIN) {
            const ssize_t n = ::read(dp_fd, buf.data(), buf.size());
            if (n > 0) gw.on_dp_receive({buf.data(), static_cast<std::size_t>(n)}, steady_now());
        }
        if (fds[1].revents != 0) {
            io_result r{};
            if (fds[1].revents & POLLIN) r = drive.read_some(buf, steady_now());
            if (r.bytes > 0)
                gw.on_modbus_receive({buf.data(), r.bytes}, steady_now());
            else if (fds[1].revents & (POLLHUP | POLLERR | POLLNVAL))
                return false;
            else if (r.ec && r.ec != errc::timeout)
                gw.on_modbus_error(r.ec);
        }
    }
    return true;
}

} // namespace ferrule::host
