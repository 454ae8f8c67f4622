// Extended MEMOBUS master (the PC side), sans-I/O: one transaction at a time over one
// connection (protocols/memobus.md §6: strict request / response, no pipelining).
//
// Behaviour:
//   * every attempt gets a new serial number, 00…FF and round again, counted per master, that
//     is per connection (§2: "set in ascending order from 00 hex and roll over after FF hex")
//   * TCP: the byte stream is split into messages by their total length (message_decoder);
//     UDP: a stream whose reads hand out one datagram at a time frames the same way, since
//     one datagram holds one message (§6)
//   * a message is checked in the order of Yaskawa's sample (§2): total length (the decoder:
//     total = 12 + 2 + MEMOBUS length), type 0x19 (0x11 too with lenient_response_type: the
//     HSL server's bug, §2), serial, then MFC 0x20, SFC and count (parse_response()). A
//     message with another serial is stale: dropped and counted, the wait goes on (a late
//     answer to an earlier attempt)
//   * SFC | 0x80 is the controller's error code (§3.5), a memobus::device_domain error,
//     not resent; a wrong type, MFC, SFC or length is errc::unexpected_type / malformed and
//     resent like a timeout, up to `retries` times
//   * bytes that start no message are counted as malformed once per run and skipped; at the
//     deadline (request sent + response_timeout) the attempt fails with errc::timeout, or
//     errc::malformed if such garbage came in it
//   * `fault_threshold` failed attempts in a row (0: never) latch a fault: every start is
//     refused with errc::fault_latched until reset_fault()
//   * on_transport_error() ends the transaction with that error
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/fault_latch.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/memobus/constants.hpp"
#include "ferrule/memobus/error.hpp"
#include "ferrule/memobus/header.hpp"
#include "ferrule/memobus/message.hpp"

namespace ferrule::memobus {

struct master_config {
    duration response_timeout = std::chrono::seconds(1); // from sending the request
    unsigned retries = 0;                                // resends after the first attempt
    unsigned fault_threshold = 0;   // failed attempts in a row that latch the fault; 0: never
    std::uint8_t cpu = default_cpu; // §3.2: destination 1, source 0
    data_order order = data_order::big_endian; // SFC 03/04/06/10 data (§3.3, §11.1)
    bool lenient_response_type = false;        // accept type 0x11 in responses (§2)
    std::uint8_t destination_channel = 0;      // 0 from a PC (§2)
    std::uint8_t source_channel = 0;
};

// Transactions end as succeeded or failed. The attempt counters (timeouts, malformed,
// device_errors) count each failed attempt once, resends included.
struct master_stats {
    std::uint32_t transactions = 0;
    std::uint32_t succeeded = 0;
    std::uint32_t failed = 0; // controller errors and transport errors included
    std::uint32_t timeouts = 0;
    std::uint32_t stale = 0;     // whole messages with another serial number
    std::uint32_t malformed = 0; // garbage runs, wrong type, MFC, SFC or length
    std::uint32_t device_errors = 0;
    std::uint32_t resends = 0;
    std::uint32_t stale_bytes = 0; // bytes while no response is awaited, or behind it
};

class master {
public:
    constexpr explicit master(const master_config& cfg = {}) noexcept : cfg_(cfg) {}

    // Starts a transaction. The CPU byte is the configuration's, not r.cpu. invalid_argument
    // for a request encode_command() refuses (limits of §3.4, words or bits that do not match
    // the count); r.words and r.bits need not outlive the call.
    ferrule::error start(const request& r) noexcept {
        if (busy()) return errc::busy;
        if (latch_.fault_latched()) return errc::fault_latched;
        request q = r;
        q.cpu = cfg_.cpu;
        const auto n =
            encode_command(q, 0, tx_, cfg_.order, cfg_.destination_channel, cfg_.source_channel);
        if (!n) return n.error();
        tx_size_ = *n;
        sent_ = q;
        sent_.words = {};
        sent_.bits = {};
        sent_.raw = {};
        attempts_ = 0;
        error_ = {};
        response_ = {};
        ++stats_.transactions;
        state_ = state::pending_send;
        return {};
    }

    session_action next(time_point now) noexcept {
        switch (state_) {
        case state::idle: return session_action::idle();
        case state::done: return session_action::done();
        case state::pending_send: return send(now);
        case state::awaiting:
            if (before(now, deadline_)) return session_action::wait_until(deadline_);
            if (garbage_) {
                fail(errc::malformed); // counted when it came
            } else {
                ++stats_.timeouts;
                fail(errc::timeout);
            }
            return next(now);
        }
        return session_action::idle();
    }

