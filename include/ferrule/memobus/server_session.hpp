// One Extended MEMOBUS channel of the controller's side as a station (core/station.hpp),
// sans-I/O: the bytes one master sends in, the replies of a memobus::server (server.hpp) on
// the register image out, in order. Fixed buffers, no heap.
//
//   * TCP: the byte stream is split into messages by their headers (message_decoder, §2); a
//     run of bytes that starts no message is counted once (stats().malformed) and framing
//     goes on from the byte after its first
//   * UDP: each on_receive() is one datagram, and a datagram is one message (§6): one that is
//     not a whole message is not answered (the server counts it as ignored)
//   * a reply is due when the last byte of its message came (an MP answers as soon as its
//     MSG-RCV has run); messages behind a reply not yet handed out wait for it (TCP: up to
//     held_capacity bytes; a datagram is not handled: over UDP a master waits for each reply)
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/queued_reply.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/static_buffer.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/memobus/constants.hpp"
#include "ferrule/memobus/header.hpp"
#include "ferrule/memobus/server.hpp"

namespace ferrule::memobus {

enum class transport : std::uint8_t { tcp, udp };

struct session_stats {
    std::uint32_t messages = 0;   // messages framed (TCP) or datagrams (UDP) handed to the server
    std::uint32_t malformed = 0;  // TCP: runs of bytes that form no message
    std::uint32_t overflowed = 0; // bytes lost behind a reply not yet handed out
};

class server_session {
public:
    // TCP: bytes kept behind a reply not yet handed out (one whole message).
    static constexpr std::size_t held_capacity = max_message;

    server_session(std::span<std::uint16_t> mw, std::span<std::uint16_t> iw,
                   const channel_config& cfg = {}, transport t = transport::tcp) noexcept
        : server_(cfg), mw_(mw), iw_(iw), transport_(t) {}
    // On a register_image (or any image with mw() and iw()), which must outlive the session.
    template <class Image>
    explicit server_session(Image& image, const channel_config& cfg = {},
                            transport t = transport::tcp) noexcept
        : server_session(std::span<std::uint16_t>(image.mw()), std::span<std::uint16_t>(image.iw()),
                         cfg, t) {}

    // Bytes of the connection, or one datagram, whose last byte came at `end`.
    void on_receive(std::span<const std::uint8_t> bytes, time_point end) noexcept {
        if (bytes.empty()) return;
        if (transport_ == transport::udp) {
            if (reply_.queued())
                stats_.overflowed += static_cast<std::uint32_t>(bytes.size());
            else
                handle(bytes, end);
            return;
        }
        if (reply_.queued() || !held_.empty()) {
            stats_.overflowed += static_cast<std::uint32_t>(held_.hold(bytes, end));
            return;
        }
        feed(bytes, end);
    }

    // send: the next reply, now; idle: none is waiting.
    session_action next(time_point now) noexcept {
        if (!reply_.queued() && !held_.empty())
            held_.release(
                [this](std::span<const std::uint8_t> in, time_point end) { feed(in, end); });
        return reply_.next(now);
    }

    // When next() has a reply, or held messages to frame; `never` when neither.
    time_point wake_at() const noexcept {
        if (reply_.queued()) return reply_.due();
        return held_.empty() ? never : scheduled(held_.end());
    }

    // TCP: bytes have been framed since the last message that have not made one (the start
    // of a message, or bytes that start none). Bytes held behind a reply are not yet framed.
    bool in_message() const noexcept { return in_message_; }

    const session_stats& stats() const noexcept { return stats_; }
    // The channel's request handler: its configuration and counts.
    const memobus::server& handler() const noexcept { return server_; }
    void set_config(const channel_config& cfg) noexcept { server_.set_config(cfg); }

private:
    void feed(std::span<const std::uint8_t> in, time_point end) noexcept {
        using status = message_decoder::status;
        while (!in.empty() && !reply_.queued()) {
            const auto s = decoder_.feed(in);
            in = in.subspan(s.consumed);
            if (s.what == status::error) ++stats_.malformed;
            if (s.what == status::frame) handle(decoder_.message(), end);
            in_message_ = decoder_.in_message() ||
                          (s.what == status::frame ? false : in_message_ || s.consumed > 0);
        }
        if (!in.empty()) stats_.overflowed += static_cast<std::uint32_t>(held_.hold(in, end));
    }

    void handle(std::span<const std::uint8_t> message, time_point end) noexcept {
        ++stats_.messages;
        const std::size_t n = server_.handle(message, mw_, iw_, reply_.buffer());
        if (n > 0) reply_.queue(n, end);
    }

    memobus::server server_;
    std::span<std::uint16_t> mw_;
    std::span<std::uint16_t> iw_;
    transport transport_;
    message_decoder decoder_{};
    bool in_message_ = false;
    queued_reply<max_message> reply_{};
    held_bytes<held_capacity> held_{};
    session_stats stats_{};
};

static_assert(station<server_session>);

} // namespace ferrule::memobus
