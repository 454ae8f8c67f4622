// MOVILINK master session: one transaction at a time, sans-I/O.
//
// Behaviour (SC01 §4; MOVILINK paper's state machine, made configurable):
//   * bus idle >= start pause before SD1; stale input dropped before each request
//   * response deadline counted from the end of the request on the wire
//   * a reply is checked for SD2, ADR, TYP, length and BCC; invalid or missing replies
//     and drive error replies are resent up to `retries` times
//   * `fault_threshold` failed attempts in a row latch a fault: every start is refused
//     with errc::fault_latched until reset_fault() (paper: 5 errors in a row -> state 7)
//   * group / broadcast requests get no reply; the next request keeps >= 25 ms spacing
//   * cyclic PARAM types: a new service toggles the handshake bit; the drive has done it
//     when the reply echoes the bit, until then the request is repeated (SC01 p.30-34)
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/fault_latch.hpp"
#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/movilink/constants.hpp"
#include "ferrule/movilink/error.hpp"
#include "ferrule/movilink/frame.hpp"

namespace ferrule::movilink {

struct master_config {
    serial_format format = default_format;
    duration start_pause = movilink::start_pause;
    duration max_char_delay = movilink::max_char_delay; // zero: gaps inside a reply unchecked
    duration response_timeout = movilink::response_timeout;
    duration broadcast_spacing = movilink::broadcast_spacing;
    unsigned retries = 4;         // resends after the first attempt
    unsigned fault_threshold = 5; // failed attempts in a row that latch the fault; 0: never
    bool retry_device_errors = true;
    unsigned handshake_polls = 10; // repeats while a cyclic PARAM service is still running
    bool discard_stale_input = true;
};

struct master_stats {
    std::uint32_t transactions = 0;
    std::uint32_t succeeded = 0;
    std::uint32_t failed = 0;
    std::uint32_t timeouts = 0;
    std::uint32_t invalid_replies = 0; // bad BCC, malformed, wrong ADR / TYP, gaps
    std::uint32_t device_errors = 0;
    std::uint32_t resends = 0;
    std::uint32_t handshake_polls = 0;
    std::uint32_t stale_bytes = 0; // received while no reply was awaited
};

class master {
public:
    constexpr explicit master(const master_config& cfg = {}) noexcept
        : cfg_(cfg), wire_(cfg.format) {}

    // Process data only: PO words out, PI words back. `po` holds pd_words(type) words.
    // A PARAM+nPD type is allowed; its parameter channel then carries "no service".
    ferrule::error start_exchange(std::uint8_t address, pdu_type type,
                                  std::span<const std::uint16_t> po) noexcept {
        if (!has_param(type) && po.size() != pd_words(type)) return errc::invalid_argument;
        param_channel idle_channel{};
        idle_channel.set_handshake(handshake_of(address));
        return start(address, type, idle_channel, po, false);
    }

    // A parameter service (read, write, read min/max/default/scale/attribute). `type`
    // must carry a parameter channel; its PO words (if any) come from `po`.
    ferrule::error start_parameter(std::uint8_t address, pdu_type type, param_channel request,
                                   std::span<const std::uint16_t> po = {}) noexcept {
        if (!has_param(type)) return errc::invalid_argument;
        return start(address, type, request, po, true);
    }

    session_action next(time_point now) noexcept {
        switch (state_) {
        case state::idle: return session_action::idle();
        case state::done: return session_action::done();
        case state::pending_send: {
            if (hold_.holds(now)) return session_action::wait_until(hold_.end());
            return send(now);
        }
        case state::awaiting_reply: {
            const time_point deadline = reply_deadline();
            if (before(now, deadline)) return session_action::wait_until(deadline);
            fail_attempt(decoder_.in_frame() ? errc::frame_gap : errc::timeout);
            return next(now);
        }
        }
        return session_action::idle();
    }