    void on_receive(std::span<const std::uint8_t> in, time_point) noexcept {
        while (!in.empty() && state_ == state::awaiting) {
            const auto s = rx_.feed(in);
            in = in.subspan(s.consumed);
            if (s.what == message_decoder::status::error) {
                ++stats_.malformed;
                garbage_ = true;
            } else if (s.what == message_decoder::status::frame) {
                evaluate();
            }
        }
        stats_.stale_bytes += static_cast<std::uint32_t>(in.size());
    }

    void on_transport_error(ferrule::error ec) noexcept {
        if (!busy()) return;
        ++stats_.failed;
        finish(ec);
    }

    // Outcome of the finished transaction: empty on success, else the cause of the last
    // failed attempt: a ferrule::errc or the controller's memobus::device_domain code.
    ferrule::error error() const noexcept { return error_; }
    // The finished transaction succeeded: error() is empty.
    bool succeeded() const noexcept { return !error_; }
    // The response of a successful transaction; its raw data spans the session's buffer,
    // valid until the next start().
    const memobus::response& reply() const noexcept { return response_; }
    // Register i of the response (03 04 09 0A 0D), in the byte order of its SFC (word_at()).
    std::uint16_t word(std::size_t i) const noexcept {
        return word_at(response_.function, response_.raw, i, cfg_.order);
    }
    // Bit i of the response (01 02), LSB of the first byte first (§3.3).
    bool bit(std::size_t i) const noexcept { return (response_.raw[i / 8] >> (i % 8)) & 1u; }
    // The command as last sent, and its serial number.
    std::span<const std::uint8_t> request_bytes() const noexcept { return {tx_.data(), tx_size_}; }
    std::uint8_t serial() const noexcept { return tx_[1]; }
    unsigned attempts() const noexcept { return attempts_; }
    bool busy() const noexcept {
        return state_ == state::pending_send || state_ == state::awaiting;
    }
    // Done -> idle once the result has been read (a new start does this too).
    void clear() noexcept {
        if (state_ == state::done) state_ = state::idle;
    }

    bool fault_latched() const noexcept { return latch_.fault_latched(); }
    unsigned consecutive_failures() const noexcept { return latch_.consecutive_failures(); }
    void reset_fault() noexcept { latch_.reset_fault(); }

    const master_stats& stats() const noexcept { return stats_; }
    const master_config& config() const noexcept { return cfg_; }

private:
    enum class state : std::uint8_t { idle, pending_send, awaiting, done };

    session_action send(time_point now) noexcept {
        if (++attempts_ > 1) ++stats_.resends;
        tx_[1] = next_serial_++; // wraps after 0xFF
        deadline_ = now + cfg_.response_timeout;
        // A message begun in the last attempt may still complete (a TCP stream keeps its
        // framing); otherwise the decoder starts afresh, and garbage counts per attempt.
        if (!rx_.in_message()) rx_.reset();
        garbage_ = false;
        state_ = state::awaiting;
        return session_action::send({tx_.data(), tx_size_}, false);
    }

    void evaluate() noexcept {
        const header h = rx_.header();
        const bool type_ok = h.type == command_type::response ||
                             (cfg_.lenient_response_type && h.type == command_type::command);
        if (!type_ok) {
            ++stats_.malformed;
            fail(errc::unexpected_type);
            return;
        }
        if (h.serial != tx_[1]) {
            ++stats_.stale;
            return;
        }
        const auto parsed = parse_response(sent_, rx_.body(), cfg_.order);
        if (!parsed) {
            if (parsed.error().domain() == &device_domain) {
                ++stats_.device_errors;
                fail(parsed.error(), false);
                return;
            }
            ++stats_.malformed;
            fail(parsed.error());
            return;
        }
        response_ = *parsed;
        latch_.succeeded();
        ++stats_.succeeded;
        finish({});
    }

    // An attempt failed: resend while retries are left (a controller error is not resent).
    void fail(ferrule::error ec, bool may_retry = true) noexcept {
        if (latch_.retry(attempts_, cfg_.retries, cfg_.fault_threshold, may_retry)) {
            error_ = ec; // the cause so far, replaced by the final outcome
            state_ = state::pending_send;
            return;
        }
        ++stats_.failed;
        finish(ec);
    }

    void finish(ferrule::error ec) noexcept {
        error_ = ec;
        state_ = state::done;
    }

    master_config cfg_;
    master_stats stats_{};
    state state_ = state::idle;
    request sent_{};
    memobus::response response_{};
    std::array<std::uint8_t, max_message> tx_{};
    std::size_t tx_size_ = 0;
    message_decoder rx_{};
    time_point deadline_{};
    ferrule::error error_{};
    unsigned attempts_ = 0;
    fault_latch latch_{};
    std::uint8_t next_serial_ = 0;
    bool garbage_ = false; // bytes that start no message in this attempt
};

static_assert(master_session<master>);

} // namespace ferrule::memobus
