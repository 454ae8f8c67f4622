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
//   * the reply is the first complete telegram after the request, framed as frame_decoder
//     frames replies (accept::replies). Bytes before it that form no telegram are skipped; if no
//     telegram follows, the attempt ends as malformed at the deadline. Bytes behind the reply, and
//     bytes while no reply is awaited, are stale
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

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/fault_latch.hpp"
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
    unsigned retries = 2;         // resends after the first attempt (S1 §8.3.5: "limited")
    unsigned fault_threshold = 0; // failed attempts in a row that latch the fault; 0: never
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
    constexpr explicit master(const master_config& cfg = {}) noexcept
        : cfg_(cfg), reply_allowance_(cfg.format.chars_time(max_reply_length)) {}

    // RECEIVE: read code `c` of drive `address` (01…99, not x0: a group never answers).
    ferrule::error start_read(std::uint8_t address, code_address c) noexcept {
        return begin(address, c, nullptr);
    }

    // SEND: write `v` to code `c` of drive `address`; 00 and x0 reach a group (no reply).
    ferrule::error start_write(std::uint8_t address, code_address c, const value& v) noexcept {
        return begin(address, c, &v);
    }

    session_action next(time_point now) noexcept {
        while (busy()) {
            if (d_.state == state::pending_send) {
                if (d_.hold.holds(now)) return session_action::wait_until(d_.hold.end());
                return send(now);
            }
            // Awaiting a reply: a reply that has begun may finish.
            const time_point until =
                d_.rx == rx::idle ? d_.deadline : d_.deadline + reply_allowance_;
            if (before(now, until)) return session_action::wait_until(until);
            expire(now, until);
        }
        return d_.state == state::done ? session_action::done() : session_action::idle();
    }

    void on_receive(std::span<const std::uint8_t> in, time_point now) noexcept {
        if (!in.empty()) hold(now, now + cfg_.turnaround); // the line is not quiet
        for (std::size_t i = 0; i < in.size(); ++i) {
            if (d_.state != state::awaiting || d_.broadcast) {
                d_.stats.stale_bytes += static_cast<std::uint32_t>(in.size() - i);
                return;
            }
            d_.heard = true;
            if (take(in[i])) evaluate({d_.rx_buf.data(), d_.rx_size});
        }
    }

    void on_transport_error(ferrule::error ec) noexcept {
        if (!busy()) return;
        ++d_.stats.failed;
        finish(ec);
    }

    // Outcome of the finished transaction: empty on success; errc::no_response_expected for a
    // broadcast; otherwise the cause of the last failed attempt, a ferrule::errc or a
    // lecom::device_errc.
    ferrule::error error() const noexcept { return d_.error; }
    // The finished transaction succeeded: error() is empty.
    bool succeeded() const noexcept { return !d_.error; }
    // The last reply telegram parsed: for a successful read the data reply (value in
    // reply().value), for a write the ACK.
    const frame& reply() const noexcept { return d_.reply; }
    const frame& request() const noexcept { return d_.request; }
    // The request as sent on the wire.
    std::span<const std::uint8_t> request_bytes() const noexcept {
        return {d_.tx.data(), d_.tx_size};
    }
    // Requests sent for the current / finished transaction.
    unsigned attempts() const noexcept { return d_.attempts; }
    bool busy() const noexcept {
        return d_.state == state::pending_send || d_.state == state::awaiting;
    }
    // Done -> idle once the result has been read (a new start does this too).
    void clear() noexcept {
        if (d_.state == state::done) d_.state = state::idle;
    }

    const master_stats& stats() const noexcept { return d_.stats; }
    const master_config& config() const noexcept { return cfg_; }

    // fault_threshold failed attempts in a row latch a fault: start() then returns
    // errc::fault_latched until reset_fault().
    bool fault_latched() const noexcept { return d_.latch.fault_latched(); }
    unsigned consecutive_failures() const noexcept { return d_.latch.consecutive_failures(); }
    void reset_fault() noexcept { d_.latch.reset_fault(); }

