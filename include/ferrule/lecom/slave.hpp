// LECOM slave session (the drive's side of the line), sans-I/O.
//
// Behaviour (lecom.md §1.3-§1.5, §1.11-§1.13):
//   * telegrams are framed by their characters, not by gaps: every master telegram starts
//     with EOT, a RECEIVE ends with ENQ, a SEND with ETX BCC (frame_decoder, requests)
//   * a drive acts on its own address (C0009), on 00 (all drives) and on its group x0
//     (x1…x9); telegrams for other drives are ignored (S1 p.6-3, S2 §6.1)
//   * a SEND with a bad BCC for this drive's own address is answered NAK by the session
//     itself (S1 p.8-20: NAK = a fault in the block); a RECEIVE carries no BCC
//   * a request the drive cannot decode stays unanswered (S1 §8.3.5: silence on a fault)
//   * 00 and x0 are never answered, SEND or RECEIVE (S1 p.6-3, p.8-24; lecom.md §1.11)
//   * the reply goes out processing_time after the request's last character (S3: t3 =
//     20 ms); a new telegram before it has gone out means the master has moved on, and the
//     reply is dropped
//   * bare_replies: the 4900 style of the LECOM paper, a bare EOT for "code does not exist"
//     and a bare NAK for a checksum fault in a RECEIVE, instead of STX C1 C2 EOT and
//     STX C1 C2 ? ETX BCC (lecom.md §1.4, UNCERTAIN: hence configurable)
//
// The session knows no character time: a request that ends inside a chunk of bytes is
// taken to end with the chunk. Bytes behind a request wait until it has been answered or
// consumed, so a broadcast and the next request read from a port at once are both served.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/queued_reply.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/static_buffer.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/lecom/constants.hpp"
#include "ferrule/lecom/frame.hpp"

namespace ferrule::lecom {

struct slave_config {
    std::uint8_t address = 1; // C0009: 01…99 except x0 (S1 p.6-3)
    duration processing_time = lecom::processing_time;
    bool bare_replies = false; // 4900 style replies to RECEIVE (lecom.md §1.4, UNCERTAIN)
};

struct slave_stats {
    std::uint32_t requests = 0;              // decoded requests for this drive
    std::uint32_t no_reply_requests = 0;     // of those: to 00 / x0, never answered
    std::uint32_t replies = 0;               // replies handed out by next()
    std::uint32_t abandoned = 0;             // replies dropped: a new telegram came first
    std::uint32_t ignored_other_address = 0; // telegrams for other drives
    std::uint32_t bad_checksum = 0;          // SENDs for this drive with a BCC mismatch
    std::uint32_t malformed = 0;             // telegrams for this drive that do not decode, garbage
    std::uint32_t overflowed = 0;            // bytes lost: too many behind a pending request
};

class slave {
public:
    // Bytes behind a pending request that are kept for later (a pty read's worth).
    static constexpr std::size_t held_capacity = 256;

    explicit slave(const slave_config& cfg = {}) noexcept : cfg_(cfg) {}

    // A chunk of bytes from the line whose last byte ended at `end`.
    void on_receive(std::span<const std::uint8_t> bytes, time_point end) noexcept {
        if (bytes.empty()) return;
        if (request_pending_) {
            hold(bytes, end);
            return;
        }
        feed(bytes, end);
    }

    // A request waits for respond() or consume().
    bool has_request() const noexcept { return request_pending_; }
    // The pending request (valid while has_request()).
    const frame& request() const noexcept { return request_; }
    // When the pending request's last character ended on the wire.
    time_point request_end() const noexcept { return request_end_; }
    // False for 00 and x0, SEND or RECEIVE (S1 p.8-24).
    bool response_expected() const noexcept { return !is_group_address(request_.address); }

    // Queues the reply to the pending request. A RECEIVE takes data / fault / no_code with
    // the request's code field, or a bare eot / nak; a SEND takes ack or nak. With
    // bare_replies a no_code reply goes out as a bare EOT and a fault reply as a bare NAK.
    // Refused with errc::no_response_expected for 00 / x0: consume() those.
    ferrule::error respond(const frame& reply) noexcept {
        if (!request_pending_) return errc::invalid_argument;
        if (!response_expected()) return errc::no_response_expected;
        if (!fits(reply)) return errc::invalid_argument;
        frame out = reply;
        if (cfg_.bare_replies && out.kind == frame_kind::no_code) out = frame{frame_kind::eot};
        if (cfg_.bare_replies && out.kind == frame_kind::fault) out = frame{frame_kind::nak};
        const auto n = encode(out, reply_.buffer());
        if (!n) return n.error();
        request_pending_ = false;
        queue(*n, request_end_);
        resume();
        return {};
    }

