// Dimetix sensor session (the host's side of the line), sans-I/O: one command at a time.
//
// Behaviour (S1 §5.8 p.20, §8.1-8.2; dimetix.md §5):
//   * the host owns the line: it sends the next command only after the answer or a timeout
//     ("always waiting for the answer … or timeout"), with no further gap (none is
//     documented); stale input is dropped before sending
//   * the answer is the first line that answers the command (check_answers), recognised by
//     the ID digits and mnemonic it repeats (detail::read_answer): lines of other IDs, the
//     startup string `gN?` and queued tracking lines `gNh+…` of this ID (still coming after
//     sNc) are skipped and counted, not taken as the answer
//   * deadline from the end of the command on the wire: measurement_timeout for commands
//     that measure or write flash (g, h, m, t, s, d), command_timeout for the others
//   * a timeout or a malformed line (not a Dimetix line, or the answer or a `gN@Ezzz` with a
//     malformed rest) is retried (the command is sent again: "each new command cancels an
//     active measurement", S1 §8.2.2); `gN@Ezzz` ends the command with the device error
//     unless retry_device_errors
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
    std::uint32_t malformed_lines = 0; // not a Dimetix line; an answer / gN@Ezzz malformed
    std::uint32_t device_errors = 0;   // gN@Ezzz from the sensor asked
    std::uint32_t resends = 0;
    std::uint32_t foreign_lines = 0; // answers of other IDs
    std::uint32_t skipped_lines = 0; // lines of this ID that do not answer the command
    std::uint32_t startups = 0;      // startup strings gN? skipped (S1 §8.1.5)
    std::uint32_t stale_bytes = 0;   // received while no answer was awaited
};

// A command with what the session reads from the command table for it (S1 ch.8): the answer
// it gets and whether it measures (or writes flash), which sets its timeout.
struct planned_command {
    command cmd{};
    answer expect = answer::none; // none: not a documented form; start() refuses it
    bool measures = false;
};

// The plan for `c`; answer::none for an undocumented form, an ID out of range or more than a
// request holds (parameter ranges are the sensor's to check, @E203; validate() checks them).
constexpr planned_command plan(const command& c) noexcept {
    planned_command p{c};
    if ((c.id > max_id && c.id != command::no_id) || c.param_count > command::max_params ||
        c.digits > 10) // as encode(): a request holds max_request_length bytes
        return p;
    if (const std::size_t i = spec_index(c.mnemonic, c.id != command::no_id);
        i < command_table.size()) {
        p.expect = answer_of(command_table[i], c.param_count);
        p.measures = command_table[i].measures;
    }
    return p;
}

class sensor {
public:
    constexpr explicit sensor(const sensor_config& cfg = {}) noexcept
        : wire_(cfg.format), cfg_(cfg) {}

    // One command: send it, wait for its answer, retry as configured.
    ferrule::error start(const command& c) noexcept { return start(plan(c)); }
    // A command planned beforehand: `static constexpr planned_command p = plan(distance(1));`
    // reads the command table at compile time, so a firmware image links none of it.
    ferrule::error start(const planned_command& p) noexcept {
        if (busy()) return errc::busy;
        if (p.expect == answer::none) return errc::invalid_argument;
        const command& c = p.cmd;
        if (cfg_.multi_drop &&
            (c.id == command::no_id || (is_continuous(c) && !cfg_.force_continuous)))
            return errc::invalid_argument;
        if (latched_ && !c.mnemonic.is('c')) return errc::fault_latched;
        cmd_ = c;
        return begin(p.expect, p.measures, cfg_.retries);
    }

    // The start-up of S1 §8.2.1 / the paper: sNc until the sensor acknowledges with gN?.
    ferrule::error start_connect(std::uint8_t id) noexcept {
        if (busy()) return errc::busy;
        if (id > max_id || cfg_.connect_attempts == 0) return errc::invalid_argument;
        cmd_ = {}; // stop_clear(id), built in place (smaller than a copy)
        cmd_.id = id;
        cmd_.mnemonic.chars[0] = 'c';
        cmd_.mnemonic.size = 1;
        // Answered gN?, without measuring (S1 §8.2.1).
        return begin(answer::ack, false, cfg_.connect_attempts - 1);
    }

    session_action next(time_point now) noexcept {
        switch (state_) {
        case state::idle: return session_action::idle();
        case state::done: return session_action::done();
        case state::pending_send: {
            if (++attempts_ > 1) ++stats_.resends;
            const time_point end = now + wire_.chars_time(tx_size_);
            deadline_ = end + timeout_;
            if (cfg_.discard_stale_input) decoder_.reset();
            state_ = state::awaiting;
            return session_action::send({tx_.data(), tx_size_}, cfg_.discard_stale_input);
        }
        case state::awaiting:
            if (before(now, deadline_)) return session_action::wait_until(deadline_);
            settle(detail::line_is::timeout);
            return next(now);
        }
        return session_action::idle();
    }

