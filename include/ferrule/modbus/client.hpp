// Modbus client session (RTU or TCP), sans-I/O: one transaction at a time.
//
// Behaviour (SL §2.4.1, §2.5.1.1; TCP §3.1.3; protocols/modbus_profibus.md §A.3-§A.5, §C.7):
//   * RTU: before each request the line has been silent for inter_frame_gap (t3.5; 1.75 ms
//     above 19200 baud), counted from the end of the last byte on the line: our request's
//     last byte (its wire time computed from the serial format) or the last byte received.
//     0 sends at once (virtual links): a response that comes back before the request's
//     computed wire end (a pty) ends the request's hold too. TCP keeps no gap
//   * the response deadline is the end of the request + response_timeout; a response that
//     has begun by then may finish until the deadline + the wire time of 256 bytes, unless
//     inter_byte_timeout (RTU, 0 = off) ends it sooner: silence inside a frame longer than
//     that is errc::frame_gap (SL §2.5.1.1 allows 1.5 characters; USB adapters and ptys
//     merge and split bytes, hence off by default)
//   * RTU responses are framed by length (rtu_receiver): bytes before the response that
//     start no frame are skipped; after a CRC error or such garbage the attempt ends once the
//     line has been silent for t3.5 (the frame is over, SL §2.5.1.1; at the latest at the
//     deadline + the wire time of 256 bytes) unless a frame is found in what was received
//   * the response must come from the unit asked (else errc::unexpected_address) and answer
//     the request: function code, byte count, echo (parse_response()). TCP: every attempt
//     has a new transaction id; a response with another id is stale, dropped and counted
//   * broadcast (RTU unit 0, write functions only, SL §2.2) and FC8 "force listen only"
//     (AP §6.8.1) get no response: the session keeps the line quiet for `turnaround` (SL
//     §2.4.1 "turnaround delay") and ends with errc::no_response_expected
//   * failed attempts are resent up to `retries` times; exception responses are the
//     server's answer and are not resent
//   * echo_suppression (RTU): adapters whose receiver stays on hand our own request back
//     first; exactly those bytes are skipped, up to the first byte that differs
//   * stale input is dropped before each request (discard_stale_input); bytes that arrive
//     while no response is awaited, or behind the response, are counted as stale
//
// Timing. A transaction whose request has n_q bytes, served by a server that starts its
// response t_d after the request's last byte with n_r bytes, takes
//     format.chars_time(n_q) + t_d + format.chars_time(n_r)
// and the next request starts inter_frame_gap after the response's last byte. Reading one
// register of unit 1 at 9600 8E1 (11-bit characters): request 8 bytes = 9.1667 ms, response
// 7 bytes = 8.0208 ms, t3.5 = 4.0104 ms.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>

#include "ferrule/core/error.hpp"
#include "ferrule/core/fault_latch.hpp"
#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/error.hpp"
#include "ferrule/modbus/pdu.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/tcp.hpp"

