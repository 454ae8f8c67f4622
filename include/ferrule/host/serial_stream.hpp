// serial_stream, tcp_stream: a ferrule::byte_stream over an asio serial port or TCP socket,
// so the blocking driver ferrule::run() and every protocol's access helpers work on a real
// port (or a pty), or on a Modbus TCP connection. Time is the host's steady clock. An
// optional tap sees every chunk written and read, with its time, for tracing.
#pragma once

#include <poll.h>
#include <termios.h>

#include <cerrno>
#include <ctime>

#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/read.hpp>
#include <asio/serial_port.hpp>
#include <asio/write.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <span>
#include <system_error>
#include <type_traits>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule::host {

// The host's steady clock as a ferrule::time_point.
inline time_point steady_now() noexcept {
    return time_point{
        std::chrono::duration_cast<duration>(std::chrono::steady_clock::now().time_since_epoch())};
}

// Waits with ppoll() until `fd` has something to read (or an error for the read to report):
// empty then; errc::timeout once `deadline` (steady_now()'s clock) has passed; the system's
// error when ppoll() fails. An interrupted or early wake-up waits again. The streams below
// wait this way, with no io_context run and no timer per call.
inline error wait_readable(int fd, time_point deadline) noexcept {
    for (;;) {
        const duration left = deadline - steady_now();
        const auto wait =
            std::clamp<duration>(left, duration::zero(), std::chrono::hours(24)).count();
        const ::timespec ts{static_cast<::time_t>(wait / 1'000'000'000),
                            static_cast<long>(wait % 1'000'000'000)};
        ::pollfd p{fd, POLLIN, 0};
        const int ready = ::ppoll(&p, 1, &ts, nullptr);
        if (ready > 0) return {};
        if (ready < 0 && errno != EINTR) return {errno, system_domain};
        if (ready == 0 && left <= duration::zero()) return errc::timeout;
    }
}

enum class direction : std::uint8_t { tx, rx };
using tap_handler = std::function<void(direction, std::span<const std::uint8_t>, time_point)>;

template <class AsyncStream>
class blocking_stream {
public:
    using time_point = ferrule::time_point;

    // The io_context is the port's; reads and writes do not run it.
    blocking_stream(::asio::io_context&, AsyncStream& port) noexcept : port_(port) {}

    void set_tap(tap_handler tap) { tap_ = std::move(tap); }

    time_point now() const noexcept { return steady_now(); }

    io_result write(std::span<const std::uint8_t> out) {
        std::error_code ec;
        const std::size_t n = ::asio::write(port_, ::asio::buffer(out.data(), out.size()), ec);
        if (ec) return {n, from_error_code(ec)};
        if (tap_) tap_(direction::tx, out.first(n), now());
        return {n, {}};
    }

    // At least one byte, or errc::timeout at the deadline. The wait is wait_readable() on the
    // port's descriptor, the read one read() (a Modbus RTU transaction on a pty makes 4 system
    // calls instead of 7, docs/PERFORMANCE.md).
    io_result read_some(std::span<std::uint8_t> in, time_point deadline) {
        if (in.empty()) return {0, {}};
        for (;;) {
            if (const auto ec = wait_readable(port_.native_handle(), deadline)) return {0, ec};
            std::error_code ec;
            const std::size_t got = port_.read_some(::asio::buffer(in.data(), in.size()), ec);
            if (got > 0) {
                if (tap_) tap_(direction::rx, in.first(got), now());
                return {got, {}};
            }
            if (ec != ::asio::error::would_block && ec != ::asio::error::try_again)
                return {0, ec ? from_error_code(ec) : errc::transport};
        }
    }

    // Drops what the port has received and not yet delivered.
    void discard_input() noexcept {
        if constexpr (std::is_same_v<AsyncStream, ::asio::serial_port>) {
            ::tcflush(port_.native_handle(), TCIFLUSH);
        } else {
            std::error_code ec;
            std::array<std::uint8_t, 256> scratch;
            while (port_.available(ec) > 0 && !ec) port_.read_some(::asio::buffer(scratch), ec);
        }
    }

private:
    AsyncStream& port_;
    tap_handler tap_;
};

using serial_stream = blocking_stream<::asio::serial_port>;
using tcp_stream = blocking_stream<::asio::ip::tcp::socket>;

static_assert(session_stream<serial_stream>);
static_assert(discards_input<serial_stream>);
static_assert(session_stream<tcp_stream>);
static_assert(discards_input<tcp_stream>);

} // namespace ferrule::host
