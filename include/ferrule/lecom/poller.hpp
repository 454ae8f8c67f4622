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
    ferrule::error error{};  // outcome of the last read
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
    ferrule::error error{};
    lecom::value value{}; // read: the value read (on error the item's last good one); write:
                          // the value written
};

template <std::size_t MaxItems = 32, std::size_t MaxWrites = 8,
          std::size_t MaxDrives = max_drives_per_segment>
class poller {
    static_assert(MaxItems > 0 && MaxWrites > 0 && MaxDrives > 0);

public:
    explicit poller(const poller_config& cfg = {}) noexcept
        : m_(cfg.master), offline_after_(cfg.offline_after),
          offline_interval_(cfg.offline_interval) {}

    // Adds an item, due at once; returns its index. invalid_argument for a group address or
    // a code that cannot be addressed; buffer_too_small when MaxItems items or MaxDrives
    // drives are taken.
    result<std::size_t> add(const poll_item& item) noexcept {
        if (!is_valid_request(item.address, item.code, nullptr) || item.interval < duration::zero())
            return errc::invalid_argument;
        if (t_.count == MaxItems) return errc::buffer_too_small;
        // Slots past the counts are as constructed: nothing is ever removed.
        std::size_t d = find_drive(item.address);
        if (d == t_.drive_count) {
            if (t_.drive_count == MaxDrives) return errc::buffer_too_small;
            t_.drives[d].address = item.address; // probe_at[d] is set when it goes offline
            ++t_.drive_count;
        }
        t_.items[t_.count] = item;
        t_.item_drive[t_.count] = d;
        t_.due[t_.count] = time_point::min();
        return t_.count++;
    }

    // Queues a SEND, sent before the next due poll; FIFO. 00 / x0 reach a group. busy when
    // MaxWrites writes wait or are under way; invalid_argument for what the master could not
    // send.
    ferrule::error write(std::uint8_t address, code_address c, const value& v) noexcept {
        if (!is_valid_request(address, c, &v)) return errc::invalid_argument;
        if (t_.queued == MaxWrites) return errc::busy;
        t_.writes[(t_.head + t_.queued) % MaxWrites] = queued_write{address, c, v};
        ++t_.queued;
        return {};
    }

    // --- master_session ----------------------------------------------------------------
    session_action next(time_point now) noexcept {
        session_action a = m_.next(now);
        if (a.what == session_action::kind::done) harvest(now); // the master is idle again
        if (a.what == session_action::kind::done || a.what == session_action::kind::idle) {
            const time_point wake = start_job(now);
            if (wake == never) return session_action::idle();
            if (before(now, wake)) return session_action::wait_until(wake);
            a = m_.next(now);
        }
        if (a.what == session_action::kind::send && m_.attempts() == 1) on_first_send(now);
        return a;
    }
    void on_receive(std::span<const std::uint8_t> in, time_point now) noexcept {
        m_.on_receive(in, now);
    }
    void on_transport_error(ferrule::error ec) noexcept { m_.on_transport_error(ec); }
    // Outcome of the last finished transaction.
    ferrule::error error() const noexcept { return t_.last.error; }