private:
    enum class state : std::uint8_t { idle, pending_send, awaiting, done };
    // Where the reply framing is: between telegrams, after STX, after ETX.
    enum class rx : std::uint8_t { idle, text, bcc };

    // A RECEIVE when `v` is null, else a SEND of *v.
    ferrule::error begin(std::uint8_t address, const code_address& c, const value* v) noexcept {
        if (busy()) return errc::busy;
        if (d_.latch.fault_latched()) return errc::fault_latched;
        // request_bytes() keeps the last request if this one is refused.
        std::array<std::uint8_t, max_request_length> tx;
        const std::size_t n = encode_request(address, c, v, tx.data());
        if (n == 0) return errc::invalid_argument;
        std::copy_n(tx.begin(), n, d_.tx.begin());
        d_.tx_size = n;
        d_.tx_time = cfg_.format.chars_time(n);
        d_.request.kind = v ? frame_kind::send : frame_kind::receive;
        d_.request.address = address;
        d_.request.code = c;
        if (v)
            d_.request.value = *v;
        else
            d_.request.value = {};
        d_.broadcast = v && is_group_address(address);
        d_.attempts = 0;
        d_.error = {};
        d_.reply = {};
        ++d_.stats.transactions;
        d_.state = state::pending_send;
        return {};
    }

    session_action send(time_point now) noexcept {
        if (++d_.attempts > 1) ++d_.stats.resends;
        const time_point end = now + d_.tx_time;
        d_.deadline = end + (d_.broadcast ? cfg_.broadcast_spacing : cfg_.response_timeout);
        if (d_.broadcast) hold(now, d_.deadline); // the drives are busy
        d_.rx = rx::idle;
        d_.heard = false;
        d_.state = state::awaiting;
        return session_action::send({d_.tx.data(), d_.tx_size}, cfg_.discard_stale_input);
    }

    void expire(time_point now, time_point deadline) noexcept {
        if (d_.broadcast) {
            finish(errc::no_response_expected);
            return;
        }
        hold(now, deadline + cfg_.turnaround);
        fail(d_.heard ? errc::malformed : errc::timeout);
    }

    // Frames the reply byte by byte as frame_decoder does with accept::replies; true when
    // rx_buf holds a telegram.
    bool take(std::uint8_t b) noexcept {
        auto& buf = d_.rx_buf;
        std::size_t& n = d_.rx_size;
        if (d_.rx == rx::bcc) { // exactly one byte, whatever its value
            buf[n++] = b;
            d_.rx = rx::idle;
            return true;
        }
        if (d_.rx == rx::text) {
            // STX code EOT: the code does not exist. (With only STX in, neither length fits.)
            const std::size_t no_code_length =
                buf[1] == extended_mark ? 2 + extended_code_length : 2 + standard_code_length;
            const bool end = b == eot && n + 1 == no_code_length;
            // Text is 7-bit without control characters; room is left for ETX and the BCC.
            if (b == etx || end || (b >= 0x20 && b <= 0x7F && n + 2 < buf.size())) {
                buf[n++] = b;
                if (b == etx) d_.rx = rx::bcc;
                if (end) d_.rx = rx::idle;
                return end;
            }
            // Cut short: `b` may start the next telegram.
        }
        buf[0] = b;
        n = 1;
        d_.rx = b == stx ? rx::text : rx::idle;
        return b == ack || b == nak || b == eot;
    }

    // The reply's bytes have set the turnaround already (on_receive).
    void evaluate(std::span<const std::uint8_t> telegram) noexcept {
        frame f;
        if (const errc e = detail::read_reply(telegram, f); e != errc{}) {
            fail(e);
            return;
        }
        d_.reply = f;
        const frame_kind k = f.kind;
        device_errc answer{}; // the drive's own answer, if the reply is one
        if (d_.request.kind == frame_kind::send) {
            if (k == frame_kind::ack) return succeed();
            if (k == frame_kind::nak) answer = device_errc::write_refused;
        } else {
            const bool echoes =
                k == frame_kind::data || k == frame_kind::fault || k == frame_kind::no_code;
            if (echoes && f.code != d_.request.code) return fail(errc::unexpected_type);
            if (k == frame_kind::data) return succeed();
            if (k == frame_kind::fault || k == frame_kind::nak)
                answer = device_errc::checksum_fault;
            if (k == frame_kind::no_code || k == frame_kind::eot)
                answer = device_errc::code_does_not_exist;
        }
        if (answer == device_errc{}) return fail(errc::malformed);
        fail(answer, d_.stats.device_errors, answer != device_errc::code_does_not_exist);
    }

    void succeed() noexcept {
        d_.latch.succeeded();
        ++d_.stats.succeeded;
        finish({});
    }

    // A failed attempt of ours: timeout, bad_checksum, or malformed (the rest).
    void fail(errc e) noexcept {
        fail(e,
             e == errc::timeout        ? d_.stats.timeouts
             : e == errc::bad_checksum ? d_.stats.bad_checksums
                                       : d_.stats.malformed,
             true);
    }

    // A failed attempt, counted in `counter`.
    void fail(ferrule::error ec, std::uint32_t& counter, bool may_retry) noexcept {
        ++counter;
        if (d_.latch.retry(d_.attempts, cfg_.retries, cfg_.fault_threshold, may_retry)) {
            d_.error = ec; // the cause so far, replaced by the final outcome
            d_.state = state::pending_send;
            return;
        }
        ++d_.stats.failed;
        finish(ec);
    }

    void finish(ferrule::error ec) noexcept {
        d_.error = ec;
        d_.state = state::done;
    }

    // No request before t.
    void hold(time_point now, time_point t) noexcept { d_.hold.extend(now, t); }

    // All of it starts zero but for two frame kinds and the error code, so that one memset and
    // a few stores set it up.
    struct data {
        master_stats stats{};
        master::state state = state::idle;
        master::rx rx = rx::idle;
        bool broadcast = false;
        bool heard = false; // bytes received since the request was sent
        unsigned attempts = 0;
        frame request{};
        frame reply{};
        std::array<std::uint8_t, max_request_length> tx{};
        std::size_t tx_size = 0;
        duration tx_time{}; // wire time of the request
        std::array<std::uint8_t, max_frame_length> rx_buf{};
        std::size_t rx_size = 0;
        line_hold hold{};
        time_point deadline{}; // end of the request + response_timeout (broadcast_spacing)
        ferrule::error error{};
        fault_latch latch{};
    };

    master_config cfg_;
    duration reply_allowance_; // wire time of max_reply_length
    data d_{};
};

static_assert(master_session<master>);

} // namespace ferrule::lecom
