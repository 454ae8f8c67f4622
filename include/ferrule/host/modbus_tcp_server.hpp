// modbus_tcp_server: serves one Modbus data model to many TCP clients at once (Modbus
// Messaging on TCP/IP Implementation Guide V1.0b), with standalone asio.
//
//   * each connection has its own modbus::server session (TCP transport) over the shared
//     model, so a client that sends half a request and stalls holds up nobody else: its
//     bytes wait in its own session while the others are served
//   * at most `max_connections` at once; a connection beyond that is accepted and closed at
//     once (the guide §4.2.1 leaves the number to the server: a closed connection tells the
//     client, a connection left in the backlog would not)
//   * requests are framed by their MBAP headers as the bytes come (mbap_framer); a
//     connection is closed when a request is not complete `request_timeout` after its first
//     byte, or when no request has completed for `idle_timeout` (§4.2.1: the server may close
//     connections it considers idle), so a client that sends a byte now and then holds no
//     connection; bytes alone reset neither
//   * a header that no Modbus request can start with (protocol id other than 0, length
//     outside 2…254) closes the connection once the requests before it are answered: the
//     stream has lost its framing, and the client learns it at once and reconnects, instead
//     of timing out on requests that a resynchronising server would swallow
//   * replies go out in the order of the requests, `processing_time` after each request
//     (0: at once); a reply is sent straight from the session's buffer, and only the part
//     the socket does not take at once is copied to wait for it
//
// One io_context thread runs the server; the model is only touched from it.
#pragma once

#include <asio/ip/tcp.hpp>
#include <asio/steady_timer.hpp>
#include <asio/write.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <system_error>
#include <vector>

#include "ferrule/core/session.hpp"
#include "ferrule/host/serial_stream.hpp"
#include "ferrule/host/server_connection.hpp"
#include "ferrule/modbus/data_model.hpp"
#include "ferrule/modbus/model_ref.hpp"
#include "ferrule/modbus/server.hpp"
#include "ferrule/modbus/tcp.hpp"

namespace ferrule::host {

struct modbus_tcp_server_options {
    std::size_t max_connections = 64;
    duration idle_timeout = std::chrono::seconds(60); // zero: never
    // From a request's first byte to its last (zero: never). No Modbus document gives one. A
    // request fits one TCP segment, so a sound client sends it at once; 2 s leave room for a
    // lost segment's retransmission (200 ms at the least on Linux, 1 s at first). libmodbus,
    // as a server too, allows 0.5 s between two bytes (its byte timeout, protocols/
    // modbus_profibus.md §A.3, §C.1).
    duration request_timeout = std::chrono::seconds(2);
    duration processing_time{};
    // Called on the server's thread for each connection the server closes or refuses itself
    // (every reason but close_reason::peer), with the client's address.
    std::function<void(const ::asio::ip::tcp::endpoint&, close_reason)> on_close{};
};

// Counted on the server's thread, readable from any other.
struct modbus_tcp_server_stats {
    std::atomic<std::uint64_t> accepted{0};
    std::atomic<std::uint64_t> refused{0};          // over max_connections
    std::atomic<std::uint64_t> idle_closed{0};      // no complete request for idle_timeout
    std::atomic<std::uint64_t> request_timeouts{0}; // a request not complete in request_timeout
    std::atomic<std::uint64_t> bad_headers{0};      // an MBAP header no request starts with
    std::atomic<std::uint64_t> closed{0};           // by the client, or after an I/O error
    std::atomic<std::uint64_t> replies{0};
};

template <modbus::data_model M>
class modbus_tcp_server {
public:
    modbus_tcp_server(::asio::any_io_executor ex, M& model, modbus_tcp_server_options o = {})
        : ex_(ex), listener_(ex), model_(model), options_(o) {}
    modbus_tcp_server(const modbus_tcp_server&) = delete;
    modbus_tcp_server& operator=(const modbus_tcp_server&) = delete;
    ~modbus_tcp_server() { close(); }

    // Binds, listens and starts accepting. Port 0 picks a free port (see port()).
    std::error_code listen(const ::asio::ip::tcp::endpoint& at) {
        return listener_.listen(at, [this](::asio::ip::tcp::socket s) { admit(std::move(s)); });
    }

    std::uint16_t port() const { return listener_.port(); }

    // Stops accepting and closes every connection.
    void close() {
        listener_.close();
        for (auto& c : connections_) c->shut();
        connections_.clear();
    }

    std::size_t connections() const noexcept { return connections_.size(); }
    const modbus_tcp_server_stats& stats() const noexcept { return stats_; }

private:
    using session_type = modbus::server<modbus::model_ref<M>>;

