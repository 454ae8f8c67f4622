// memobus_server: an MP controller's Extended MEMOBUS side for many masters at once, with
// standalone asio: one register image, served over TCP and UDP, each master on its own
// channel, as an MP2310 serves several PCs on its transmission buffer channels with one
// MSG-RCV each (seeds/004; protocols/memobus.md §6, §10.4).
//
//   * a channel is one TCP connection or one UDP master (an IP address, below), with its own
//     memobus::server_session and so its own channel_config (offsets, write range): channel i
//     takes options.channels[i], or options.channel when there is none; a new connection or
//     UDP master takes the lowest free channel
//   * at most `max_channels` at once, TCP and UDP together (218IFA: 4, 218IF: 10, seeds/004;
//     MotionAPI: 20, §6, §11.4): a TCP connection beyond it is accepted and closed at once
//     and counted as refused; a command from a UDP master beyond it is refused (below)
//   * TCP: the session of each connection frames its messages (§2), so a master that sends
//     garbage, half a header or a header announcing 65535 bytes disturbs only its own channel:
//     its session resynchronises (max_message bounds what it waits for) or waits while the
//     others are served. Requests are answered in order, pipelined ones too (§6 assumes none). A
//     connection is closed when no message has completed for `idle_timeout`, or when one is
//     not complete `request_timeout` after its first byte (bytes that form no message count
//     as one), so a master that sends a byte now and then holds no channel
//   * UDP: one datagram is one message (§6), and a UDP master is its IP address: one
//     channel per address, answered at the port its last command came from
//       - a datagram from no master takes a channel only when it is a 218 command (type 0x11,
//         both lengths agreeing, §2, §10.1); anything else is dropped and counted (ignored)
//       - a command from a new port of a master's address moves the master's channel to that
//         port, offsets and counts and all: a PC program that runs again sends from a new
//         ephemeral port, and the server answers each datagram before it reads the next, so
//         the old port has no request outstanding. (An MP's connection table names the PC's
//         address and port, §6; a master that does not fix its port is known here by its
//         address. Two programs on one PC share its UDP channel; over TCP each has its own.)
//       - a master silent for `idle_timeout` gives up its channel when another master or a
//         TCP connection needs one
//       - a command from a new address when no channel is free is refused: dropped (UDP has
//         no refusal a master could see), counted, and passed to `on_udp_refused`
//     A reply the socket does not take at once is dropped (and counted), as a datagram may be
//   * replies are sent straight from the session's buffer; only the part a TCP socket does
//     not take at once is copied to wait for it, and a master that does not read its replies
//     is not read from while reply_writer::backlog_limit bytes of them wait
//
// One io_context thread runs the server; the image is only touched from it (post to it).
// Statistics, the server's and each channel's, are atomics readable from any thread.
#pragma once

#include <asio/ip/tcp.hpp>
#include <asio/ip/udp.hpp>
#include <asio/steady_timer.hpp>
#include <asio/write.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <optional>
#include <span>
#include <system_error>
#include <utility>
#include <vector>

#include "ferrule/core/session.hpp"
#include "ferrule/host/serial_stream.hpp"
#include "ferrule/host/server_connection.hpp"
#include "ferrule/memobus/header.hpp"
#include "ferrule/memobus/server.hpp"
#include "ferrule/memobus/server_session.hpp"

