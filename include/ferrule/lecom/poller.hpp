// Poll scheduler: reads a list of (drive, code) items over and over, as a PLC does on a
// LECOM-B bus, and slips queued writes in between. A master_session itself (it never
// reports `done`: it starts the next transaction when one finishes), so run-loops, the
// poll_driver and the asio driver all drive it. It owns its master.
//
// Scheduling, at each point where the bus is free:
//   1. a queued write, first in first out (write() queues; a write is sent before the next
//      poll that is due, but a poll already started finishes first)
//   2. else the due item that is most overdue: the one with the earliest due time, ties in
//      item order. An item is due `interval` after the start of its last poll on the wire
//      (interval 0: at once, so items of interval 0 go round in item order as fast as the
//      bus allows). An item whose interval has run out therefore waits for the poll under
//      way and for the items that have been due longer
//   3. else wait until the earliest due time
// Between two transactions the master keeps its turnaround (master_config::turnaround).
//
// Live list: a drive goes offline after `offline_after` failed transactions in a row that
// say nothing came back from it (timeout, bad BCC, malformed, wrong code echoed). An answer
// of the drive's own (ACK, data, NAK, `?`, no such code) shows it is there. While offline
// its items are polled at most once per `offline_interval` (counted from the start of the
// last probe), so a dead drive does not eat the bus; its next good reply brings it back.
// A probe is one transaction with the master's retries: it costs up to (1 + retries) ×
// (request wire time + response_timeout), 3 × (6.875 + 100) ms for a read at the defaults
// and 9600 8E1, so offline_interval should be well above that. offline_after = 0: drives never go
// offline.
//
// Cycle: cycles() counts the starts on the wire of item 0's poll after its first one, and
// last_cycle_time() is the time between the last two such starts (resends not counted).
// With every interval 0 and no writes that is one pass over all items:
//     Σ over the items (request wire time + drive delay + reply wire time + turnaround)
//
// Worked example, the LECOM paper (lecom.md §5, S7): six 4900 drives at 01…06 on one
// RS-485 segment, 9600 8E1, the PLC reads each drive's actual speed (C0050) "every 50 ms".
// One read is 6 request characters (6.875 ms) + the drive's processing time (t3 = 20 ms,
// S3) + 9 reply characters for a 4-digit value (10.3125 ms) = 37.1875 ms, so the six reads
// take 223.125 ms: a 50 ms interval cannot be kept by any scheduler, 120 ms of it is the
// drives' own processing time. With interval = 50 ms every item is always overdue and the
// poller serves them round the list, each drive every 223 ms, a write costing one slot.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <system_error>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/lecom/code.hpp"
#include "ferrule/lecom/constants.hpp"
#include "ferrule/lecom/error.hpp"
#include "ferrule/lecom/frame.hpp"
#include "ferrule/lecom/master.hpp"
#include "ferrule/lecom/value.hpp"

namespace ferrule::lecom {

struct poll_item {
    std::uint8_t address = 0;
    code_address code{};
    duration interval = duration::zero(); // 0: every cycle, as fast as the bus allows
};

struct item_state {
    value last{};            // the value of the last good read
    std::error_code error{}; // outcome of the last read
    time_point updated{};    // when `last` was read (the reply's end)
    std::uint32_t reads = 0; // reads finished, good or not
    std::uint32_t failures = 0;
    bool valid = false; // the last read succeeded: `last` is current
};

struct drive_state {
    std::uint8_t address = 0;
    bool online = false; // answered, and fewer than offline_after misses since
    bool seen = false;   // has answered at least once
    unsigned misses = 0; // failed transactions in a row without an answer of the drive
    std::uint32_t transactions = 0, failures = 0, timeouts = 0, writes = 0;
};

struct poller_config {
    master_config master{};
    unsigned offline_after = 3;
    duration offline_interval = std::chrono::seconds(1);
};

struct poll_event {
    enum class kind : std::uint8_t { read, write };
    kind what = kind::read;
    std::size_t item = 0; // reads only
    std::uint8_t address = 0;
    code_address code{};
    std::error_code error{};
    lecom::value value{}; // read: the value read (on error the item's last good one); write:
                          // the value written
};

template <std::size_t MaxItems = 32, std::size_t MaxWrites = 8,
          std::size_t MaxDrives = max_drives_per_segment>
class poller {
    static_assert(MaxItems > 0 && MaxWrites > 0 && MaxDrives > 0);

public:
    explicit poller(const poller_config& cfg = {}) noexcept : cfg_(cfg), m_(cfg.master) {}