    void on_receive(std::span<const std::uint8_t> in, time_point now) noexcept {
        if (in.empty()) return;
        if (state_ != state::awaiting_reply) {
            // Bus activity outside a transaction: not ours, and the line is not idle.
            stats_.stale_bytes += static_cast<std::uint32_t>(in.size());
            mark_activity(now, cfg_.start_pause);
            return;
        }
        if (decoder_.in_frame() && cfg_.max_char_delay.count() > 0) {
            const duration wire = wire_.chars_time(in.size());
            if (before(last_activity_ + cfg_.max_char_delay, now - wire)) {
                mark_activity(now, 2 * cfg_.start_pause);
                fail_attempt(errc::frame_gap);
                return;
            }
        }
        last_activity_ = now;
        hold_line(now);
        const auto step = decoder_.feed(in);
        if (step.what == decoder::status::error) {
            // SC01 p.19: after a broken telegram wait two start pauses.
            mark_activity(now, 2 * cfg_.start_pause);
            fail_attempt(step.ec);
            return;
        }
        if (step.what == decoder::status::frame) {
            if (step.consumed < in.size()) {
                // More bytes behind a complete telegram: the line was not clean.
                mark_activity(now, 2 * cfg_.start_pause);
                fail_attempt(errc::malformed);
                return;
            }
            evaluate();
        }
    }

    void on_transport_error(ferrule::error ec) noexcept {
        if (!busy()) return;
        ++stats_.failed;
        finish(ec);
    }

    // Outcome of the finished transaction: empty on success; errc::no_response_expected
    // for group / broadcast; a ferrule::errc or a movilink::device_domain code.
    ferrule::error error() const noexcept { return error_; }
    // The finished transaction succeeded: error() is empty.
    bool succeeded() const noexcept { return !error_; }
    // The drive's reply (valid when error() is empty).
    const telegram& reply() const noexcept { return reply_; }
    // Requests sent for the finished transaction, not counting handshake repeats.
    unsigned attempts() const noexcept { return attempts_; }
    bool busy() const noexcept {
        return state_ == state::pending_send || state_ == state::awaiting_reply;
    }

    // Done -> idle once the result has been read (a new start() does this too).
    void clear() noexcept {
        if (state_ == state::done) state_ = state::idle;
    }

    bool fault_latched() const noexcept { return latch_.fault_latched(); }
    unsigned consecutive_failures() const noexcept { return latch_.consecutive_failures(); }
    void reset_fault() noexcept { latch_.reset_fault(); }

    const master_stats& stats() const noexcept { return stats_; }
    const master_config& config() const noexcept { return cfg_; }
    // The request as last sent (for tracing).
    std::span<const std::uint8_t> request_bytes() const noexcept { return {tx_.data(), tx_size_}; }

private:
    enum class state : std::uint8_t { idle, pending_send, awaiting_reply, done };

    ferrule::error start(std::uint8_t address, pdu_type type, param_channel param,
                         std::span<const std::uint16_t> po, bool param_job) noexcept {
        if (busy()) return errc::busy;
        if (latch_.fault_latched()) return errc::fault_latched;
        const auto kind = kind_of(address);
        if (kind == address_kind::undefined || kind == address_kind::local)
            return errc::invalid_argument;
        if (!is_valid_pdu_type(static_cast<std::uint8_t>(type)) || po.size() != pd_words(type))
            return errc::invalid_argument;

        request_ = telegram{direction::request, address, type, param, {}};
        for (std::size_t i = 0; i < po.size(); ++i) request_.pd[i] = po[i];
        param_job_ = param_job && !is_acyclic(type);
        if (param_job_) {
            // Cyclic PARAM types: a new job is signalled by toggling the handshake bit.
            toggle_handshake(address);
            request_.param.set_handshake(handshake_of(address));
        } else if (param_job) {
            request_.param.set_handshake(false);
        }
        const auto n = encode(request_, tx_);
        tx_size_ = *n;

        attempts_ = 0;
        handshake_polls_ = 0;
        handshake_polling_ = false; // a poll cut short by a transport error ends with it
        error_ = {};
        reply_ = {};
        ++stats_.transactions;
        state_ = state::pending_send;
        return {};
    }

    session_action send(time_point now) noexcept {
        if (handshake_polling_)
            ++stats_.handshake_polls;
        else if (++attempts_ > 1)
            ++stats_.resends;
        handshake_polling_ = false;
        tx_end_ = now + wire_.chars_time(tx_size_);
        last_activity_ = tx_end_;
        pause_ = cfg_.start_pause;
        decoder_.idle();
        if (expects_response(request_.address)) {
            state_ = state::awaiting_reply;
        } else {
            // SC01 p.21: no reply to group / broadcast; keep 25 ms before the next SD1.
            pause_ = cfg_.broadcast_spacing;
            state_ = state::done;
            error_ = errc::no_response_expected;
        }
        hold_line(now);
        return session_action::send({tx_.data(), tx_size_}, cfg_.discard_stale_input);
    }

