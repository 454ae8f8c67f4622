// reconnecting_tcp_stream: a blocking byte stream over a TCP connection that is opened on the
// first write and opened again on the first write after it was lost — for masters that keep
// talking to a controller across its restarts (Extended MEMOBUS, Modbus TCP). A transport
// error ends the transaction under way (the session sees it); the next one reconnects.
//
// An optional local port is bound before connecting: an MP controller's connection table may
// name the PC's port as well as its address (protocols/memobus.md §6).
#pragma once

#include <asio/connect.hpp>
#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>

#include <cstdint>
#include <optional>
#include <span>
#include <system_error>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/host/serial_stream.hpp"

namespace ferrule::host {

struct reconnect_stats {
    std::uint32_t connects = 0; // connections opened
    std::uint32_t failed_connects = 0;
    std::uint32_t losses = 0; // connections lost (read or write errors, EOF)
};

class reconnecting_tcp_stream {
public:
    using time_point = ferrule::time_point;

    reconnecting_tcp_stream(::asio::io_context& ctx, ::asio::ip::tcp::endpoint peer,
                            std::uint16_t local_port = 0)
        : ctx_(ctx), socket_(ctx), peer_(peer), local_port_(local_port) {}

    time_point now() const noexcept { return steady_now(); }
    bool connected() const noexcept { return socket_.is_open(); }
    const reconnect_stats& stats() const noexcept { return stats_; }

    io_result write(std::span<const std::uint8_t> out) {
        if (!socket_.is_open()) {
            if (const auto ec = connect()) return {0, from_error_code(ec)};
        }
        const io_result r = stream().write(out);
        if (r.ec) lost();
        return r;
    }

    io_result read_some(std::span<std::uint8_t> in, time_point deadline) {
        if (!socket_.is_open()) return {0, errc::transport};
        const io_result r = stream().read_some(in, deadline);
        if (r.ec && r.ec != errc::timeout) lost();
        return r;
    }

    void discard_input() noexcept {
        if (socket_.is_open()) stream().discard_input();
    }

private:
    tcp_stream stream() noexcept { return tcp_stream(ctx_, socket_); }

    std::error_code connect() {
        std::error_code ec;
        socket_.open(peer_.protocol(), ec);
        if (!ec && local_port_ != 0) {
            socket_.set_option(::asio::socket_base::reuse_address(true), ec);
            if (!ec) socket_.bind({peer_.protocol(), local_port_}, ec);
        }
        if (!ec) socket_.connect(peer_, ec);
        if (!ec) socket_.set_option(::asio::ip::tcp::no_delay(true), ec);
        if (ec) {
            ++stats_.failed_connects;
            std::error_code ignored;
            socket_.close(ignored);
            return ec;
        }
        ++stats_.connects;
        return {};
    }

    void lost() {
        ++stats_.losses;
        std::error_code ignored;
        socket_.close(ignored);
    }

    ::asio::io_context& ctx_;
    ::asio::ip::tcp::socket socket_;
    ::asio::ip::tcp::endpoint peer_;
    std::uint16_t local_port_;
    reconnect_stats stats_{};
};

static_assert(session_stream<reconnecting_tcp_stream>);

} // namespace ferrule::host