    // Adds an item, due at once; returns its index. invalid_argument for a group address or
    // a code that cannot be addressed; buffer_too_small when MaxItems items or MaxDrives
    // drives are taken.
    result<std::size_t> add(const poll_item& item) noexcept {
        if (!is_unit_address(item.address) || !is_valid(item.code) ||
            item.interval < duration::zero())
            return errc::invalid_argument;
        if (count_ == MaxItems) return errc::buffer_too_small;
        std::size_t d = find_drive(item.address);
        if (d == drive_count_) {
            if (drive_count_ == MaxDrives) return errc::buffer_too_small;
            drives_[d] = drive_state{};
            drives_[d].address = item.address;
            probe_at_[d] = time_point::min();
            ++drive_count_;
        }
        items_[count_] = item;
        item_drive_[count_] = d;
        due_[count_] = time_point::min();
        states_[count_] = item_state{};
        return count_++;
    }

    // Queues a SEND, sent before the next due poll; FIFO. 00 / x0 reach a group. busy when
    // MaxWrites writes wait or are under way; invalid_argument for what the master could not
    // send.
    std::error_code write(std::uint8_t address, code_address c, const value& v) noexcept {
        std::array<std::uint8_t, max_request_length> probe{};
        if (!encode(write_request(address, c, v), probe)) return errc::invalid_argument;
        if (queued_ == MaxWrites) return errc::busy;
        writes_[(head_ + queued_) % MaxWrites] = queued_write{address, c, v};
        ++queued_;
        return {};
    }

    // --- master_session ----------------------------------------------------------------
    session_action next(time_point now) noexcept {
        session_action a = m_.next(now);
        if (a.what == session_action::kind::done) {
            harvest(now);
            a = m_.next(now);
        }
        if (a.what == session_action::kind::idle) {
            const time_point wake = start_job(now);
            if (wake == never) return session_action::idle();
            if (wake > now) return session_action::wait_until(wake);
            a = m_.next(now);
        }
        if (a.what == session_action::kind::send && m_.attempts() == 1) on_first_send(now);
        return a;
    }
    void on_receive(std::span<const std::uint8_t> in, time_point now) noexcept {
        m_.on_receive(in, now);
    }
    void on_transport_error(std::error_code ec) noexcept { m_.on_transport_error(ec); }
    // Outcome of the last finished transaction.
    std::error_code error() const noexcept { return last_.error; }

    // --- results -----------------------------------------------------------------------
    std::span<const poll_item> items() const noexcept { return {items_.data(), count_}; }
    const item_state& state(std::size_t i) const noexcept { return states_[i]; }
    std::span<const drive_state> drives() const noexcept { return {drives_.data(), drive_count_}; }
    const drive_state* drive(std::uint8_t address) const noexcept {
        const std::size_t d = find_drive(address);
        return d == drive_count_ ? nullptr : &drives_[d];
    }
    // Transactions finished so far; last_event() is the latest.
    std::uint32_t completed() const noexcept { return completed_; }
    const poll_event& last_event() const noexcept { return last_; }
    // Writes waiting, the one under way included.
    std::size_t queued_writes() const noexcept { return queued_; }
    std::uint32_t cycles() const noexcept { return cycles_; }
    duration last_cycle_time() const noexcept { return cycle_time_; }
    const master& session() const noexcept { return m_; }

private:
    enum class job : std::uint8_t { none, read, write };
    struct queued_write {
        std::uint8_t address;
        code_address code;
        value v;
    };

    std::size_t find_drive(std::uint8_t address) const noexcept {
        std::size_t d = 0;
        while (d < drive_count_ && drives_[d].address != address) ++d;
        return d;
    }

    bool offline(std::size_t d) const noexcept {
        return cfg_.offline_after != 0 && drives_[d].misses >= cfg_.offline_after;
    }

    time_point due_time(std::size_t i) const noexcept {
        const std::size_t d = item_drive_[i];
        return offline(d) && probe_at_[d] > due_[i] ? probe_at_[d] : due_[i];
    }