    // --- results -----------------------------------------------------------------------
    std::span<const poll_item> items() const noexcept { return {t_.items.data(), t_.count}; }
    const item_state& state(std::size_t i) const noexcept { return t_.states[i]; }
    std::span<const drive_state> drives() const noexcept {
        return {t_.drives.data(), t_.drive_count};
    }
    const drive_state* drive(std::uint8_t address) const noexcept {
        const std::size_t d = find_drive(address);
        return d == t_.drive_count ? nullptr : &t_.drives[d];
    }
    // Transactions finished so far; last_event() is the latest.
    std::uint32_t completed() const noexcept { return t_.completed; }
    const poll_event& last_event() const noexcept { return t_.last; }
    // Writes waiting, the one under way included.
    std::size_t queued_writes() const noexcept { return t_.queued; }
    std::uint32_t cycles() const noexcept { return t_.cycles; }
    duration last_cycle_time() const noexcept { return t_.cycle_time; }
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
        while (d < t_.drive_count && t_.drives[d].address != address) ++d;
        return d;
    }

    bool offline(std::size_t d) const noexcept {
        return offline_after_ != 0 && t_.drives[d].misses >= offline_after_;
    }

    time_point due_time(std::size_t i) const noexcept {
        const std::size_t d = t_.item_drive[i];
        return offline(d) ? latest(t_.probe_at[d], t_.due[i]) : t_.due[i];
    }

    // Starts the next transaction and returns `now`, or returns when the next item is due
    // (never: nothing to do).
    time_point start_job(time_point now) noexcept {
        // The live list takes the fault latch's place (offline_after): the failures of one
        // drive must not stop the polls of the others, so the master is never left latched.
        m_.reset_fault();
        t_.sent_at = now;
        if (t_.queued > 0) { // it leaves the queue when it has been sent
            const queued_write& w = t_.writes[t_.head];
            t_.running = job::write;
            (void)m_.start_write(w.address, w.code, w.v); // checked by write(); the master is idle
            return scheduled(now);
        }
        std::size_t best = t_.count;
        time_point best_due = never;
        for (std::size_t i = 0; i < t_.count; ++i) {
            const time_point t = due_time(i);
            if (best == t_.count || before(t, best_due)) {
                best = i;
                best_due = t;
            }
        }
        if (best == t_.count) return never;
        if (before(now, best_due)) return scheduled(best_due);
        t_.running = job::read;
        t_.current_item = best;
        (void)m_.start_read(t_.items[best].address, t_.items[best].code); // checked by add()
        return scheduled(now);
    }

    void on_first_send(time_point now) noexcept {
        t_.sent_at = now;
        if (t_.running != job::read || t_.current_item != 0) return;
        if (t_.cycle_started) {
            ++t_.cycles;
            t_.cycle_time = now - t_.cycle_start;
        }
        t_.cycle_start = now;
        t_.cycle_started = true;
    }

    // The transaction has finished: its event, the item's or the write's bookkeeping.
    void harvest(time_point now) noexcept {
        const ferrule::error ec = m_.error();
        const frame& request = m_.request();
        ++t_.completed;
        t_.last.error = ec;
        t_.last.address = request.address;
        t_.last.code = request.code;
        std::size_t d = 0;
        const value* v = &request.value; // a write: the value written
        if (t_.running == job::write) {
            t_.last.what = poll_event::kind::write;
            t_.last.item = 0;
            t_.head = (t_.head + 1) % MaxWrites;
            --t_.queued;
            d = find_drive(request.address);
        } else {
            const std::size_t i = t_.current_item;
            item_state& s = t_.states[i];
            t_.last.what = poll_event::kind::read;
            t_.last.item = i;
            ++s.reads;
            s.error = ec;
            s.valid = !ec;
            if (ec) {
                ++s.failures;
            } else {
                s.last = m_.reply().value;
                s.updated = now;
            }
            v = &s.last;
            t_.due[i] = t_.sent_at + t_.items[i].interval;
            d = t_.item_drive[i];
        }
        t_.last.value = *v;
        if (d < t_.drive_count) account(d, ec, t_.running == job::write);
        t_.running = job::none;
        m_.clear();
    }

    // Nothing came back from the drive (lecom.md §1.12: silence, or a telegram broken on
    // the line): the ferrule::errc values of such failures.
    static constexpr bool is_miss(int e) noexcept {
        constexpr unsigned misses =
            1u << static_cast<int>(errc::timeout) | 1u << static_cast<int>(errc::bad_checksum) |
            1u << static_cast<int>(errc::malformed) | 1u << static_cast<int>(errc::unexpected_type);
        return static_cast<unsigned>(e) < 32 && (misses >> e & 1u) != 0;
    }

    // Device errors are answers; transport errors are the host's port.
    void account(std::size_t d, ferrule::error ec, bool write) noexcept {
        drive_state& s = t_.drives[d];
        ++s.transactions;
        s.writes += write;
        if (!ec || ec.domain() == &device_domain) {
            s.seen = true;
            s.online = true;
            s.misses = 0;
        }
        if (!ec) return;
        ++s.failures;
        if (ec.domain() != &errc_domain) return;
        if (ec.value() == static_cast<int>(errc::timeout)) ++s.timeouts;
        if (!is_miss(ec.value())) return;
        ++s.misses;
        if (offline(d)) {
            s.online = false;
            t_.probe_at[d] = t_.sent_at + offline_interval_;
        }
    }

    // All but the error codes start zero, so that one memset sets up nearly all of it.
    struct tables {
        std::array<poll_item, MaxItems> items{};
        std::array<item_state, MaxItems> states{};
        std::array<time_point, MaxItems> due{};
        std::array<std::size_t, MaxItems> item_drive{};
        std::size_t count = 0;
        std::array<drive_state, MaxDrives> drives{};
        std::array<time_point, MaxDrives> probe_at{};
        std::size_t drive_count = 0;
        std::array<queued_write, MaxWrites> writes{};
        std::size_t head = 0;
        std::size_t queued = 0;
        job running = job::none;
        std::size_t current_item = 0;
        time_point sent_at{}; // start of the running transaction's first request on the wire
        poll_event last{};
        std::uint32_t completed = 0;
        std::uint32_t cycles = 0;
        duration cycle_time{};
        time_point cycle_start{};
        bool cycle_started = false;
    };

    master m_;
    unsigned offline_after_;
    duration offline_interval_;
    tables t_{};
};

static_assert(master_session<poller<>>);

} // namespace ferrule::lecom
