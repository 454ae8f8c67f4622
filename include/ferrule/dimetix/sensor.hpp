// Dimetix sensor session (the host's side of the line), sans-I/O: one command at a time.
//
// Behaviour (S1 §5.8 p.20, §8.1-8.2; dimetix.md §5):
//   * the host owns the line: it sends the next command only after the answer or a timeout
//     ("always waiting for the answer … or timeout"), with no further gap (none is
//     documented); stale input is dropped before sending
//   * the answer is the first line that answers the command (check_answers): lines of other
//     IDs, the startup string `gN?` and queued tracking lines `gNh+…` of this ID (still
//     coming after sNc) are skipped and counted, not taken as the answer
//   * deadline from the end of the command on the wire: measurement_timeout for commands
//     that measure or write flash (g, h, m, t, s, d), command_timeout for the others
//   * a timeout or a malformed line is retried (the command is sent again: "each new command
//     cancels an active measurement", S1 §8.2.2); `gN@Ezzz` ends the command with the
//     device error unless retry_device_errors
//   * multi-drop (default): continuous commands (sNh, sNh+, sNm+1) are refused, because on
//     RS-485 only a power cycle stops them (S1 §8.2.3-8.2.4); force_continuous allows them
//     on a one-sensor RS-232/422 line. ID-less dt / dg are refused too (S1 §8.5.3-8.5.4)
//   * fault_threshold failed commands in a row latch a fault: only sNc is then accepted,
//     and its acknowledge clears the latch (the paper's start-up: sNc until gN?)
//   * a continuous command is done with its first line; the lines that follow are stale
//     input for the next command, and the answer to sNc is found behind them
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
#include "ferrule/dimetix/command.hpp"
#include "ferrule/dimetix/constants.hpp"
#include "ferrule/dimetix/error.hpp"
#include "ferrule/dimetix/line.hpp"
#include "ferrule/dimetix/reply.hpp"

namespace ferrule::dimetix {

struct sensor_config {
    serial_format format = default_format;
    duration command_timeout = dimetix::command_timeout;
    duration measurement_timeout = dimetix::measurement_timeout;
    unsigned retries = 2;           // resends after the first attempt
    unsigned connect_attempts = 10; // sNc sent by start_connect() before it gives up
    unsigned fault_threshold = 5;   // failed commands in a row that latch the fault; 0: never
    bool retry_device_errors = false;
    bool multi_drop = true;        // RS-422/485 with (possibly) several sensors
    bool force_continuous = false; // allow sNh / sNh+ / sNm+1 although multi_drop
    bool discard_stale_input = true;
};

struct sensor_stats {
    std::uint32_t transactions = 0;
    std::uint32_t succeeded = 0;
    std::uint32_t failed = 0;
    std::uint32_t timeouts = 0;
    std::uint32_t malformed_lines = 0; // not a Dimetix answer, or too long
    std::uint32_t device_errors = 0;   // gN@Ezzz from the sensor asked
    std::uint32_t resends = 0;
    std::uint32_t foreign_lines = 0; // answers of other IDs
    std::uint32_t skipped_lines = 0; // lines of this ID that do not answer the command
    std::uint32_t startups = 0;      // startup strings gN? skipped (S1 §8.1.5)
    std::uint32_t stale_bytes = 0;   // received while no answer was awaited
};

class sensor {
public:
    explicit sensor(const sensor_config& cfg = {}) noexcept : cfg_(cfg) {}

    // One command: send it, wait for its answer, retry as configured.
    std::error_code start(const command& c) noexcept {
        if (busy()) return errc::busy;
        // A documented command form (S1 ch.8); parameter ranges are the sensor's to check
        // (@E203), validate() checks them beforehand.
        if ((c.id > max_id && c.id != command::no_id) || c.param_count > command::max_params)
            return errc::invalid_argument;
        const command_spec* s = find_spec(c.mnemonic, c.id != command::no_id);
        if (!s || answer_of(*s, c.param_count) == answer::none) return errc::invalid_argument;
        if (cfg_.multi_drop &&
            (c.id == command::no_id || (is_continuous(c) && !cfg_.force_continuous)))
            return errc::invalid_argument;
        if (latched_ && !c.mnemonic.is('c')) return errc::fault_latched;
        return begin(c, *s, cfg_.retries);
    }

    // The start-up of S1 §8.2.1 / the paper: sNc until the sensor acknowledges with gN?.
    std::error_code start_connect(std::uint8_t id) noexcept {
        if (busy()) return errc::busy;
        if (id > max_id || cfg_.connect_attempts == 0) return errc::invalid_argument;
        static constexpr command stop = stop_clear(0);
        command c = stop;
        c.id = id;
        return begin(c, command_table[0], cfg_.connect_attempts - 1);
    }

    session_action next(time_point now) noexcept {
        switch (state_) {
        case state::idle: return session_action::idle();
        case state::done: return session_action::done();
        case state::pending_send: {
            if (++attempts_ > 1) ++stats_.resends;
            const time_point end = now + cfg_.format.chars_time(tx_size_);
            deadline_ = end + timeout_;
            if (cfg_.discard_stale_input) decoder_.reset();
            state_ = state::awaiting;
            return session_action::send({tx_.data(), tx_size_}, cfg_.discard_stale_input);
        }
        case state::awaiting:
            if (now < deadline_) return session_action::wait_until(deadline_);
            fail(errc::timeout, true);
            return next(now);
        }
        return session_action::idle();
    }