namespace ferrule::modbus {

struct client_config {
    serial_format format = default_format;
    bool rtu = true; // false: Modbus TCP (MBAP header, no CRC, no gaps)
    duration response_timeout = std::chrono::seconds(1);  // from the end of the request
    duration inter_frame_gap = t35(format);               // RTU: silence before a request
    duration inter_byte_timeout = duration::zero();       // RTU: silence inside a response; 0 = off
    duration turnaround = std::chrono::milliseconds(100); // after a broadcast
    unsigned retries = 0;                                 // resends after the first attempt
    bool discard_stale_input = true;
    bool echo_suppression = false; // RTU: skip our own request if it comes back first
    // Failed attempts in a row that latch the fault; 0: never. 16 bits, where the padding
    // behind the flags has room: a firmware image's copy of the config does not grow.
    std::uint16_t fault_threshold = 0;
};

// Transactions end as succeeded, failed or (broadcasts) neither. The attempt counters
// (timeouts … unexpected_units) count each failed attempt once, resends included.
struct client_stats {
    std::uint32_t transactions = 0;
    std::uint32_t succeeded = 0;
    std::uint32_t failed = 0; // exception responses and transport errors included
    std::uint32_t broadcasts = 0;
    std::uint32_t timeouts = 0;
    std::uint32_t bad_checksums = 0;
    std::uint32_t malformed = 0; // unparseable, wrong function code or echo, gap in a frame
    std::uint32_t unexpected_units = 0;
    std::uint32_t exceptions = 0;
    std::uint32_t resends = 0;
    std::uint32_t stale_bytes = 0; // no response awaited, behind the response, old TCP ids
    std::uint32_t echo_bytes = 0;
};

// Fs: the function codes the client can send (function_set); start() refuses others with
// errc::invalid_argument, and their code is not compiled in. Latch: fault_latch, or
// no_fault_latch for a firmware image that does without it (core/fault_latch.hpp).
template <link_mode Link = link_mode::any, function_set Fs = all_functions,
          class Latch = fault_latch>
class basic_client {
public:
    constexpr explicit basic_client(const client_config& cfg = {}) noexcept
        : cfg_(cfg), wire_(cfg.format), char_time_(wire_.chars_time(1)),
          silence_(t35(cfg.format) + char_time_), adu_time_(wire_.chars_time(max_rtu_adu)) {
        if constexpr (Link != link_mode::any) cfg_.rtu = Link == link_mode::rtu;
    }

    // Starts a transaction with `unit`. RTU: 1…247, or 0 (broadcast) for FC 5, 6, 15, 16.
    // TCP: any unit id. invalid_argument for a request encode_request() refuses.
    // Out of line: an application starts requests in many places, each would carry a copy.
    [[gnu::noinline]] ferrule::error start(std::uint8_t unit, const request& r) noexcept {
        if (busy()) return errc::busy;
        if (latch_.fault_latched()) return errc::fault_latched;
        if (rtu() && unit > max_unit_address) return errc::invalid_argument;
        const bool broadcast = rtu() && unit == broadcast_address;
        if (broadcast && r.function != function::write_single_coil &&
            r.function != function::write_single_register &&
            r.function != function::write_multiple_coils &&
            r.function != function::write_multiple_registers)
            return errc::invalid_argument;
        // The PDU is encoded in place, behind the RTU address or the MBAP header.
        std::uint8_t* const pdu = tx_.data() + pdu_offset();
        const auto n = encode_request<Fs>(r, {pdu, max_pdu});
        if (!n) return n.error();
        pdu_size_ = *n;
        unit_ = unit;
        no_reply_ =
            broadcast || (detail::one_of<Fs, function::diagnostics>(r.function) &&
                          r.value == static_cast<std::uint16_t>(diag_sub::force_listen_only));
        // TCP: the header is written at each attempt, with its transaction id.
        if (rtu()) tx_size_ = seal_rtu(unit, tx_.data(), pdu_size_);
        attempts_ = 0;
        error_ = {};
        response_.data = {};
        rx_pdu_ = {};
        ++stats_.transactions;
        state_ = state::pending_send;
        return {};
    }

    session_action next(time_point now) noexcept {
        switch (state_) {
        case state::idle: return session_action::idle();
        case state::done: return session_action::done();
        case state::pending_send: {
            // The line quiet since our last request (its gap or turnaround) and since the
            // last byte received (its gap).
            if (quiet_.holds(now)) return session_action::wait_until(quiet_.end());
            return send(now);
        }
        case state::awaiting:
        case state::no_reply:
            if (before(now, deadline_)) return session_action::wait_until(deadline_);
            if (state_ == state::no_reply) {
                finish(errc::no_response_expected);
                return session_action::done();
            }
            expire();
            return next(now);
        }
        return session_action::idle();
    }

