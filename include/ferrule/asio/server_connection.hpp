// server_connection: what each connection of ferrule's TCP servers (Modbus TCP, Extended
// MEMOBUS) does the same way beneath its protocol: a non-blocking socket without Nagle's
// delay, the idle timeout, reading only once all bytes read before are used (so a
// connection takes no more than its session can hold), and replies through reply_writer.
//
// A connection derives from server_connection<Connection> and gives it
//     void feed()           use the bytes of unused() (use(n) each), then call read_on()
//     void end(bool idle)   count and close, once (idle: by the idle timeout); calls shut()
#pragma once

#include <asio/buffer.hpp>
#include <asio/ip/tcp.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <system_error>
#include <utility>

#include "ferrule/asio/idle_watch.hpp"
#include "ferrule/asio/reply_writer.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule::host {

template <class Connection>
class server_connection : public std::enable_shared_from_this<Connection> {
public:
    explicit server_connection(::asio::ip::tcp::socket socket)
        : socket_(std::move(socket)), idle_(socket_.get_executor()) {}
    server_connection(const server_connection&) = delete;
    server_connection& operator=(const server_connection&) = delete;

    // Once, right after the connection is made shared.
    void start(duration idle_timeout) {
        std::error_code ec;
        socket_.non_blocking(true, ec);
        socket_.set_option(::asio::ip::tcp::no_delay(true), ec);
        idle_.touch();
        idle_.start(idle_timeout, this->shared_from_this(), [this] { self().end(true); });
        read_on();
    }

    void shut() {
        std::error_code ec;
        socket_.close(ec);
        idle_.cancel();
    }

protected:
    // The bytes read and not yet used; use(n) takes n of them off the front.
    std::span<const std::uint8_t> unused() const noexcept {
        return {rx_.data() + rx_pos_, rx_size_ - rx_pos_};
    }
    void use(std::size_t n) noexcept { rx_pos_ += n; }

    // Reads again when all is used, no read is under way and the replies do not back up.
    void read_on() {
        if (reading_ || rx_pos_ < rx_size_ || backlogged() || !socket_.is_open()) return;
        reading_ = true;
        socket_.async_read_some(::asio::buffer(rx_),
                                [keep = this->shared_from_this()](
                                    std::error_code ec, std::size_t n) { keep->on_read(ec, n); });
    }

    void send(std::span<const std::uint8_t> bytes) {
        const auto ec = writer_.send(bytes, this->shared_from_this(), [this](std::error_code e) {
            if (e) return self().end(false);
            self().feed();
        });
        if (ec) self().end(false);
    }

    bool backlogged() const noexcept { return writer_.backlogged(); }

    ::asio::ip::tcp::socket socket_;
    idle_watch idle_;

private:
    Connection& self() noexcept { return static_cast<Connection&>(*this); }

    void on_read(std::error_code ec, std::size_t n) {
        reading_ = false;
        rx_pos_ = 0;
        rx_size_ = ec ? 0 : n;
        if (ec) return self().end(false);
        idle_.touch();
        self().feed();
    }

    std::array<std::uint8_t, 512> rx_{};
    std::size_t rx_pos_ = 0;
    std::size_t rx_size_ = 0;
    bool reading_ = false;
    reply_writer<::asio::ip::tcp::socket> writer_{socket_};
};

} // namespace ferrule::host