    // Drops the pending request without an answer (required for 00 / x0).
    void consume() noexcept {
        if (!request_pending_) return;
        request_pending_ = false;
        resume();
    }

    // idle: listening; done: a request waits for respond() / consume(); wait: a reply is
    // queued for the deadline; send: put these bytes on the line now.
    session_action next(time_point now) noexcept {
        return reply_.next(now, request_pending_, stats_.replies);
    }

    // When the queued reply is due; `never` when none is queued (a pending request waits for
    // the application, not for a time).
    time_point wake_at() const noexcept { return reply_.due(); }

    std::uint8_t address() const noexcept { return cfg_.address; }
    // A new C0009 takes effect for the next telegram; 00 and x0 are not unit addresses
    // (S1 p.6-3) and leave the address as it is.
    void set_address(std::uint8_t a) noexcept {
        if (is_unit_address(a)) cfg_.address = a;
    }
    // Does a telegram to `target` concern this drive?
    bool addressed(std::uint8_t target) const noexcept {
        return lecom::addresses(target, cfg_.address);
    }

    const slave_stats& stats() const noexcept { return stats_; }
    const slave_config& config() const noexcept { return cfg_; }

private:
    void feed(std::span<const std::uint8_t> in, time_point end) noexcept {
        std::size_t offset = 0;
        while (offset < in.size() && !request_pending_) {
            const auto step = decoder_.feed(in.subspan(offset));
            offset += step.consumed;
            const bool telegram = step.what == frame_decoder::status::frame || decoder_.in_frame();
            if (reply_.queued() && telegram) {
                reply_.drop();
                ++stats_.abandoned;
            }
            if (step.what == frame_decoder::status::error) ++stats_.malformed;
            if (step.what == frame_decoder::status::frame) accept(decoder_.frame(), end);
        }
        if (offset < in.size()) hold(in.subspan(offset), end);
    }

    // Keeps bytes for after the pending request (their end time is the latest chunk's).
    void hold(std::span<const std::uint8_t> in, time_point end) noexcept {
        stats_.overflowed += static_cast<std::uint32_t>(held_.hold(in, end));
    }

    // Decodes the held bytes once the pending request is done with.
    void resume() noexcept {
        if (held_.empty()) return;
        held_.release([this](std::span<const std::uint8_t> in, time_point end) { feed(in, end); });
    }

    // A telegram from the decoder: EOT, two digits, then a RECEIVE or SEND body.
    void accept(std::span<const std::uint8_t> t, time_point end) noexcept {
        const auto target = static_cast<std::uint8_t>((t[1] - '0') * 10 + (t[2] - '0'));
        if (!addressed(target)) {
            ++stats_.ignored_other_address;
            return;
        }
        const auto f = parse_request(t);
        if (!f) {
            if (f.error() != errc::bad_checksum) {
                ++stats_.malformed;
                return;
            }
            // Only a SEND has a BCC. Its NAK is the session's own answer (S1 p.8-20); 00
            // and x0 get none (S1 p.8-24).
            ++stats_.bad_checksum;
            if (target == cfg_.address) {
                reply_.buffer()[0] = nak;
                queue(1, end);
            }
            return;
        }
        ++stats_.requests;
        request_ = *f;
        request_end_ = end;
        request_pending_ = true;
        if (!response_expected()) ++stats_.no_reply_requests;
    }

    // Is `reply` an answer to the pending request (S1 p.8-21…8-23)?
    bool fits(const frame& reply) const noexcept {
        if (request_.kind == frame_kind::send)
            return reply.kind == frame_kind::ack || reply.kind == frame_kind::nak;
        switch (reply.kind) {
        case frame_kind::data:
        case frame_kind::fault:
        case frame_kind::no_code: return reply.code == request_.code;
        case frame_kind::eot:
        case frame_kind::nak: return true;
        default: return false;
        }
    }

    void queue(std::size_t n, time_point request_end) noexcept {
        reply_.queue(n, request_end + cfg_.processing_time);
    }

    slave_config cfg_;
    slave_stats stats_{};
    bool request_pending_ = false; // waits for respond() / consume()
    frame_decoder decoder_{frame_decoder::accept::requests};
    frame request_{};
    time_point request_end_{};
    queued_reply<max_reply_length> reply_{};
    held_bytes<held_capacity> held_{};
};

static_assert(station<slave>);

} // namespace ferrule::lecom