    void on_receive(std::span<const std::uint8_t> in, time_point now) noexcept {
        if (in.empty()) return;
        const bool awaiting = state_ == state::awaiting;
        if (rtu()) {
            // An answer before our request's computed wire end: the link is faster than the
            // serial format says (a pty, a TCP bridge), so the request's hold ends now.
            if (awaiting && before(now, tx_end_) && echo_pos_ == tx_size_) quiet_.release();
            if (awaiting && cfg_.inter_byte_timeout.count() > 0 && !rx_.empty() &&
                before(last_rx_ + cfg_.inter_byte_timeout, now - wire_.chars_time(in.size()))) {
                received(now);
                fail(errc::frame_gap);
                stats_.stale_bytes += static_cast<std::uint32_t>(in.size());
                return;
            }
        }
        received(now);
        std::size_t used = 0;
        if (awaiting) used = rtu() ? feed_rtu(in) : feed_tcp(in);
        stats_.stale_bytes += static_cast<std::uint32_t>(in.size() - used);
    }

    void on_transport_error(ferrule::error ec) noexcept {
        if (!busy()) return;
        ++stats_.failed;
        finish(ec);
    }

    // Outcome of the finished transaction: empty on success; errc::no_response_expected for
    // a broadcast; otherwise the cause of the last failed attempt, a ferrule::errc or a
    // modbus::device_domain exception code.
    ferrule::error error() const noexcept { return error_; }
    // !error(), without making a ferrule::error (firmware that only tells success from
    // failure saves the conversion at each call).
    bool succeeded() const noexcept { return !error_; }
    // The response of a successful transaction; its data spans the session's buffer, valid
    // until the next start(). Read it only when error() is empty: after a failure its data
    // is empty, its other fields are not to be used.
    const modbus::response& reply() const noexcept { return response_; }
    // The PDU of the last response that answered the request (a normal or an exception
    // response), as received; empty when none did. Valid until the next start().
    std::span<const std::uint8_t> response_pdu() const noexcept { return rx_pdu_; }
    // The request PDU and the ADU as last sent.
    std::span<const std::uint8_t> pdu() const noexcept {
        return {tx_.data() + pdu_offset(), pdu_size_};
    }
    std::span<const std::uint8_t> request_bytes() const noexcept { return {tx_.data(), tx_size_}; }
    std::uint8_t unit() const noexcept { return unit_; }
    std::uint16_t transaction() const noexcept { return transaction_; } // TCP: last id sent
    unsigned attempts() const noexcept { return attempts_; }
    bool busy() const noexcept { return state_ >= state::pending_send; }
    // Done -> idle once the result has been read (a new start does this too).
    void clear() noexcept {
        if (state_ == state::done) state_ = state::idle;
    }

    const client_stats& stats() const noexcept { return stats_; }
    const client_config& config() const noexcept { return cfg_; }

    // fault_threshold failed attempts in a row (exception responses included) latch a fault:
    // start() then returns errc::fault_latched until reset_fault().
    bool fault_latched() const noexcept { return latch_.fault_latched(); }
    unsigned consecutive_failures() const noexcept { return latch_.consecutive_failures(); }
    void reset_fault() noexcept { latch_.reset_fault(); }

private:
    constexpr bool rtu() const noexcept {
        if constexpr (Link == link_mode::any)
            return cfg_.rtu;
        else
            return Link == link_mode::rtu;
    }

    constexpr std::size_t pdu_offset() const noexcept { return rtu() ? 1 : mbap_size; }

    // The busy states last.
    enum class state : std::uint8_t { idle, done, pending_send, awaiting, no_reply };

    session_action send(time_point now) noexcept {
        if (++attempts_ > 1) ++stats_.resends;
        if (!rtu()) tx_size_ = seal_tcp(++transaction_, unit_, tx_.data(), pdu_size_);
        tx_end_ = rtu() ? now + wire_.chars_time(tx_size_) : now;
        last_rx_ = tx_end_;
        rx_.clear();
        tcp_.reset();
        heard_ = false;
        decode_error_ = errc{};
        echo_pos_ = rtu() && cfg_.echo_suppression ? 0 : tx_size_;
        duration quiet = rtu() ? cfg_.inter_frame_gap : duration::zero();
        if (no_reply_) {
            ++stats_.broadcasts;
            if (quiet.count() < cfg_.turnaround.count()) quiet = cfg_.turnaround;
            deadline_ = tx_end_ + cfg_.turnaround;
            state_ = state::no_reply;
        } else {
            state_ = state::awaiting;
            rearm();
        }
        quiet_.set(now, tx_end_ + quiet);
        return session_action::send({tx_.data(), tx_size_}, cfg_.discard_stale_input);
    }

