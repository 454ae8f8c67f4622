// mock_serial: a byte_stream in virtual time, for tests.
//
// The line runs at a configured serial_format: every byte takes its wire time, a write
// returns when its last byte has left (like write + tcdrain), and read_some() moves the
// clock to the next arriving byte or to the deadline, so a 5 s timeout costs no real time.
// The far end is a mock_peer: scripted (script_peer) or a simulated device; with no peer the
// far end is silent (it hears everything and never answers). Every byte on the line is
// recorded with its start and end time so tests can assert gaps exactly. Faults: any one
// I/O operation can be made to fail (fail_at), and the far end can close (end_of_stream).
// Fixed capacity, no heap: usable in firmware-style tests too.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule {

class mock_serial;

// The device at the other end of a mock_serial line.
class mock_peer {
public:
    // Bytes written by the session under test; `end` is when the last one left the wire.
    virtual void on_receive(mock_serial& line, std::span<const std::uint8_t> bytes,
                            time_point end) = 0;
    // When the peer next wants to act (reply after a delay), or never.
    virtual time_point wake_at() const noexcept { return never; }
    virtual void on_wake(mock_serial&, time_point) {}

protected:
    ~mock_peer() = default;
};

struct wire_byte {
    enum class from : std::uint8_t { session, peer };
    time_point start;
    time_point end;
    std::uint8_t value;
    from origin;
};

class mock_serial {
public:
    using time_point = ferrule::time_point;
    static constexpr std::size_t rx_capacity = 1024;
    static constexpr std::size_t log_capacity = 4096;

    explicit mock_serial(serial_format fmt, mock_peer* peer = nullptr) noexcept
        : fmt_(fmt), peer_(peer) {}

    void set_peer(mock_peer* p) noexcept { peer_ = p; }
    const serial_format& format() const noexcept { return fmt_; }
    duration char_time() const noexcept { return fmt_.char_time(); }

    // --- byte_stream -------------------------------------------------------------------
    time_point now() const noexcept { return now_; }

    io_result write(std::span<const std::uint8_t> out) {
        if (const ferrule::error ec = count_operation()) return {0, ec};
        process_wakes(now_);
        if (rx_busy_.holds(now_)) ++collisions_;
        const time_point start = now_;
        for (std::size_t i = 0; i < out.size(); ++i)
            log(start + fmt_.chars_time(i), start + fmt_.chars_time(i + 1), out[i],
                wire_byte::from::session);
        now_ = start + fmt_.chars_time(out.size());
        ++writes_;
        if (peer_ && !out.empty() && !closed_) peer_->on_receive(*this, out, now_);
        return {out.size(), {}};
    }

    io_result read_some(std::span<std::uint8_t> in, time_point deadline) {
        if (const ferrule::error ec = count_operation()) return {0, ec};
        if (in.empty()) return {0, {}};
        for (;;) {
            process_wakes(now_);
            if (rx_size_ > 0 && !before(now_, rx_[rx_head_].arrival)) {
                std::size_t n = 0;
                const std::size_t limit = read_size_ ? std::min(read_size_, in.size()) : in.size();
                while (n < limit && rx_size_ > 0 && !before(now_, rx_[rx_head_].arrival)) {
                    in[n++] = rx_[rx_head_].value;
                    pop_rx();
                }
                return {n, {}};
            }
            if (closed_ && rx_size_ == 0) return {0, errc::transport};
            time_point next = rx_size_ > 0 ? scheduled(rx_[rx_head_].arrival) : never;
            if (peer_ && !closed_) next = earliest(next, peer_->wake_at());
            if (!reached(next, deadline)) {
                now_ = latest(now_, deadline);
                return {0, errc::timeout};
            }
            now_ = latest(now_, next);
        }
    }

    // Optional byte_stream members.
    void discard_input() noexcept {
        process_wakes(now_);
        while (rx_size_ > 0 && !before(now_, rx_[rx_head_].arrival)) {
            pop_rx();
            ++discarded_;
        }
    }

    // --- the peer's side ---------------------------------------------------------------
    // Puts bytes on the line towards the session, first byte starting at `start` (or when
    // the line is free), with `gap` of silence between consecutive bytes.
    void inject(std::span<const std::uint8_t> bytes, time_point start, duration gap = {}) {
        // After the bytes still arriving: kept as a line_hold, so that a test may leave the
        // line idle for longer than half the 32-bit tick's range (core/time.hpp).
        const time_point t0 = rx_busy_.holds(now_) ? latest(start, rx_busy_.end()) : start;
        for (std::size_t i = 0; i < bytes.size(); ++i) {
            // Exact wire times: byte i starts after i characters and i gaps.
            const time_point s = t0 + fmt_.chars_time(i) + static_cast<std::int64_t>(i) * gap;
            const time_point end = t0 + fmt_.chars_time(i + 1) + static_cast<std::int64_t>(i) * gap;
            if (rx_size_ < rx_capacity) {
                rx_[(rx_head_ + rx_size_) % rx_capacity] = {end, bytes[i]};
                ++rx_size_;
            } else {
                ++overflowed_;
            }
            log(s, end, bytes[i], wire_byte::from::peer);
            rx_busy_.extend(now_, end);
        }
    }

