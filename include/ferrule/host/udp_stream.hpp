// udp_stream: a ferrule::byte_stream over a connected asio UDP socket, for protocols whose
// messages travel one per datagram (Extended MEMOBUS over UDP, protocols/memobus.md §6).
// write() sends one datagram; read_some() hands out the bytes of one datagram, never of two
// in one call: a datagram longer than the caller's buffer (ferrule::run() reads 64 bytes at a
// time) is kept and handed out over the next calls. Time is the host's steady clock; the
// wait is wait_readable() on the socket (serial_stream.hpp), as in blocking_stream.
#pragma once

#include <asio/io_context.hpp>
#include <asio/ip/udp.hpp>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <system_error>
#include <vector>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/host/serial_stream.hpp"

namespace ferrule::host {

class udp_stream {
public:
    using time_point = ferrule::time_point;
    static constexpr std::size_t max_datagram = 65536;

    // The socket must be connected (it sends to and hears from one peer). The io_context is
    // the socket's; reads and writes do not run it.
    udp_stream(::asio::io_context&, ::asio::ip::udp::socket& socket)
        : socket_(socket), datagram_(max_datagram) {}

    void set_tap(tap_handler tap) { tap_ = std::move(tap); }

    time_point now() const noexcept { return steady_now(); }

    // One datagram with all of `out`.
    io_result write(std::span<const std::uint8_t> out) {
        std::error_code ec;
        const std::size_t n = socket_.send(::asio::buffer(out.data(), out.size()), 0, ec);
        if (ec) return {n, from_error_code(ec)};
        if (n != out.size()) return {n, errc::transport};
        if (tap_) tap_(direction::tx, out, now());
        return {n, {}};
    }

    // The rest of the current datagram, or the next one; errc::timeout at the deadline. An
    // ICMP "port unreachable" for an earlier datagram comes back as connection_refused.
    io_result read_some(std::span<std::uint8_t> in, time_point deadline) {
        if (in.empty()) return {0, {}};
        if (pos_ == size_) {
            if (auto ec = receive(deadline)) return {0, ec};
        }
        const std::size_t n = std::min(in.size(), size_ - pos_);
        std::copy_n(datagram_.begin() + static_cast<std::ptrdiff_t>(pos_), n, in.begin());
        pos_ += n;
        return {n, {}};
    }

    // Drops the rest of the current datagram and every datagram already received.
    void discard_input() noexcept {
        pos_ = size_ = 0;
        std::error_code ec;
        while (socket_.available(ec) > 0 && !ec) {
            socket_.receive(::asio::buffer(datagram_), 0, ec);
            if (ec) break;
        }
    }

private:
    error receive(time_point deadline) {
        for (;;) {
            if (const auto ec = wait_readable(socket_.native_handle(), deadline)) return ec;
            std::error_code ec;
            const std::size_t got = socket_.receive(::asio::buffer(datagram_), 0, ec);
            if (ec) return from_error_code(ec);
            if (got > 0) {
                pos_ = 0;
                size_ = got;
                if (tap_) tap_(direction::rx, std::span(datagram_).first(got), now());
                return {};
            }
            // An empty datagram carries nothing: wait for the next.
        }
    }

    ::asio::ip::udp::socket& socket_;
    std::vector<std::uint8_t> datagram_;
    std::size_t pos_ = 0;
    std::size_t size_ = 0;
    tap_handler tap_;
};

static_assert(session_stream<udp_stream>);
static_assert(discards_input<udp_stream>);

} // namespace ferrule::host
