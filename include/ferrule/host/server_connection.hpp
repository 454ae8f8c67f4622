// server_connection: what each connection of ferrule's TCP servers (Modbus TCP, Extended
// MEMOBUS) does the same way beneath its protocol: a non-blocking socket without Nagle's
// delay, the idle timeout and the request deadline (idle_watch), reading only once all bytes
// read before are used (so a connection takes no more than its session can hold), and
// replies through reply_writer. tcp_listener, below, is their listening socket.
//
// A connection derives from server_connection<Connection> and gives it
//     void feed()                  use the bytes of unused() (use(n) each), then call read_on()
//     void end(close_reason why)   count and close, once; calls shut()
// and, to see each read's bytes before feed() does,
//     void received(std::span<const std::uint8_t> bytes)
// It tells the watch where requests begin and end (request_begun(), request_completed()),
// by its framing of the bytes.
#pragma once

#include <asio/buffer.hpp>
#include <asio/ip/tcp.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <system_error>
#include <utility>

#include "ferrule/core/time.hpp"
#include "ferrule/host/idle_watch.hpp"
#include "ferrule/host/reply_writer.hpp"

namespace ferrule::host {

// Why a server closed a connection, or refused it.
enum class close_reason : std::uint8_t {
    peer,            // the peer closed it, or an I/O error ended it
    refused,         // beyond the server's connection (channel) limit
    idle,            // no complete request for idle_timeout
    request_timeout, // a request not complete request_timeout after its first byte
    unframeable,     // bytes that no request can start with (Modbus TCP: a bad MBAP header)
};

template <class Connection>
class server_connection : public std::enable_shared_from_this<Connection> {
public:
    explicit server_connection(::asio::ip::tcp::socket socket)
        : socket_(std::move(socket)), watch_(socket_.get_executor()) {}
    server_connection(const server_connection&) = delete;
    server_connection& operator=(const server_connection&) = delete;

    // Once, right after the connection is made shared.
    void start(const connection_limits& limits) {
        std::error_code ec;
        socket_.non_blocking(true, ec);
        socket_.set_option(::asio::ip::tcp::no_delay(true), ec);
        watch_.start(limits, this->shared_from_this(), [this](idle_watch::expiry e) {
            if (ending_) return self().end(*ending_);
            self().end(e == idle_watch::expiry::idle ? close_reason::idle
                                                     : close_reason::request_timeout);
        });
        read_on();
    }

    void shut() {
        std::error_code ec;
        socket_.close(ec);
        watch_.cancel();
    }

protected:
    // The bytes read and not yet used; use(n) takes n of them off the front.
    std::span<const std::uint8_t> unused() const noexcept {
        return {rx_.data() + rx_pos_, rx_size_ - rx_pos_};
    }
    void use(std::size_t n) noexcept { rx_pos_ += n; }
    // When the bytes of the last read came.
    time_point received_at() const noexcept { return received_at_; }

    // Reads again when all is used, no read is under way and the replies do not back up.
    void read_on() {
        if (ending_ || reading_ || rx_pos_ < rx_size_ || backlogged() || !socket_.is_open()) return;
        reading_ = true;
        socket_.async_read_some(::asio::buffer(rx_),
                                [keep = this->shared_from_this()](
                                    std::error_code ec, std::size_t n) { keep->on_read(ec, n); });
    }

    void send(std::span<const std::uint8_t> bytes) {
        const auto ec = writer_.send(bytes, this->shared_from_this(), [this](std::error_code e) {
            if (e) return self().end(close_reason::peer);
            self().feed();
        });
        if (ec) self().end(close_reason::peer);
    }

    bool backlogged() const noexcept { return writer_.backlogged(); }

    // A byte of a request has come (nothing happens while one is under way already); the
    // request is complete.
    void request_begun() noexcept { watch_.begun(); }
    void request_completed() noexcept { watch_.completed(); }

    // Of the unused bytes only the first `n` are used, and nothing more is read: the
    // connection is to end for `why` once its requests before them are answered.
    void read_no_more(std::size_t n, close_reason why) noexcept {
        rx_size_ = rx_pos_ + n;
        ending_ = why;
    }
    bool ending() const noexcept { return ending_.has_value(); }
    // Ends the connection for read_no_more()'s reason once the replies sent have gone (the
    // writer's drain calls feed() again); feed() calls it when all is answered.
    void end_when_sent() {
        if (writer_.idle()) self().end(*ending_);
    }

    // A connection that frames as feed() uses the bytes needs no look at them before.
    void received(std::span<const std::uint8_t>) noexcept {}

    ::asio::ip::tcp::socket socket_;

private:
    Connection& self() noexcept { return static_cast<Connection&>(*this); }

    void on_read(std::error_code ec, std::size_t n) {
        reading_ = false;
        rx_pos_ = 0;
        rx_size_ = ec ? 0 : n;
        if (ec) return self().end(close_reason::peer);
        received_at_ = steady_now();
        self().received(unused());
        self().feed();
    }

    idle_watch watch_;
    std::array<std::uint8_t, 512> rx_{};
    std::size_t rx_pos_ = 0;
    std::size_t rx_size_ = 0;
    time_point received_at_{};
    bool reading_ = false;
    std::optional<close_reason> ending_;
    reply_writer<::asio::ip::tcp::socket> writer_{socket_};
};

// The listening socket of ferrule's TCP servers: binds, listens and hands each accepted
// connection to the server, until close().
class tcp_listener {
public:
    using admit_handler = std::function<void(::asio::ip::tcp::socket)>;

    explicit tcp_listener(::asio::any_io_executor ex) : acceptor_(ex) {}

    // Binds, listens and starts accepting: `admit` gets each connection, on the executor's
    // thread. Port 0 picks a free port (see port()).
    std::error_code listen(const ::asio::ip::tcp::endpoint& at, admit_handler admit) {
        std::error_code ec;
        acceptor_.open(at.protocol(), ec);
        if (!ec) acceptor_.set_option(::asio::socket_base::reuse_address(true), ec);
        if (!ec) acceptor_.bind(at, ec);
        if (!ec) acceptor_.listen(::asio::socket_base::max_listen_connections, ec);
        if (ec) return ec;
        admit_ = std::move(admit);
        accept();
        return {};
    }

    std::uint16_t port() const {
        std::error_code ec;
        return acceptor_.local_endpoint(ec).port();
    }

    // Stops accepting; connections already admitted are the server's to close.
    void close() {
        std::error_code ec;
        acceptor_.close(ec);
    }

private:
    void accept() {
        acceptor_.async_accept([this](std::error_code ec, ::asio::ip::tcp::socket socket) {
            if (ec == ::asio::error::operation_aborted || !acceptor_.is_open()) return;
            if (!ec) admit_(std::move(socket));
            accept();
        });
    }

    ::asio::ip::tcp::acceptor acceptor_;
    admit_handler admit_;
};

} // namespace ferrule::host