    // --- time and faults ---------------------------------------------------------------
    void advance(duration d) { sleep_until(now_ + d); }
    void sleep_until(time_point t) {
        while (peer_ && reached(peer_->wake_at(), t)) {
            now_ = latest(now_, peer_->wake_at());
            peer_->on_wake(*this, now_);
        }
        now_ = latest(now_, t);
    }
    // The n-th I/O operation from now (write or read_some; 1: the next one) fails with `ec`
    // and does nothing else: no byte leaves or is taken, the clock stays. The operations
    // after it run normally; 0 fails none. Like Beast's test::stream fail_count, so a test
    // can count a transaction's operations (io_operations()) and fail each one in turn.
    void fail_at(std::size_t n, ferrule::error ec = errc::transport) noexcept {
        fail_countdown_ = n;
        fail_ec_ = ec;
    }
    // The far end closes (or opens again with false). Bytes already on their way are still
    // read; then read_some returns errc::transport at once, as a read of a closed port or
    // socket ends without waiting. Writes still leave, and the peer hears none of them.
    void end_of_stream(bool closed = true) noexcept { closed_ = closed; }
    // Deliver at most n bytes per read_some (0: as many as have arrived).
    void set_read_size(std::size_t n) noexcept { read_size_ = n; }

    // --- what happened -----------------------------------------------------------------
    std::span<const wire_byte> wire() const noexcept { return {log_.data(), log_size_}; }
    std::size_t pending() const noexcept { return rx_size_; }
    // When the next byte towards the session arrives (never: none is on its way).
    time_point next_arrival() const noexcept {
        return rx_size_ > 0 ? scheduled(rx_[rx_head_].arrival) : never;
    }
    std::size_t discarded() const noexcept { return discarded_; }
    std::size_t collisions() const noexcept { return collisions_; }
    std::size_t writes() const noexcept { return writes_; }
    // write and read_some calls so far, failed ones included.
    std::size_t io_operations() const noexcept { return operations_; }
    std::size_t log_overflowed() const noexcept { return log_dropped_; }
    std::size_t rx_overflowed() const noexcept { return overflowed_; }
    void clear_wire_log() noexcept { log_size_ = 0; }

private:
    struct rx_byte {
        time_point arrival;
        std::uint8_t value;
    };

    ferrule::error count_operation() noexcept {
        ++operations_;
        if (fail_countdown_ == 0 || --fail_countdown_ > 0) return {};
        return fail_ec_;
    }
    void process_wakes(time_point t) {
        while (peer_ && reached(peer_->wake_at(), t))
            peer_->on_wake(*this, latest(peer_->wake_at(), now_));
    }
    void pop_rx() noexcept {
        rx_head_ = (rx_head_ + 1) % rx_capacity;
        --rx_size_;
    }
    void log(time_point s, time_point e, std::uint8_t v, wire_byte::from f) noexcept {
        if (log_size_ < log_capacity)
            log_[log_size_++] = {s, e, v, f};
        else
            ++log_dropped_;
    }

    serial_format fmt_;
    mock_peer* peer_;
    time_point now_{};
    line_hold rx_busy_{}; // until the last byte towards the session has arrived
    std::array<rx_byte, rx_capacity> rx_{};
    std::size_t rx_head_ = 0;
    std::size_t rx_size_ = 0;
    std::array<wire_byte, log_capacity> log_{};
    std::size_t log_size_ = 0;
    std::size_t log_dropped_ = 0;
    std::size_t discarded_ = 0;
    std::size_t overflowed_ = 0;
    std::size_t collisions_ = 0;
    std::size_t writes_ = 0;
    std::size_t read_size_ = 0;
    std::size_t operations_ = 0;
    std::size_t fail_countdown_ = 0;
    ferrule::error fail_ec_{};
    bool closed_ = false;
};

static_assert(session_stream<mock_serial>);
static_assert(discards_input<mock_serial>);

// Faults a simulated device applies to its next replies on a mock_serial line: leave them
// out (the master sees a timeout), flip bits of one byte, or send them later. Each knob acts
// on the next k replies. The protocols' simulated buses (movilink::sim::bus,
// dimetix::sim::bus) put their devices' replies on the line through deliver().
class reply_faults {
public:
    static constexpr std::size_t max_reply = 256;