    // The attempt's deadline, after each change of what has been received: the end of the
    // request + response_timeout; for a response that has begun, up to the wire time of a
    // whole ADU later, or sooner: t3.5 of silence after garbage or a bad CRC (SL §2.5.1.1),
    // the inter-byte timeout inside a frame.
    [[gnu::noinline]] void rearm() noexcept {
        deadline_ = tx_end_ + cfg_.response_timeout;
        gap_ = false;
        if (!rtu() || (!garbled() && rx_.empty())) return;
        const time_point late = deadline_ + adu_time_;
        deadline_ = late;
        if (garbled()) {
            // When the silence has lasted t3.5, a byte begun by then would have arrived.
            deadline_ = earliest(last_rx_ + silence_, late);
        } else if (cfg_.inter_byte_timeout.count() > 0) {
            const time_point gap = last_rx_ + char_time_ + cfg_.inter_byte_timeout;
            gap_ = !before(late, gap);
            if (gap_) deadline_ = gap;
        }
    }

    // Bytes received at `now`: on RTU the line must then be quiet for the gap (t3.5).
    void received(time_point now) noexcept {
        last_rx_ = now;
        if (rtu()) quiet_.extend(now, now + cfg_.inter_frame_gap);
    }

    void expire() noexcept {
        // The silence ends what was received: a frame behind the bytes that start none still
        // counts.
        if (rtu()) {
            events e{*this};
            rx_.finish(e);
            if (state_ != state::awaiting) return;
        }
        if (gap_)
            fail(errc::frame_gap);
        else if (garbled())
            fail(decode_error_);
        else
            fail(heard_ ? errc::malformed : errc::timeout); // TCP: a frame begun, not ended
    }

    // Takes bytes of the response until it is evaluated; returns how many.
    std::size_t feed_rtu(std::span<const std::uint8_t> in) noexcept {
        events e{*this};
        std::size_t used = 0;
        for (; used < in.size() && state_ == state::awaiting; ++used) {
            if (echo_pos_ < tx_size_) {
                if (in[used] == tx_[echo_pos_]) {
                    if (++echo_pos_ == tx_size_)
                        stats_.echo_bytes += static_cast<std::uint32_t>(tx_size_);
                    continue;
                }
                // Not our echo: the bytes held back (address and function code match the
                // request's) begin the response.
                const std::size_t held = echo_pos_;
                echo_pos_ = tx_size_;
                for (std::size_t i = 0; i < held && state_ == state::awaiting; ++i)
                    rx_.push(tx_[i], e);
                if (state_ != state::awaiting) break;
            }
            rx_.push(in[used], e);
        }
        if (state_ == state::awaiting) rearm();
        return used;
    }

    // What the RTU receive buffer finds: the response is evaluated and nothing behind it
    // is looked at; dropped bytes note the attempt's first decoding error.
    struct events {
        basic_client& c;
        bool on_frame(std::uint8_t unit, std::span<const std::uint8_t> pdu) noexcept {
            c.evaluate(unit, pdu);
            return false;
        }
        void on_garbage(errc why) noexcept {
            if (!c.garbled()) c.decode_error_ = why;
        }
    };

    std::size_t feed_tcp(std::span<const std::uint8_t> in) noexcept {
        std::size_t used = 0;
        if constexpr (Link != link_mode::rtu) {
            heard_ = true;
            tcp_decoder::step s;
            do {
                s = tcp_.feed(in.subspan(used));
                used += s.consumed;
                if (s.what == tcp_decoder::status::error && !garbled())
                    decode_error_ = static_cast<errc>(s.ec.value()); // the decoder reports errc
                if (s.what != tcp_decoder::status::frame) continue;
                if (tcp_.transaction() != transaction_) {
                    stats_.stale_bytes += static_cast<std::uint32_t>(tcp_.adu().size());
                    continue;
                }
                evaluate(tcp_.unit(), tcp_.pdu());
            } while (s.what != tcp_decoder::status::need_more && state_ == state::awaiting);
        }
        return used;
    }