    time_point reply_deadline() const noexcept {
        if (!decoder_.in_frame()) return tx_end_ + cfg_.response_timeout;
        if (cfg_.max_char_delay.count() > 0)
            return last_activity_ + wire_.chars_time(1) + cfg_.max_char_delay;
        return tx_end_ + cfg_.response_timeout + wire_.chars_time(max_telegram_size);
    }

    void evaluate() noexcept {
        const auto parsed = parse(decoder_.frame());
        if (!parsed) {
            fail_attempt(parsed.error());
            return;
        }
        const telegram& t = *parsed;
        if (t.dir != direction::response) {
            fail_attempt(errc::malformed);
            return;
        }
        if (t.address != request_.address && request_.address != address_point_to_point) {
            fail_attempt(errc::unexpected_address);
            return;
        }
        if (t.type != request_.type) {
            fail_attempt(errc::unexpected_type);
            return;
        }
        reply_ = t;
        if (has_param(t.type) && param_job_ && t.param.handshake() != request_.param.handshake()) {
            // The drive still answers with the old handshake bit: not done yet.
            if (++handshake_polls_ > cfg_.handshake_polls) {
                fail_attempt(errc::timeout);
                return;
            }
            handshake_polling_ = true;
            state_ = state::pending_send;
            return;
        }
        if (has_param(t.type) && t.param.is_error()) {
            ++stats_.device_errors;
            fail_attempt(make_device_error(t.param), cfg_.retry_device_errors);
            return;
        }
        latch_.succeeded();
        ++stats_.succeeded;
        finish({});
    }

    void fail_attempt(ferrule::error ec, bool may_retry = true) noexcept {
        if (ec == errc::timeout)
            ++stats_.timeouts;
        else if (ec.domain() != &device_domain)
            ++stats_.invalid_replies;
        if (latch_.retry(attempts_, cfg_.retries, cfg_.fault_threshold, may_retry)) {
            handshake_polling_ = false;
            state_ = state::pending_send;
            error_ = ec; // the cause so far, replaced by the final outcome
            return;
        }
        ++stats_.failed;
        finish(ec);
    }

    void finish(ferrule::error ec) noexcept {
        error_ = ec;
        state_ = state::done;
    }

    void mark_activity(time_point now, duration pause) noexcept {
        last_activity_ = now;
        if (pause > pause_) pause_ = pause;
        hold_line(now);
    }
    // No request before the line has been idle for pause_ after its last activity: the start
    // pause (SC01 p.19), longer after a broken telegram or a broadcast (SC01 p.21-22).
    void hold_line(time_point now) noexcept { hold_.set(now, last_activity_ + pause_); }

    bool handshake_of(std::uint8_t adr) const noexcept {
        return (handshake_[adr / 8] >> (adr % 8)) & 1u;
    }
    void toggle_handshake(std::uint8_t adr) noexcept {
        handshake_[adr / 8] = static_cast<std::uint8_t>(handshake_[adr / 8] ^ (1u << (adr % 8)));
    }

    master_config cfg_;
    wire_clock wire_; // cfg_.format's character times, the product taken once
    master_stats stats_{};
    state state_ = state::idle;
    telegram request_{};
    telegram reply_{};
    std::array<std::uint8_t, max_telegram_size> tx_{};
    std::size_t tx_size_ = 0;
    decoder decoder_{decoder::accept::responses};
    time_point last_activity_{};
    time_point tx_end_{};
    duration pause_ = movilink::start_pause;
    line_hold hold_{time_point{}, movilink::start_pause};
    ferrule::error error_{};
    unsigned attempts_ = 0;
    unsigned handshake_polls_ = 0;
    fault_latch latch_{};
    bool param_job_ = false;
    bool handshake_polling_ = false;
    std::array<std::uint8_t, 32> handshake_{}; // one bit per address
};

} // namespace ferrule::movilink