    // Starts the next transaction and returns `now`, or returns when the next item is due
    // (never: nothing to do).
    time_point start_job(time_point now) noexcept {
        sent_at_ = now;
        if (queued_ > 0) { // it leaves the queue when it has been sent
            const queued_write& w = writes_[head_];
            running_ = job::write;
            (void)m_.start_write(w.address, w.code, w.v); // checked by write(); the master is idle
            return now;
        }
        std::size_t best = count_;
        time_point best_due = never;
        for (std::size_t i = 0; i < count_; ++i) {
            const time_point t = due_time(i);
            if (t < best_due) {
                best = i;
                best_due = t;
            }
        }
        if (best == count_ || best_due > now) return best_due;
        running_ = job::read;
        current_item_ = best;
        (void)m_.start_read(items_[best].address, items_[best].code); // checked by add()
        return now;
    }

    void on_first_send(time_point now) noexcept {
        sent_at_ = now;
        if (running_ != job::read || current_item_ != 0) return;
        if (cycle_started_) {
            ++cycles_;
            cycle_time_ = now - cycle_start_;
        }
        cycle_start_ = now;
        cycle_started_ = true;
    }

    void harvest(time_point now) noexcept {
        const std::error_code ec = m_.error();
        ++completed_;
        last_.error = ec;
        std::size_t d = drive_count_;
        if (running_ == job::write) {
            const queued_write& w = writes_[head_];
            last_.what = poll_event::kind::write;
            last_.item = 0;
            last_.address = w.address;
            last_.code = w.code;
            last_.value = w.v;
            head_ = (head_ + 1) % MaxWrites;
            --queued_;
            d = find_drive(last_.address);
            if (d < drive_count_) ++drives_[d].writes;
        } else {
            const poll_item& it = items_[current_item_];
            item_state& s = states_[current_item_];
            last_.what = poll_event::kind::read;
            last_.item = current_item_;
            last_.address = it.address;
            last_.code = it.code;
            ++s.reads;
            s.error = ec;
            s.valid = !ec;
            if (ec) {
                ++s.failures;
            } else {
                s.last = m_.reply().value;
                s.updated = now;
            }
            last_.value = s.last;
            due_[current_item_] = sent_at_ + it.interval;
            d = item_drive_[current_item_];
        }
        if (d < drive_count_) account(d, ec);
        running_ = job::none;
        m_.clear();
    }

    // Nothing came back from the drive (lecom.md §1.12: silence, or a telegram broken on
    // the line); device errors are answers, transport errors are the host's port.
    static bool is_miss(std::error_code ec) noexcept {
        constexpr unsigned misses =
            1u << static_cast<int>(errc::timeout) | 1u << static_cast<int>(errc::bad_checksum) |
            1u << static_cast<int>(errc::malformed) | 1u << static_cast<int>(errc::unexpected_type);
        return ec.category() == errc_category() && ec.value() > 0 && ec.value() < 32 &&
               (misses >> ec.value() & 1u) != 0;
    }

    void account(std::size_t d, std::error_code ec) noexcept {
        drive_state& s = drives_[d];
        ++s.transactions;
        if (ec) ++s.failures;
        if (ec == errc::timeout) ++s.timeouts;
        if (!ec || ec.category() == device_category()) {
            s.seen = true;
            s.online = true;
            s.misses = 0;
        } else if (is_miss(ec)) {
            ++s.misses;
            if (offline(d)) {
                s.online = false;
                probe_at_[d] = sent_at_ + cfg_.offline_interval;
            }
        }
    }

    poller_config cfg_;
    master m_;
    std::array<poll_item, MaxItems> items_{};
    std::array<item_state, MaxItems> states_{};
    std::array<time_point, MaxItems> due_{};
    std::array<std::size_t, MaxItems> item_drive_{};
    std::size_t count_ = 0;
    std::array<drive_state, MaxDrives> drives_{};
    std::array<time_point, MaxDrives> probe_at_{};
    std::size_t drive_count_ = 0;
    std::array<queued_write, MaxWrites> writes_{};
    std::size_t head_ = 0;
    std::size_t queued_ = 0;
    job running_ = job::none;
    std::size_t current_item_ = 0;
    time_point sent_at_{}; // start of the running transaction's first request on the wire
    poll_event last_{};
    std::uint32_t completed_ = 0;
    std::uint32_t cycles_ = 0;
    duration cycle_time_{};
    time_point cycle_start_{};
    bool cycle_started_ = false;
};

static_assert(master_session<poller<>>);

} // namespace ferrule::lecom
