// MOVILINK slave session (the inverter's side), sans-I/O.
//
// Behaviour (movilink.md §1.4, §1.6, §1.7):
//   * telegrams are framed by the start pause: a gap >= start_pause before a byte makes it a
//     possible SD1; a gap > max_char_delay inside a telegram breaks it, and everything up to
//     the next start pause is skipped (SC01 p.19, p.27)
//   * only error-free requests for this unit are processed: its single address, 254
//     (point-to-point), its group (100 = no group) and 255 (broadcast); faulty requests get
//     no answer at all (SC01 p.28, "receiver rules")
//   * group and broadcast requests are processed but never answered (SC01 p.21-22)
//   * the reply goes out no earlier than start_pause + processing_time after the request's
//     BCC: "inverter waits >= 3.44 ms idle" (SC01 p.19)
//   * bus activity before the reply has gone out means the master has moved on (or the line
//     was not clean): the pending request is dropped
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/queued_reply.hpp"
#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/movilink/constants.hpp"
#include "ferrule/movilink/frame.hpp"

namespace ferrule::movilink {

struct slave_config {
    std::uint8_t address = 1; // RS-485 address P810, 0-99
    std::uint8_t group = 100; // group address P811, 100-199; 100 = member of no group
    serial_format format = default_format;
    duration start_pause = movilink::start_pause;
    duration max_char_delay = movilink::max_char_delay;
    duration processing_time{}; // extra delay before replying, beyond the start pause
};

struct slave_stats {
    std::uint32_t requests = 0;              // error-free requests for this unit
    std::uint32_t no_reply_requests = 0;     // of those: group / broadcast, never answered
    std::uint32_t replies = 0;               // replies handed out by next()
    std::uint32_t abandoned = 0;             // requests dropped: a new telegram came first
    std::uint32_t ignored_other_address = 0; // error-free requests for other units
    std::uint32_t bad_checksum = 0;          // BCC mismatch
    std::uint32_t malformed = 0;             // bad SD / TYP, bytes behind a telegram
    std::uint32_t gap_errors = 0;            // telegrams broken by a character delay
    std::uint32_t skipped_bytes = 0;         // broken telegrams up to the next start pause
};

class slave {
public:
    explicit slave(const slave_config& cfg = {}) noexcept : cfg_(cfg) {}

    // A chunk of back-to-back bytes whose last byte ended at `now`.
    void on_receive(std::span<const std::uint8_t> in, time_point now) noexcept {
        if (in.empty()) return;
        const time_point first_start = now - cfg_.format.chars_time(in.size());
        const duration gap = first_start - last_end_;
        const bool after_idle = !heard_ || gap >= cfg_.start_pause;
        const bool gap_too_long = heard_ && gap > cfg_.max_char_delay;
        heard_ = true;
        last_end_ = now;

        if (request_pending_ || reply_.queued()) {
            // A new telegram: the master gave up on this one. Without a start pause the
            // bytes belong to the request itself, which the decoder reports as malformed.
            if (after_idle) ++stats_.abandoned;
            request_pending_ = false;
            reply_.drop();
        }
        if (after_idle) {
            if (decoder_.in_frame()) break_telegram();
            decoder_.idle();
            skipping_ = false;
        } else if (gap_too_long && decoder_.in_frame()) {
            // SC01 p.27: characters more than max_char_delay apart are not one telegram.
            break_telegram();
            skipping_ = true;
        }
        if (skipping_) {
            stats_.skipped_bytes += static_cast<std::uint32_t>(in.size());
            return;
        }

        std::size_t offset = 0;
        while (offset < in.size()) {
            const std::size_t partial = decoder_.in_frame() ? decoder_.buffered() : 0;
            const std::size_t from = offset;
            const auto step = decoder_.feed(in.subspan(offset));
            offset += step.consumed;
            if (step.what == decoder::status::error) {
                // Bytes right behind a request also spoil it: the line was not clean.
                request_pending_ = false;
                if (step.ec == errc::bad_checksum)
                    ++stats_.bad_checksum;
                else
                    ++stats_.malformed;
                // The broken telegram and everything up to the next start pause.
                stats_.skipped_bytes += static_cast<std::uint32_t>(partial + in.size() - from);
                skipping_ = true;
                return;
            }
            if (step.what == decoder::status::frame)
                accept(now - cfg_.format.chars_time(in.size() - offset));
        }
    }

    // A request waits for respond() or consume().
    bool has_request() const noexcept { return request_pending_; }
    // The pending request (valid while has_request()).
    const telegram& request() const noexcept { return request_; }
    // When the pending request's BCC ended on the wire.
    time_point request_end() const noexcept { return request_end_; }
    // False for group and broadcast requests (SC01 p.21-22).
    bool response_expected() const noexcept { return expects_response(request_.address); }

    // Queues the reply to the pending request: SD2, the request's TYP, and its ADR (for a
    // point-to-point request also this unit's own address). Refused with
    // errc::no_response_expected for group / broadcast requests: consume() those.
    ferrule::error respond(const telegram& reply) noexcept {
        if (!request_pending_) return errc::invalid_argument;
        if (!response_expected()) return errc::no_response_expected;
        const bool own_address =
            reply.address == request_.address ||
            (request_.address == address_point_to_point && reply.address == cfg_.address);
        if (reply.dir != direction::response || reply.type != request_.type || !own_address)
            return errc::invalid_argument;
        request_pending_ = false;
        reply_.queue(*encode(reply, reply_.buffer()),
                     request_end_ + cfg_.start_pause + cfg_.processing_time);
        return {};
    }

    // Drops the pending request without an answer (required for group / broadcast).
    void consume() noexcept { request_pending_ = false; }

    // idle: listening; done: a request waits for respond() / consume(); wait: a reply is
    // queued for the deadline; send: put these bytes on the line now.
    session_action next(time_point now) noexcept {
        return reply_.next(now, request_pending_, stats_.replies);
    }

    // When the queued reply is due; `never` when none is queued (a pending request waits for
    // the application, not for a time).
    time_point wake_at() const noexcept { return reply_.due(); }

    // Whether a request with this ADR is for this unit (SC01 p.20-22).
    bool addressed(std::uint8_t adr) const noexcept {
        if (adr == cfg_.address || adr == address_point_to_point || adr == address_broadcast)
            return true;
        // Group 100 means "not assigned to any group".
        return adr == cfg_.group && kind_of(cfg_.group) == address_kind::group && cfg_.group != 100;
    }

    const slave_stats& stats() const noexcept { return stats_; }
    const slave_config& config() const noexcept { return cfg_; }

private:
    void break_telegram() noexcept {
        ++stats_.gap_errors;
        stats_.skipped_bytes += static_cast<std::uint32_t>(decoder_.buffered());
    }

    void accept(time_point end) noexcept {
        // The decoder has checked SD1, TYP, length and BCC, so parsing cannot fail.
        const telegram t = *parse(decoder_.frame());
        if (!addressed(t.address)) {
            ++stats_.ignored_other_address;
            return;
        }
        ++stats_.requests;
        if (!expects_response(t.address)) ++stats_.no_reply_requests;
        request_ = t;
        request_end_ = end;
        request_pending_ = true;
    }

    slave_config cfg_;
    slave_stats stats_{};
    bool request_pending_ = false; // waits for respond() / consume()
    decoder decoder_{decoder::accept::requests};
    bool heard_ = false;
    bool skipping_ = false;
    time_point last_end_{};
    telegram request_{};
    time_point request_end_{};
    queued_reply<max_telegram_size> reply_{};
};

static_assert(station<slave>);

} // namespace ferrule::movilink