    void drop_replies(unsigned k) noexcept { drop_ = k; }
    void corrupt_replies(unsigned k, std::size_t byte_index, std::uint8_t mask = 0xFF) noexcept {
        corrupt_ = k;
        corrupt_index_ = byte_index;
        corrupt_mask_ = mask;
    }
    void delay_replies(unsigned k, duration extra) noexcept {
        delay_ = k;
        extra_delay_ = extra;
    }

    std::size_t replies_sent() const noexcept { return sent_; } // put on the line
    std::size_t replies_dropped() const noexcept { return dropped_; }

    // Puts `reply` (at most max_reply bytes) on the line at `at`, as the knobs say.
    void deliver(mock_serial& line, std::span<const std::uint8_t> reply, time_point at) {
        if (drop_ > 0) {
            --drop_;
            ++dropped_;
            return;
        }
        std::array<std::uint8_t, max_reply> buf{};
        const std::size_t n = std::min(reply.size(), buf.size());
        std::copy_n(reply.begin(), n, buf.begin());
        if (corrupt_ > 0) {
            --corrupt_;
            if (corrupt_index_ < n)
                buf[corrupt_index_] =
                    static_cast<std::uint8_t>(buf[corrupt_index_] ^ corrupt_mask_);
        }
        if (delay_ > 0) {
            --delay_;
            at += extra_delay_;
        }
        line.inject(std::span<const std::uint8_t>(buf.data(), n), at);
        ++sent_;
    }

private:
    unsigned drop_ = 0;
    unsigned corrupt_ = 0;
    std::size_t corrupt_index_ = 0;
    std::uint8_t corrupt_mask_ = 0xFF;
    unsigned delay_ = 0;
    duration extra_delay_{};
    std::size_t sent_ = 0;
    std::size_t dropped_ = 0;
};

// A peer that follows a script: for each request, check the bytes and answer.
struct script_step {
    std::span<const std::uint8_t> expect{}; // empty: accept any request
    std::span<const std::uint8_t> reply{};  // empty: no reply (the device stays silent)
    duration delay{};                       // request end -> first reply byte
    std::span<const std::uint8_t> noise{};  // sent right after the request, before the reply
    std::size_t chunk = 0;                  // split the reply into chunks of this size ...
    duration chunk_gap{};                   // ... with this silence between them
    int drop_index = -1;                    // leave out this reply byte
    int corrupt_index = -1;                 // flip bits of this reply byte
    std::uint8_t corrupt_mask = 0xFF;
};

class script_peer final : public mock_peer {
public:
    explicit script_peer(std::span<const script_step> steps) noexcept : steps_(steps) {}

    void on_receive(mock_serial& line, std::span<const std::uint8_t> bytes,
                    time_point end) override {
        if (next_ >= steps_.size()) {
            ++unexpected_;
            return;
        }
        const script_step& s = steps_[next_++];
        if (!s.expect.empty() &&
            !std::equal(bytes.begin(), bytes.end(), s.expect.begin(), s.expect.end())) {
            ++mismatches_;
            if (first_mismatch_ == 0) first_mismatch_ = next_;
        }
        if (!s.noise.empty()) line.inject(s.noise, end);
        if (s.reply.empty()) return;
        std::array<std::uint8_t, 512> buf{};
        std::size_t n = 0;
        for (std::size_t i = 0; i < s.reply.size() && n < buf.size(); ++i) {
            if (static_cast<int>(i) == s.drop_index) continue;
            std::uint8_t b = s.reply[i];
            if (static_cast<int>(i) == s.corrupt_index)
                b = static_cast<std::uint8_t>(b ^ s.corrupt_mask);
            buf[n++] = b;
        }
        const std::span<const std::uint8_t> reply(buf.data(), n);
        time_point t = end + s.delay;
        if (s.chunk == 0) {
            line.inject(reply, t);
            return;
        }
        for (std::size_t off = 0; off < reply.size(); off += s.chunk) {
            const auto part = reply.subspan(off, std::min(s.chunk, reply.size() - off));
            line.inject(part, t);
            t += line.format().chars_time(part.size()) + s.chunk_gap;
        }
    }

    std::size_t steps_done() const noexcept { return next_; }
    bool finished() const noexcept { return next_ == steps_.size(); }
    std::size_t mismatches() const noexcept { return mismatches_; }
    std::size_t first_mismatch() const noexcept { return first_mismatch_; } // 1-based step
    std::size_t unexpected_requests() const noexcept { return unexpected_; }

private:
    std::span<const script_step> steps_;
    std::size_t next_ = 0;
    std::size_t mismatches_ = 0;
    std::size_t first_mismatch_ = 0;
    std::size_t unexpected_ = 0;
};

} // namespace ferrule