namespace ferrule::host {

struct memobus_server_options {
    std::size_t max_channels = 4;
    duration idle_timeout = std::chrono::seconds(60); // zero: never
    memobus::channel_config channel{};                // every channel without its own
    std::vector<memobus::channel_config> channels{};  // channel i's, i = 0, 1, …
    // TCP: from a message's first byte to its last (zero: never); as Modbus TCP's
    // (modbus_tcp_server_options): a message fits a segment or a few, 2 s allow a
    // retransmission.
    duration request_timeout = std::chrono::seconds(2);
    // Called on the server's thread with the sender of each refused UDP command.
    std::function<void(const ::asio::ip::udp::endpoint&)> on_udp_refused{};
};

// Counted on the server's thread, readable from any other.
struct memobus_server_stats {
    std::atomic<std::uint64_t> accepted{0};    // TCP connections given a channel
    std::atomic<std::uint64_t> refused{0};     // TCP connections over max_channels
    std::atomic<std::uint64_t> idle_closed{0}; // closed after idle_timeout
    std::atomic<std::uint64_t> closed{0};      // by the master, or after an I/O error
    std::atomic<std::uint64_t> udp_peers{0};   // UDP masters (addresses) given a channel
    std::atomic<std::uint64_t> udp_moved{0};   // channels moved to their master's new port
    std::atomic<std::uint64_t> udp_refused{0}; // commands of new masters, no channel free
    std::atomic<std::uint64_t> udp_ignored{0}; // datagrams of no master that are no command
    std::atomic<std::uint64_t> udp_unsent{0};  // replies the UDP socket did not take
    std::atomic<std::uint64_t> replies{0};
    // TCP connections closed with a message not complete request_timeout after its first byte
    std::atomic<std::uint64_t> request_timeouts{0};
};

// One channel's counts over every connection or peer it has served (channel_stats()).
struct memobus_channel_stats {
    bool open = false;
    std::uint64_t opened = 0;    // connections or peers served
    std::uint64_t malformed = 0; // TCP: runs of bytes that form no message
    std::uint64_t requests = 0;
    std::uint64_t responses = 0;
    std::uint64_t sfc_errors = 0;
    std::uint64_t address_errors = 0;
    std::uint64_t count_errors = 0;
    std::uint64_t general = 0;
    std::uint64_t ignored = 0;
    std::uint64_t bytes_in = 0;
    std::uint64_t bytes_out = 0;
};

template <class Image>
class memobus_server {
public:
    memobus_server(::asio::any_io_executor ex, Image& image, memobus_server_options o = {})
        : listener_(ex), udp_(ex), image_(image), options_(std::move(o)),
          slots_(std::make_unique<slot[]>(options_.max_channels)) {}
    memobus_server(const memobus_server&) = delete;
    memobus_server& operator=(const memobus_server&) = delete;
    ~memobus_server() { close(); }

    // Binds, listens and starts accepting TCP connections. Port 0 picks a free port.
    std::error_code listen(const ::asio::ip::tcp::endpoint& at) {
        return listener_.listen(at, [this](::asio::ip::tcp::socket s) { admit(std::move(s)); });
    }

    // Binds the UDP socket and starts receiving. Port 0 picks a free port.
    std::error_code open_udp(const ::asio::ip::udp::endpoint& at) {
        std::error_code ec;
        udp_.open(at.protocol(), ec);
        if (!ec) udp_.bind(at, ec);
        if (!ec) udp_.non_blocking(true, ec);
        if (ec) return ec;
        receive();
        return {};
    }

    std::uint16_t port() const { return listener_.port(); }
    std::uint16_t udp_port() const {
        std::error_code ec;
        return udp_.local_endpoint(ec).port();
    }

    // Stops accepting and receiving and closes every channel.
    void close() {
        listener_.close();
        std::error_code ec;
        udp_.close(ec);
        for (auto& c : connections_) {
            c->shut();
            release(c->channel());
        }
        connections_.clear();
        for (const auto& p : peers_) release(p.channel);
        peers_.clear();
    }

    std::size_t max_channels() const noexcept { return options_.max_channels; }
    // Channels in use, from any thread.
    std::size_t open_channels() const noexcept {
        std::size_t n = 0;
        for (std::size_t i = 0; i < options_.max_channels; ++i) n += slots_[i].open.load();
        return n;
    }
    const memobus_server_stats& stats() const noexcept { return stats_; }

    // Channel i's counts (i < max_channels()), from any thread.
    memobus_channel_stats channel_stats(std::size_t i) const noexcept {
        const slot& s = slots_[i];
        memobus_channel_stats r;
        r.open = s.open.load();
        r.opened = s.opened.load();
        r.malformed = s.malformed.load();
        std::array<std::uint64_t, fields.size()> v{};
        for (std::size_t k = 0; k < fields.size(); ++k) v[k] = s.counts[k].load();
        r.requests = v[0];
        r.responses = v[1];
        r.sfc_errors = v[2];
        r.address_errors = v[3];
        r.count_errors = v[4];
        r.general = v[5];
        r.ignored = v[6];
        r.bytes_in = v[7];
        r.bytes_out = v[8];
        return r;
    }

private:
    // memobus::channel_stats in the order of memobus_channel_stats.
    static constexpr std::array<std::uint32_t memobus::channel_stats::*, 9> fields{
        &memobus::channel_stats::requests,     &memobus::channel_stats::responses,
        &memobus::channel_stats::sfc_errors,   &memobus::channel_stats::address_errors,
        &memobus::channel_stats::count_errors, &memobus::channel_stats::general,
        &memobus::channel_stats::ignored,      &memobus::channel_stats::bytes_in,
        &memobus::channel_stats::bytes_out};