    void evaluate(std::uint8_t unit, std::span<const std::uint8_t> pdu) noexcept {
        if (unit != unit_) {
            fail(errc::unexpected_address);
            return;
        }
        // The PDU stays in the receive buffer: nothing more is taken into it until the next
        // attempt, and none follows a response that answers.
        // response_ is written only by a response that answers.
        if (const errc e = detail::check_response<Fs>(this->pdu(), pdu, response_); e != errc{}) {
            fail(e);
            return;
        }
        rx_pdu_ = pdu;
        if (pdu[0] & exception_flag) {
            // An exception response is the server's answer: it is not resent, and it is a
            // failure in a row for the latch.
            latch_.retry(attempts_, cfg_.retries, cfg_.fault_threshold, false);
            ++stats_.exceptions;
            ++stats_.failed;
            finish(make_device_error(pdu[1]));
            return;
        }
        latch_.succeeded();
        ++stats_.succeeded;
        finish({});
    }

    // A failed attempt, resent while retries are left.
    void fail(errc e) noexcept {
        switch (e) {
        case errc::timeout: ++stats_.timeouts; break;
        case errc::bad_checksum: ++stats_.bad_checksums; break;
        case errc::unexpected_address: ++stats_.unexpected_units; break;
        default: ++stats_.malformed; break;
        }
        error_ = e; // when resent, the cause so far, replaced by the final outcome
        if (latch_.retry(attempts_, cfg_.retries, cfg_.fault_threshold)) {
            state_ = state::pending_send;
            return;
        }
        ++stats_.failed;
        state_ = state::done;
    }

    bool garbled() const noexcept { return decode_error_ != errc{}; }

    void finish(ferrule::error ec) noexcept {
        error_ = ec;
        state_ = state::done;
    }

    client_config cfg_;
    wire_clock wire_;    // cfg_.format's character times, the product taken once
    duration char_time_; // one character on the wire
    duration silence_;   // t3.5 and the character that would end it
    duration adu_time_;  // the longest ADU on the wire
    client_stats stats_{};
    state state_ = state::idle;
    modbus::response response_{};
    std::size_t pdu_size_ = 0;
    std::array<std::uint8_t, max_tcp_adu> tx_{};
    std::size_t tx_size_ = 0;
    std::span<const std::uint8_t> rx_pdu_{};       // the response PDU as received
    rtu_receiver<rtu_frames::responses, Fs> rx_{}; // RTU: the response so far
    // An RTU-only client carries no MBAP decoder (276 bytes of RAM).
    struct no_tcp_decoder {
        constexpr void reset() noexcept {}
    };
    [[no_unique_address]] std::conditional_t<Link == link_mode::rtu, no_tcp_decoder, tcp_decoder>
        tcp_{};
    line_hold quiet_{}; // before the next request
    time_point tx_end_{};
    time_point last_rx_ = time_point::min(); // or the end of our request
    time_point deadline_{};                  // of the attempt (rearm()) or of the turnaround
    ferrule::error error_{};
    errc decode_error_{};      // garbage or a bad CRC in this attempt (the decoders report errc)
    std::size_t echo_pos_ = 0; // bytes of our echo matched so far
    unsigned attempts_ = 0;
    [[no_unique_address]] Latch latch_{};
    std::uint16_t transaction_ = 0;
    std::uint8_t unit_ = 0;
    bool no_reply_ = false;
    bool gap_ = false; // deadline_ is the inter-byte timeout's
    // TCP: bytes since the request (RTU: every byte other than our echo is in rx_ or has
    // been evaluated or dropped by the deadline).
    bool heard_ = false;
};

using client = basic_client<>;

static_assert(master_session<client>);
static_assert(master_session<basic_client<link_mode::rtu>>);

} // namespace ferrule::modbus
