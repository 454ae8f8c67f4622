// LECOM-A/B master session (the host's side of the bus), sans-I/O: one transaction at a time.
//
// Behaviour (S1 §8.3.5 and p.8-20…8-24; lecom.md §1.4, §1.11, §1.12, §2):
//   * RECEIVE (read) goes to a drive address 01…99 other than x0; SEND (write) to any address
//     00…99. A SEND to 00 or x0 reaches a group and is never acknowledged (S1 p.6-3, p.8-24):
//     the session keeps the line quiet for `broadcast_spacing` (the drives' processing time)
//     and then finishes with errc::no_response_expected
//   * the reply deadline is the end of the request on the wire + response_timeout; a reply
//     that has begun by then may finish until the deadline + the wire time of
//     max_reply_length, so a reply that is arriving is never cut
//   * the reply is the first complete telegram after the request. Bytes before it that form
//     no telegram are skipped; if no telegram follows, the attempt ends as malformed at the
//     deadline. Bytes behind the reply, and bytes while no reply is awaited, are stale
//   * how an attempt ends (lecom.md §1.4, §1.5, §2):
//       data reply echoing the code asked ............ read done
//       ACK to SEND .................................. write done
//       STX code EOT, or bare EOT to RECEIVE ......... device_errc::code_does_not_exist
//       STX code ? ETX BCC, or bare NAK to RECEIVE ... device_errc::checksum_fault
//       NAK to SEND .................................. device_errc::write_refused
//       BCC wrong .................................... errc::bad_checksum
//       data / fault / no-code reply of another code . errc::unexpected_type
//       anything else (ACK to RECEIVE, data to SEND,
//       bytes that form no telegram) ................. errc::malformed
//       silence until the deadline ................... errc::timeout
//     Every one but code_does_not_exist is sent again, up to `retries` times: "the
//     transmission is tried again. The number of repetitions is limited" (S1 §8.3.5). NAK to
//     SEND is retried too, because it also stands for a parity fault (S1 p.8-20)
//   * before each request the line has been quiet for `turnaround` since the last byte
//     received or the last timeout (for broadcast_spacing after a broadcast); stale input is
//     dropped first (discard_stale_input)
//   * LECOM telegrams carry no sequence number: a reply that comes after its deadline, while
//     the resend is awaited, is taken as the answer to the resend
//
// Timing. A read with a request of n_q characters, a drive that starts answering t_d after
// the request's last byte (t3 = 20 ms for the 8200, S3) and a reply of n_r characters occupies
//     format.chars_time(n_q) + t_d + format.chars_time(n_r)
// from the first byte of the request to the last byte of the reply; the next request starts
// `turnaround` after that last byte. Read C0050 from drive 01 at 9600 8E1 (11 bits a
// character): request EOT '0' '1' '5' '0' ENQ, 6 characters = 6.875 ms; reply STX '5' '0'
// "1500" ETX BCC, 9 characters = 10.3125 ms; with t_d = 20 ms one read takes 37.1875 ms.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <system_error>

#include "ferrule/core/error.hpp"
#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/lecom/code.hpp"
#include "ferrule/lecom/constants.hpp"
#include "ferrule/lecom/error.hpp"
#include "ferrule/lecom/frame.hpp"
#include "ferrule/lecom/value.hpp"

namespace ferrule::lecom {

struct master_config {
    serial_format format = default_format;
    duration response_timeout = lecom::response_timeout; // from the end of the request
    duration turnaround = duration::zero(); // quiet line after a reply / timeout, before a request
    duration broadcast_spacing = lecom::processing_time; // after a SEND to 00 / x0 (no reply)
    unsigned retries = 2; // resends after the first attempt (S1 §8.3.5: "limited")
    bool discard_stale_input = true;
};

// Transactions end as succeeded, failed, or (a broadcast) neither. The attempt counters
// (timeouts … device_errors) count each failed attempt once, resends included.
struct master_stats {
    std::uint32_t transactions = 0;
    std::uint32_t succeeded = 0;
    std::uint32_t failed = 0; // device errors and transport errors included
    std::uint32_t timeouts = 0;
    std::uint32_t bad_checksums = 0;
    std::uint32_t malformed = 0; // unparseable, wrong form or wrong code echoed, broken telegram
    std::uint32_t device_errors = 0;
    std::uint32_t resends = 0;
    std::uint32_t stale_bytes = 0; // received while no reply was awaited, or behind the reply
};

class master {
public:
    explicit master(const master_config& cfg = {}) noexcept : cfg_(cfg) {}

    // RECEIVE: read code `c` of drive `address` (01…99, not x0: a group never answers).
    std::error_code start_read(std::uint8_t address, code_address c) noexcept {
        if (busy()) return errc::busy;
        if (!is_unit_address(address)) return errc::invalid_argument;
        return begin(read_request(address, c));
    }

    // SEND: write `v` to code `c` of drive `address`; 00 and x0 reach a group (no reply).
    std::error_code start_write(std::uint8_t address, code_address c, const value& v) noexcept {
        if (busy()) return errc::busy;
        return begin(write_request(address, c, v));
    }

    session_action next(time_point now) noexcept {
        switch (state_) {
        case state::idle: return session_action::idle();
        case state::done: return session_action::done();
        case state::pending_send:
            if (now < send_after_) return session_action::wait_until(send_after_);
            return send(now);
        case state::awaiting: {
            const time_point deadline = deadline_now();
            if (now < deadline) return session_action::wait_until(deadline);
            expire(deadline);
            return next(now);
        }
        }
        return session_action::idle();
    }