    struct slot {
        std::atomic<bool> open{false};
        std::atomic<std::uint64_t> opened{0};
        std::atomic<std::uint64_t> malformed{0};
        std::array<std::atomic<std::uint64_t>, fields.size()> counts{};
    };

    // A session of one channel and what of its counts has gone to the channel's slot.
    struct channel_session {
        memobus::server_session session;
        memobus::channel_stats published{};
        std::uint32_t published_malformed = 0;

        // The next reply that is due, its counts published first; empty when none is.
        std::span<const std::uint8_t> next_reply(memobus_server& owner, std::size_t channel) {
            const session_action a = session.next(steady_now());
            publish(owner, channel);
            if (a.what != session_action::kind::send) return {};
            ++owner.stats_.replies;
            return a.bytes;
        }

        void publish(memobus_server& owner, std::size_t channel) {
            const memobus::channel_stats& now = session.handler().stats();
            slot& s = owner.slots_[channel];
            for (std::size_t k = 0; k < fields.size(); ++k)
                s.counts[k] += static_cast<std::uint32_t>(now.*fields[k] - published.*fields[k]);
            published = now;
            s.malformed += session.stats().malformed - published_malformed;
            published_malformed = session.stats().malformed;
        }
    };

    std::optional<std::size_t> take() {
        for (std::size_t i = 0; i < options_.max_channels; ++i) {
            if (slots_[i].open.load()) continue;
            slots_[i].open = true;
            ++slots_[i].opened;
            return i;
        }
        return std::nullopt;
    }
    void release(std::size_t i) { slots_[i].open = false; }
    memobus::channel_config config_of(std::size_t i) const {
        return i < options_.channels.size() ? options_.channels[i] : options_.channel;
    }

    // --- TCP -------------------------------------------------------------------------------
    class connection : public server_connection<connection> {
        using base = server_connection<connection>;
        friend base;
        using base::backlogged;
        using base::read_on;
        using base::received_at;
        using base::request_begun;
        using base::request_completed;
        using base::send;
        using base::socket_;
        using base::unused;
        using base::use;

    public:
        connection(memobus_server& owner, ::asio::ip::tcp::socket socket, std::size_t channel)
            : base(std::move(socket)), owner_(owner),
              channel_(channel), session_{memobus::server_session(owner.image_,
                                                                  owner.config_of(channel))} {}

        std::size_t channel() const noexcept { return channel_; }
        using base::shut;

    private:
        // Answers what was read, handing the session a chunk only when it has no reply
        // waiting, until all is used or the replies back up; reads on when all is used.
        void feed() {
            for (;;) {
                answer();
                if (!socket_.is_open()) return;
                if (backlogged() || session_.session.wake_at() != never || unused().empty()) break;
                const auto bytes = unused().first(
                    std::min(unused().size(), memobus::server_session::held_capacity));
                session_.session.on_receive(bytes, received_at());
                use(bytes.size());
            }
            read_on();
        }

        // Sends the replies that are due while the master takes them. The bytes since the
        // last message, whether they begin one or form none, are timed as a request.
        void answer() {
            while (!backlogged()) {
                const auto reply = session_.next_reply(owner_, channel_);
                if (reply.empty()) break;
                send(reply);
                if (!socket_.is_open()) return;
            }
            const std::uint32_t framed = session_.session.stats().messages;
            if (framed != framed_) request_completed();
            framed_ = framed;
            if (session_.session.in_message()) request_begun();
        }

        void end(close_reason why) {
            if (!socket_.is_open()) return;
            // Counted before the close that the master sees.
            ++owner_.counter(why);
            shut();
            owner_.release(channel_);
            owner_.forget(this);
        }

        memobus_server& owner_;
        std::size_t channel_;
        channel_session session_;
        std::uint32_t framed_ = 0; // the session's messages, as last timed
    };

    // The count of TCP connections closed for `why`.
    std::atomic<std::uint64_t>& counter(close_reason why) noexcept {
        switch (why) {
        case close_reason::refused: return stats_.refused;
        case close_reason::idle: return stats_.idle_closed;
        case close_reason::request_timeout: return stats_.request_timeouts;
        case close_reason::peer:
        case close_reason::unframeable: // not here: message_decoder resynchronises
            break;
        }
        return stats_.closed;
    }