    class connection : public server_connection<connection> {
        using base = server_connection<connection>;
        friend base;
        using base::end_when_sent;
        using base::ending;
        using base::read_no_more;
        using base::read_on;
        using base::received_at;
        using base::request_begun;
        using base::request_completed;
        using base::send;
        using base::socket_;
        using base::unused;
        using base::use;

    public:
        connection(modbus_tcp_server& owner, ::asio::ip::tcp::socket socket)
            : base(std::move(socket)), owner_(owner), reply_timer_(socket_.get_executor()),
              session_(config(owner.options_), modbus::model_ref<M>(owner.model_)) {}

        void shut() {
            base::shut();
            reply_timer_.cancel();
        }

    private:
        static modbus::server_config config(const modbus_tcp_server_options& o) {
            modbus::server_config c;
            c.transport = modbus::transport::tcp;
            c.processing_time = o.processing_time;
            return c;
        }

        // Times the requests as their bytes come, by their MBAP headers; stops at a header
        // that starts none.
        void received(std::span<const std::uint8_t> bytes) {
            const auto s = framer_.feed(bytes);
            if (s.ended > 0) request_completed();
            if (framer_.bad()) return read_no_more(s.taken, close_reason::unframeable);
            if (framer_.in_adu()) request_begun();
        }

        // Gives the session what it can take: a chunk no larger than it holds behind a
        // request, and only while no reply is waiting, so that a client sending many requests
        // at once (guide §3.1.2 lets it) loses none. Reads on when all is fed, unless replies
        // back up; after a bad header, ends once all before it is answered.
        void feed() {
            while (!unused().empty() && session_.wake_at() == never) {
                const auto bytes =
                    unused().first(std::min(unused().size(), session_type::held_capacity));
                session_.on_receive(bytes, received_at());
                use(bytes.size());
                pump();
                if (!socket_.is_open()) return;
            }
            if (ending() && unused().empty() && session_.wake_at() == never) return end_when_sent();
            read_on();
        }

        // Hands out every reply that is due; sleeps until the next one.
        void pump() {
            for (;;) {
                const time_point now = steady_now();
                const session_action a = session_.next(now);
                if (a.what == session_action::kind::send) {
                    ++owner_.stats_.replies;
                    send(a.bytes);
                    continue;
                }
                if (a.what == session_action::kind::wait && a.deadline != never) {
                    reply_timer_.expires_at(std::chrono::steady_clock::time_point(
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            a.deadline.time_since_epoch())));
                    reply_timer_.async_wait([self = this->shared_from_this()](std::error_code e) {
                        if (e) return;
                        self->pump();
                        if (self->socket_.is_open()) self->feed();
                    });
                }
                return;
            }
        }

        void end(close_reason why) {
            if (!socket_.is_open()) return;
            // Counted before the close that the client sees.
            owner_.closing(socket_, why);
            shut();
            owner_.forget(this);
        }

        modbus_tcp_server& owner_;
        ::asio::steady_timer reply_timer_;
        session_type session_;
        modbus::mbap_framer framer_;
    };

    // Counts a connection that ends for `why`; one the server closes or refuses itself goes to
    // on_close too.
    void closing(const ::asio::ip::tcp::socket& socket, close_reason why) {
        ++counter(why);
        if (why == close_reason::peer || !options_.on_close) return;
        std::error_code ec;
        const auto peer = socket.remote_endpoint(ec);
        if (!ec) options_.on_close(peer, why);
    }

    std::atomic<std::uint64_t>& counter(close_reason why) noexcept {
        switch (why) {
        case close_reason::refused: return stats_.refused;
        case close_reason::idle: return stats_.idle_closed;
        case close_reason::request_timeout: return stats_.request_timeouts;
        case close_reason::unframeable: return stats_.bad_headers;
        case close_reason::peer: break;
        }
        return stats_.closed;
    }

    void admit(::asio::ip::tcp::socket socket) {
        if (connections_.size() >= options_.max_connections) {
            closing(socket, close_reason::refused);
            std::error_code ignored;
            socket.close(ignored);
            return;
        }
        ++stats_.accepted;
        auto c = std::make_shared<connection>(*this, std::move(socket));
        connections_.push_back(c);
        c->start({options_.idle_timeout, options_.request_timeout});
    }

    void forget(connection* c) {
        connections_.remove_if([c](const std::shared_ptr<connection>& p) { return p.get() == c; });
    }

    ::asio::any_io_executor ex_;
    tcp_listener listener_;
    M& model_;
    modbus_tcp_server_options options_;
    modbus_tcp_server_stats stats_;
    std::list<std::shared_ptr<connection>> connections_;
};

} // namespace ferrule::host