    void on_receive(std::span<const std::uint8_t> in, time_point now) noexcept {
        if (!in.empty()) hold(now, cfg_.turnaround); // the line is not quiet
        while (!in.empty()) {
            if (state_ != state::awaiting || broadcast_) {
                stats_.stale_bytes += static_cast<std::uint32_t>(in.size());
                return;
            }
            heard_ = true;
            const auto step = decoder_.feed(in);
            in = in.subspan(step.consumed);
            if (step.what == frame_decoder::status::frame) evaluate(decoder_.frame());
        }
    }

    void on_transport_error(std::error_code ec) noexcept {
        if (!busy()) return;
        ++stats_.failed;
        finish(ec);
    }

    // Outcome of the finished transaction: empty on success; errc::no_response_expected for a
    // broadcast; otherwise the cause of the last failed attempt, a ferrule::errc or a
    // lecom::device_errc.
    std::error_code error() const noexcept { return error_; }
    // The last reply telegram parsed: for a successful read the data reply (value in
    // reply().value), for a write the ACK.
    const frame& reply() const noexcept { return reply_; }
    const frame& request() const noexcept { return request_; }
    // The request as sent on the wire.
    std::span<const std::uint8_t> request_bytes() const noexcept { return {tx_.data(), tx_size_}; }
    // Requests sent for the current / finished transaction.
    unsigned attempts() const noexcept { return attempts_; }
    bool busy() const noexcept {
        return state_ == state::pending_send || state_ == state::awaiting;
    }
    // Done -> idle once the result has been read (a new start does this too).
    void clear() noexcept {
        if (state_ == state::done) state_ = state::idle;
    }

    const master_stats& stats() const noexcept { return stats_; }
    const master_config& config() const noexcept { return cfg_; }

private:
    enum class state : std::uint8_t { idle, pending_send, awaiting, done };

    std::error_code begin(const frame& request) noexcept {
        const auto n = encode(request, tx_);
        if (!n) return errc::invalid_argument;
        tx_size_ = *n;
        request_ = request;
        broadcast_ = request.kind == frame_kind::send && is_group_address(request.address);
        attempts_ = 0;
        error_ = {};
        reply_ = {};
        ++stats_.transactions;
        state_ = state::pending_send;
        return {};
    }

    session_action send(time_point now) noexcept {
        if (++attempts_ > 1) ++stats_.resends;
        tx_end_ = now + cfg_.format.chars_time(tx_size_);
        if (broadcast_) hold(tx_end_, cfg_.broadcast_spacing); // the drives are busy
        decoder_.reset();
        heard_ = false;
        state_ = state::awaiting;
        return session_action::send({tx_.data(), tx_size_}, cfg_.discard_stale_input);
    }

    time_point deadline_now() const noexcept {
        if (broadcast_) return tx_end_ + cfg_.broadcast_spacing;
        const time_point d = tx_end_ + cfg_.response_timeout;
        return decoder_.in_frame() ? d + cfg_.format.chars_time(max_reply_length) : d;
    }

    void expire(time_point deadline) noexcept {
        if (broadcast_) {
            finish(errc::no_response_expected);
            return;
        }
        hold(deadline, cfg_.turnaround);
        fail(heard_ ? errc::malformed : errc::timeout, true);
    }

    // The reply's bytes have set the turnaround already (on_receive).
    void evaluate(std::span<const std::uint8_t> telegram) noexcept {
        const auto parsed = parse_reply(telegram);
        if (!parsed) {
            fail(parsed.error(), true);
            return;
        }
        reply_ = *parsed;
        const frame_kind k = reply_.kind;
        if (request_.kind == frame_kind::send) {
            if (k == frame_kind::ack)
                succeed();
            else if (k == frame_kind::nak)
                fail(device_errc::write_refused, true);
            else
                fail(errc::malformed, true);
            return;
        }
        const bool echoes =
            k == frame_kind::data || k == frame_kind::fault || k == frame_kind::no_code;
        if (echoes && reply_.code != request_.code) {
            fail(errc::unexpected_type, true);
            return;
        }
        switch (k) {
        case frame_kind::data: succeed(); return;
        case frame_kind::fault:
        case frame_kind::nak: fail(device_errc::checksum_fault, true); return;
        case frame_kind::no_code:
        case frame_kind::eot: fail(device_errc::code_does_not_exist, false); return;
        default: fail(errc::malformed, true); return;
        }
    }

    void succeed() noexcept {
        ++stats_.succeeded;
        finish({});
    }

    void fail(std::error_code ec, bool may_retry) noexcept {
        if (ec == errc::timeout)
            ++stats_.timeouts;
        else if (ec == errc::bad_checksum)
            ++stats_.bad_checksums;
        else if (ec.category() == device_category())
            ++stats_.device_errors;
        else
            ++stats_.malformed;
        if (may_retry && attempts_ <= cfg_.retries) {
            error_ = ec; // the cause so far, replaced by the final outcome
            state_ = state::pending_send;
            return;
        }
        ++stats_.failed;
        finish(ec);
    }

    void finish(std::error_code ec) noexcept {
        error_ = ec;
        state_ = state::done;
    }

    // No request before t + quiet.
    void hold(time_point t, duration quiet) noexcept {
        if (t + quiet > send_after_) send_after_ = t + quiet;
    }

    master_config cfg_;
    master_stats stats_{};
    state state_ = state::idle;
    frame request_{};
    frame reply_{};
    std::array<std::uint8_t, max_request_length> tx_{};
    std::size_t tx_size_ = 0;
    frame_decoder decoder_{frame_decoder::accept::replies};
    time_point send_after_ = time_point::min();
    time_point tx_end_{};
    std::error_code error_{};
    unsigned attempts_ = 0;
    bool broadcast_ = false;
    bool heard_ = false; // bytes received since the request was sent
};

static_assert(master_session<master>);

} // namespace ferrule::lecom