    void on_receive(std::span<const std::uint8_t> in, time_point) noexcept {
        for (const std::uint8_t b : in) {
            const auto what = decoder_.push(b);
            if (state_ != state::awaiting)
                ++stats_.stale_bytes;
            else if (what != line_decoder::status::need_more)
                evaluate(); // the line just read; empty after a malformed one: counted as one
        }
    }

    void on_transport_error(ferrule::error ec) noexcept {
        if (!busy()) return;
        ++stats_.failed;
        finish(ec);
    }

    // Outcome of the finished command: empty, a ferrule::errc, or a device error
    // (dimetix::device_domain, value = zzz of gN@Ezzz).
    ferrule::error error() const noexcept { return error_; }
    // The finished transaction succeeded: error() is empty.
    bool succeeded() const noexcept { return !error_; }
    // The answer (valid when error() is empty; for a device error the gN@Ezzz line).
    const dimetix::reply& reply() const noexcept { return reply_; }
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

    // cmd_, checked by start(), answered by `a` within measurement_timeout after it was sent
    // if it `measures` (or writes flash), else within command_timeout.
    ferrule::error begin(answer a, bool measures, unsigned retries) noexcept {
        tx_size_ = detail::encode_unchecked(cmd_, tx_.data());
        retries_ = retries;
        attempts_ = 0;
        expect_ = a;
        timeout_ = measures ? cfg_.measurement_timeout : cfg_.command_timeout;
        ++stats_.transactions;
        state_ = state::pending_send;
        return error_ = {};
    }

    // The line the decoder has just yielded, read against the command.
    void evaluate() noexcept {
        // reply_: the line read last; the answer once the command is done
        settle(detail::read_answer(cmd_, expect_, decoder_.line(), reply_));
    }

    // The end of an attempt (a line read, or line_is::timeout), counted. One place for both, so
    // that the retry and the fault latch of fail() are built once.
    void settle(detail::line_is what) noexcept {
        // The counter of each outcome, in detail::line_is order.
        static constexpr std::uint32_t sensor_stats::*counter[] = {
            &sensor_stats::succeeded, &sensor_stats::device_errors, &sensor_stats::foreign_lines,
            &sensor_stats::startups,  &sensor_stats::skipped_lines, &sensor_stats::malformed_lines,
            &sensor_stats::timeouts};
        ++(stats_.*counter[static_cast<std::size_t>(what)]);
        if (what == detail::line_is::answer) {
            failures_ = 0;
            // While latched only sNc runs: its gN? has the sensor back in hand (S1 §8.2.1).
            latched_ = false;
            finish({});
        } else if (what == detail::line_is::device_error) {
            // gN@Ezzz: the sensor is there, but refused or failed
            fail(make_device_error(reply_.error_code), cfg_.retry_device_errors, false);
        } else if (what >= detail::line_is::malformed) { // the line faults: malformed, timeout
            fail(what == detail::line_is::malformed ? errc::malformed : errc::timeout, true, true);
        }
    }

    // A failed attempt: resent while attempts remain and `may_retry`, else the command fails
    // with `ec`. A line fault (timeout, malformed line) counts towards the fault latch; a
    // device error does not: the sensor answered.
    void fail(ferrule::error ec, bool may_retry, bool line_fault) noexcept {
        error_ = ec; // while resending: the cause so far, replaced by the final outcome
        if (may_retry && attempts_ <= retries_) {
            state_ = state::pending_send;
            return;
        }
        ++stats_.failed;
        if (line_fault && ++failures_ == cfg_.fault_threshold) latched_ = true; // 0: never
        state_ = state::done;
    }

    void finish(ferrule::error ec) noexcept {
        error_ = ec;
        state_ = state::done;
    }

    // The small members first: Thumb code reaches them with short instructions.
    state state_ = state::idle;
    answer expect_ = answer::none;
    bool latched_ = false;
    unsigned attempts_ = 0;
    unsigned retries_ = 0;
    unsigned failures_ = 0;
    std::size_t tx_size_ = 0;
    ferrule::error error_{};
    time_point deadline_{};
    duration timeout_{};
    wire_clock wire_; // cfg_.format's character times
    sensor_stats stats_{};
    line_decoder decoder_{};
    sensor_config cfg_;
    command cmd_{};
    dimetix::reply reply_{};
    std::array<std::uint8_t, max_request_length> tx_{};
};

static_assert(master_session<sensor>);

} // namespace ferrule::dimetix