    void admit(::asio::ip::tcp::socket socket) {
        const auto channel = take_or_reclaim();
        if (!channel) {
            ++counter(close_reason::refused);
            std::error_code ignored;
            socket.close(ignored);
            return;
        }
        ++stats_.accepted;
        auto c = std::make_shared<connection>(*this, std::move(socket), *channel);
        connections_.push_back(c);
        c->start({options_.idle_timeout, options_.request_timeout});
    }

    void forget(connection* c) {
        connections_.remove_if([c](const std::shared_ptr<connection>& p) { return p.get() == c; });
    }

    // --- UDP -------------------------------------------------------------------------------
    struct peer {
        ::asio::ip::udp::endpoint endpoint;
        std::size_t channel = 0;
        channel_session session;
        time_point last_activity{};
    };

    void receive() {
        udp_.async_receive_from(::asio::buffer(udp_rx_), udp_from_,
                                [this](std::error_code ec, std::size_t n) {
                                    if (ec == ::asio::error::operation_aborted || !udp_.is_open())
                                        return;
                                    if (!ec) on_datagram(n);
                                    receive();
                                });
    }

    void on_datagram(std::size_t n) {
        // A datagram longer than max_message fills udp_rx_ and is no message.
        const std::span<const std::uint8_t> datagram(udp_rx_.data(), n);
        peer* p = find_peer(udp_from_, datagram);
        if (p == nullptr) return;
        p->last_activity = steady_now();
        p->session.session.on_receive(datagram, p->last_activity);
        for (;;) {
            const auto reply = p->session.next_reply(*this, p->channel);
            if (reply.empty()) return;
            std::error_code ec;
            udp_.send_to(::asio::buffer(reply.data(), reply.size()), p->endpoint, 0, ec);
            if (ec) ++stats_.udp_unsent;
        }
    }

    // A free channel, or the channel of a UDP peer silent for idle_timeout (a UDP peer has no
    // connection to close: its channel is reclaimed when a new TCP connection or peer needs one).
    std::optional<std::size_t> take_or_reclaim() {
        if (auto channel = take()) return channel;
        if (options_.idle_timeout == duration::zero()) return std::nullopt;
        const time_point now = steady_now();
        for (auto it = peers_.begin(); it != peers_.end(); ++it) {
            if (now - it->last_activity < options_.idle_timeout) continue;
            release(it->channel);
            peers_.erase(it);
            return take();
        }
        return std::nullopt;
    }

    // The sender's peer, or null when the datagram is dropped. A sender that is no peer
    // becomes one only with a command: it takes the channel of its address's peer, a free
    // channel, or one of a peer silent for idle_timeout.
    peer* find_peer(const ::asio::ip::udp::endpoint& from, std::span<const std::uint8_t> datagram) {
        for (auto& p : peers_)
            if (p.endpoint == from) return &p;
        if (!is_command(datagram)) {
            ++stats_.udp_ignored;
            return nullptr;
        }
        for (auto& p : peers_) {
            if (p.endpoint.address() != from.address()) continue;
            p.endpoint = from;
            ++stats_.udp_moved;
            return &p;
        }
        const auto channel = take_or_reclaim();
        if (!channel) {
            ++stats_.udp_refused;
            if (options_.on_udp_refused) options_.on_udp_refused(from);
            return nullptr;
        }
        ++stats_.udp_peers;
        peers_.push_back(
            {from,
             *channel,
             {memobus::server_session(image_, config_of(*channel), memobus::transport::udp)},
             {}});
        return &peers_.back();
    }

    // A whole 218 command (§2): what a master sends, and what garbage hardly ever is.
    static bool is_command(std::span<const std::uint8_t> datagram) noexcept {
        const auto h = memobus::parse_message(datagram);
        return h && h->type == memobus::command_type::command;
    }

    tcp_listener listener_;
    ::asio::ip::udp::socket udp_;
    Image& image_;
    memobus_server_options options_;
    memobus_server_stats stats_;
    std::unique_ptr<slot[]> slots_;
    std::list<std::shared_ptr<connection>> connections_;
    std::list<peer> peers_;
    std::array<std::uint8_t, memobus::max_message + 1> udp_rx_{};
    ::asio::ip::udp::endpoint udp_from_;
};

} // namespace ferrule::host