    void on_receive(std::span<const std::uint8_t> in, time_point) noexcept {
        while (!in.empty()) {
            const auto step = decoder_.feed(in);
            const bool awaiting = state_ == state::awaiting;
            if (!awaiting) stats_.stale_bytes += static_cast<std::uint32_t>(step.consumed);
            in = in.subspan(step.consumed);
            if (!awaiting || step.what == line_decoder::status::need_more) continue;
            if (step.what == line_decoder::status::error) {
                ++stats_.malformed_lines;
                fail(errc::malformed, true);
            } else {
                evaluate(decoder_.line());
            }
        }
    }

    void on_transport_error(std::error_code ec) noexcept {
        if (busy()) finish(ec);
    }

    // Outcome of the finished command: empty, a ferrule::errc, or a device error
    // (dimetix::device_category(), value = zzz of gN@Ezzz).
    std::error_code error() const noexcept { return error_; }
    // The answer (valid when error() is empty; for a device error the gN@Ezzz line).
    const reply& last_reply() const noexcept { return reply_; }
    const command& last_command() const noexcept { return cmd_; }
    unsigned attempts() const noexcept { return attempts_; }
    bool busy() const noexcept {
        return state_ == state::pending_send || state_ == state::awaiting;
    }
    // Done -> idle once the result has been read (a new start does this too).
    void clear() noexcept {
        if (state_ == state::done) state_ = state::idle;
    }

    bool fault_latched() const noexcept { return latched_; }
    unsigned consecutive_failures() const noexcept { return failures_; }
    void reset_fault() noexcept {
        latched_ = false;
        failures_ = 0;
    }
    const sensor_stats& stats() const noexcept { return stats_; }
    const sensor_config& config() const noexcept { return cfg_; }
    // The command as last sent (for tracing).
    std::span<const std::uint8_t> request_bytes() const noexcept { return {tx_.data(), tx_size_}; }

private:
    enum class state : std::uint8_t { idle, pending_send, awaiting, done };

    std::error_code begin(const command& c, const command_spec& s, unsigned retries) noexcept {
        tx_size_ = detail::encode_unchecked(c, tx_.data()); // checked by start()
        cmd_ = c;
        retries_ = retries;
        attempts_ = 0;
        error_ = {};
        reply_ = {};
        expect_ = answer_of(s, c.param_count);
        timeout_ = s.measures ? cfg_.measurement_timeout : cfg_.command_timeout;
        ++stats_.transactions;
        state_ = state::pending_send;
        return {};
    }

    void evaluate(std::span<const std::uint8_t> line) noexcept {
        reply& r = reply_; // the line read last; the answer once the command is done
        r = reply{};
        if (!detail::parse_into(line, r)) {
            ++stats_.malformed_lines;
            fail(errc::malformed, true);
            return;
        }
        switch (detail::classify(cmd_, expect_, r)) {
        case detail::match::other_id: ++stats_.foreign_lines; break;
        case detail::match::other_answer:
            if (r.kind == reply_kind::startup_or_ack)
                ++stats_.startups;
            else
                ++stats_.skipped_lines;
            break;
        case detail::match::device_error: // gN@Ezzz: the sensor is there, but refused or failed
            ++stats_.device_errors;
            fail(make_device_error(r.error_code), cfg_.retry_device_errors);
            break;
        case detail::match::answer:
            detail::make_answer(cmd_, expect_, r);
            succeed();
            break;
        }
    }

    void succeed() noexcept {
        ++stats_.succeeded;
        failures_ = 0;
        if (cmd_.mnemonic.is('c')) latched_ = false; // S1 §8.2.1: the sensor is back in hand
        finish({});
    }

    void fail(std::error_code ec, bool may_retry) noexcept {
        if (ec == errc::timeout) ++stats_.timeouts;
        if (may_retry && attempts_ <= retries_) {
            error_ = ec; // the cause so far, replaced by the final outcome
            state_ = state::pending_send;
            return;
        }
        ++stats_.failed;
        if (ec.category() != device_category() && ++failures_ >= cfg_.fault_threshold &&
            cfg_.fault_threshold != 0)
            latched_ = true;
        finish(ec);
    }

    void finish(std::error_code ec) noexcept {
        error_ = ec;
        state_ = state::done;
    }

    sensor_config cfg_;
    sensor_stats stats_{};
    state state_ = state::idle;
    command cmd_{};
    reply reply_{};
    line_decoder decoder_{};
    std::array<std::uint8_t, max_request_length> tx_{};
    std::size_t tx_size_ = 0;
    time_point deadline_{};
    duration timeout_{};
    answer expect_ = answer::none;
    std::error_code error_{};
    unsigned attempts_ = 0;
    unsigned retries_ = 0;
    unsigned failures_ = 0;
    bool latched_ = false;
};

static_assert(master_session<sensor>);

} // namespace ferrule::dimetix
