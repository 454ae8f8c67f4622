// Mapped mode of the PROFIBUS-DP ↔ Modbus RTU gateway: the transaction list ("scan list") and
// its scheduler. Sans-I/O: the gateway core asks next() for the Modbus request to run, runs
// it on its modbus::basic_client, and reports the outcome with done(); the scan list copies
// read registers into the DP input image and takes write data from the DP output image.
//
// Every commercial gateway has this list (modbus_profibus.md §E, "Transaction / command
// list"): per entry a unit, a function code, a Modbus address and count, a DP offset, a
// byte/word swap and an update mode. Ours takes FC 3, 4, 6, 16 and 23 (§E, v1 "Mapping").
//
// Update modes (§E "Update modes", Anybus Communicator):
//   cyclic     due `interval` after its last start (an entry never started is due at once);
//              interval 0 runs it as often as the bus allows, in turn with the others
//   on_change  due while its DP output bytes differ from those last written successfully,
//              or nothing was written yet; a failed write is due again. An entry that only
//              reads (FC 3/4) has no output bytes: it runs until it first succeeds (a single
//              shot at start-up)
//   trigger    due when the DP output byte at trigger_offset differs from its value when
//              the entry last started (the PLC increments it to ask for one run); its value
//              at the first next() whose outputs hold it counts as seen. A failed run waits
//              for the next change
//
// Scheduling: next() looks at the entries round the list, starting after the one it last
// started, and starts the first that is due, so one entry that is always due (interval 0,
// or an on_change write that keeps failing) takes one turn in n and starves no one.
//
// Offline and reconnect (§E "Timeout / retries / reconnect": MGate retries, then the node is
// offline; Anybus "reconnect time"): timeouts and retries belong to the client, so one
// failed transaction here is one that failed after its retries. `offline_after` of them in
// a row for one unit (counting all its entries) take it offline; its entries are then
// skipped until `reconnect_time` after it went offline, when the first of them that is due
// runs as a probe; while the probe is out, and for reconnect_time after it started, the
// others are skipped again. Any answer (also an exception response) brings it back online.
// offline_after = 0: units never go offline.
//
// Live list and status word (§E "Control / status word", "Live list"): online() is true for
// a unit that has answered and is not offline since (a unit not heard from yet is neither
// online nor counted offline); offline_count() / first_offline() give the Anybus status codes
// "single node missing (data = address)" and "multiple nodes missing (data = count)";
// all_succeeded_once() is Anybus's "Data Valid" ("all transactions executed successfully at
// least once").
//
// Byte order: Modbus sends each register big-endian (high byte first). `swap` maps register
// bytes to DP bytes, the same way in both directions (§E: MGate None/Byte/Word/ByteWord).
// For registers 0x1234 0x5678:
//   none             12 34 56 78
//   bytes            34 12 78 56   (the two bytes of each register swapped)
//   words            56 78 12 34   (registers swapped in pairs: 32-bit values low word first;
//                                   an odd count leaves its last register in place)
//   bytes_and_words  78 56 34 12
//
// One transaction runs at a time: call next() whenever the client is free (after each
// done(), when the outputs change, and at wake_at()), and done() when its transaction ended. The
// list is the caller's; call validate() with the DP image sizes before scheduling: next() and
// done() only guard against touching bytes outside the spans given. Memory: about 9 KB, most of it
// the bytes each entry last wrote (32 × 246).
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "ferrule/core/bytes.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/error.hpp"
#include "ferrule/modbus/pdu.hpp"

namespace ferrule::gateway {

// How register bytes map to DP bytes (see above).
enum class swap : std::uint8_t { none, bytes, words, bytes_and_words };
enum class update : std::uint8_t { cyclic, on_change, trigger };

struct transaction {
    std::uint8_t unit = 1;                                                // Modbus unit 1…247
    modbus::function function = modbus::function::read_holding_registers; // 3, 4, 6, 16, 23
    std::uint16_t address = 0;       // FC 3/4/6/16; FC 23: the read address
    std::uint16_t count = 1;         // registers; FC 6: 1; FC 23: the read count
    std::uint16_t write_address = 0; // FC 23 only
    std::uint16_t write_count = 0;   // FC 23 only
    std::uint16_t input_offset = 0;  // DP input byte where read registers go (FC 3, 4, 23)
    std::uint16_t output_offset = 0; // DP output byte where written registers come from (6, 16, 23)
    gateway::swap swap = swap::none;
    gateway::update update = update::cyclic;
    duration interval = std::chrono::milliseconds(100); // cyclic: at most this often
    std::uint16_t trigger_offset = 0; // trigger: the DP output byte whose change starts it
};

struct node_policy {
    unsigned offline_after = 3; // consecutive failed transactions → unit offline; 0: never
    duration reconnect_time = std::chrono::seconds(1); // an offline unit is tried again after this
};

namespace detail {
constexpr bool reads(modbus::function f) noexcept {
    return f == modbus::function::read_holding_registers ||
           f == modbus::function::read_input_registers ||
           f == modbus::function::read_write_multiple_registers;
}
// Register bytes read by the entry (FC 3, 4, 23), 0 for the others.
constexpr std::size_t read_bytes(const transaction& t) noexcept {
    return reads(t.function) ? 2u * t.count : 0u;
}
// Register bytes written by the entry (FC 6, 16, 23), 0 for the others.
constexpr std::size_t write_bytes(const transaction& t) noexcept {
    switch (t.function) {
    case modbus::function::write_single_register: return 2;
    case modbus::function::write_multiple_registers: return 2u * t.count;
    case modbus::function::read_write_multiple_registers: return 2u * t.write_count;
    default: return 0;
    }
}
// Copies whole registers from `from` to `to` (same size) in the order of `s`; its own
// inverse, so it serves both directions.
constexpr void copy_swapped(swap s, std::span<const std::uint8_t> from,
                            std::span<std::uint8_t> to) noexcept {
    const std::size_t regs = from.size() / 2;
    const bool words = s == swap::words || s == swap::bytes_and_words;
    const bool bytes = s == swap::bytes || s == swap::bytes_and_words;
    for (std::size_t r = 0; r < regs; ++r) {
        const std::size_t partner = r ^ 1u;
        const std::size_t src = words && partner < regs ? partner : r;
        to[2 * r] = from[2 * src + (bytes ? 1 : 0)];
        to[2 * r + 1] = from[2 * src + (bytes ? 0 : 1)];
    }
}
constexpr bool quantity_ok(std::uint16_t address, std::uint16_t count, std::uint16_t max) noexcept {
    return count >= 1 && count <= max && std::uint32_t{address} + count <= 0x10000u;
}
} // namespace detail

class scan_list {
public:
    static constexpr std::size_t max_transactions = 32;
    // Write data of one request: FC 16's 123 registers are the most.
    static constexpr std::size_t max_write_bytes = 2u * modbus::max_write_registers;

    struct job {
        std::size_t index; // of the entry, for done()
        std::uint8_t unit;
        modbus::request request;
    };

    // Keeps the span: the list lives in the caller's storage.
    explicit scan_list(std::span<const transaction> list, node_policy p = {}) noexcept
        : list_(list), policy_(p) {
        if (list_.size() > max_transactions) return;
        for (std::size_t i = 0; i < list_.size(); ++i) {
            const std::uint8_t u = list_[i].unit;
            std::size_t s = 0;
            while (s < units_ && unit_address_[s] != u) ++s;
            if (s == units_) unit_address_[units_++] = u;
            unit_of_[i] = static_cast<std::uint8_t>(s);
        }
        if (!list_.empty()) cursor_ = list_.size() - 1;
    }

    // errc::invalid_argument when an entry has a function other than 3, 4, 6, 16, 23, a
    // count beyond the Modbus limits (FC 3/4: 1…125, FC 6: 1, FC 16: 1…123, FC 23: read
    // 1…125, write 1…121; AP §6) or address + count beyond 65536, unit 0 or > 247, an
    // unknown swap or update mode, DP bytes (registers or trigger byte) outside
    // input_size / output_size, or when the list has more than max_transactions entries.
    ferrule::error validate(std::size_t input_size, std::size_t output_size) const noexcept {
        using modbus::function;
        if (list_.size() > max_transactions) return errc::invalid_argument;
        for (const transaction& t : list_) {
            bool ok = t.unit >= 1 && t.unit <= modbus::max_unit_address &&
                      t.swap <= swap::bytes_and_words && t.update <= update::trigger;
            switch (t.function) {
            case function::read_holding_registers:
            case function::read_input_registers:
                ok = ok && detail::quantity_ok(t.address, t.count, modbus::max_read_registers);
                break;
            case function::write_single_register: ok = ok && t.count == 1; break;
            case function::write_multiple_registers:
                ok = ok && detail::quantity_ok(t.address, t.count, modbus::max_write_registers);
                break;
            case function::read_write_multiple_registers:
                ok = ok && detail::quantity_ok(t.address, t.count, modbus::max_read_registers) &&
                     detail::quantity_ok(t.write_address, t.write_count,
                                         modbus::max_rw_write_registers);
                break;
            default: ok = false;
            }
            ok = ok && std::size_t{t.input_offset} + detail::read_bytes(t) <= input_size &&
                 std::size_t{t.output_offset} + detail::write_bytes(t) <= output_size &&
                 (t.update != update::trigger || t.trigger_offset < output_size);
            if (!ok) return errc::invalid_argument;
        }
        return {};
    }

    // The next entry due at `now` with these DP outputs, round the list from the one after
    // the last started; nullopt when none is. Write data is taken from `outputs` into the
    // scan list's buffer in Modbus order; request.data spans it until the next call.
    std::optional<job> next(std::span<const std::uint8_t> outputs, time_point now) noexcept {
        const std::size_t n = list_.size();
        if (n == 0 || n > max_transactions) return std::nullopt;
        last_now_ = now;
        // A trigger byte as the PLC has it when first seen counts as seen.
        for (std::size_t i = 0; i < n; ++i) {
            const transaction& t = list_[i];
            if (t.update == update::trigger && !has(trigger_primed_, i) &&
                t.trigger_offset < outputs.size()) {
                trigger_seen_[i] = outputs[t.trigger_offset];
                set(trigger_primed_, i, true);
            }
        }
        for (std::size_t k = 1; k <= n; ++k) {
            const std::size_t i = (cursor_ + k) % n;
            const std::size_t u = unit_of_[i];
            const bool offline = has(offline_, u);
            if (offline && within(now, unit_since_[u], policy_.reconnect_time)) continue;
            if (!due(i, outputs, now)) continue;
            if (offline) unit_since_[u] = now; // this one is the probe
            cursor_ = i;
            return start(i, outputs, now);
        }
        return std::nullopt;
    }

    // When next() may have something new to say with the same outputs: the earliest time a
    // cyclic entry falls due (time_point::min() for one never started), or a reconnect time
    // of an offline unit still ahead of the last next(); `never` when there is none.
    time_point wake_at() const noexcept {
        const std::size_t n = list_.size();
        if (n > max_transactions) return never;
        time_point at = never;
        for (std::size_t i = 0; i < n; ++i) {
            const std::size_t u = unit_of_[i];
            const bool offline = has(offline_, u);
            const time_point reconnect = unit_since_[u] + policy_.reconnect_time;
            time_point t = never;
            if (list_[i].update == update::cyclic) {
                t = has(started_, i) ? last_start_[i] + list_[i].interval : time_point::min();
                if (offline && before(t, reconnect)) t = reconnect;
            } else if (offline && before(last_now_, reconnect)) {
                t = reconnect;
            }
            at = earliest(at, t == never ? t : scheduled(t));
        }
        return at;
    }

    // The transaction of entry `index` ended at `now`. No error: read registers (r.data,
    // Modbus order) go swapped into `inputs` at input_offset, a write's bytes count as
    // written (on_change), the unit is online. Read data of another size than asked
    // (errc::malformed) or beyond `inputs` (errc::buffer_too_small) fails the entry, though
    // the unit answered. An exception response (modbus::device_domain) shows the unit
    // is there: it is online, the entry failed. Any other error counts towards the unit's
    // offline_after.
    void done(std::size_t index, ferrule::error ec, const modbus::response& r,
              std::span<std::uint8_t> inputs, time_point now) noexcept {
        if (index >= list_.size() || list_.size() > max_transactions) return;
        const transaction& t = list_[index];
        const std::size_t u = unit_of_[index];
        const bool answered = !ec || ec.domain() == &modbus::device_domain;
        if (!ec && detail::reads(t.function)) {
            const std::size_t bytes = detail::read_bytes(t);
            if (r.data.size() != bytes)
                ec = errc::malformed;
            else if (std::size_t{t.input_offset} + bytes > inputs.size())
                ec = errc::buffer_too_small;
            else
                detail::copy_swapped(t.swap, r.data, inputs.subspan(t.input_offset, bytes));
        }
        errors_[index] = ec;
        if (!answered) {
            if (unit_failures_[u] < policy_.offline_after &&
                ++unit_failures_[u] == policy_.offline_after && !has(offline_, u)) {
                set(offline_, u, true);
                unit_since_[u] = now;
            }
            return;
        }
        unit_failures_[u] = 0;
        set(offline_, u, false);
        set(answered_, u, true);
        if (ec) return;
        set(succeeded_, index, true);
        set(written_, index, true);
    }

    // Answered and not offline since; false for a unit not in the list.
    bool online(std::uint8_t unit) const noexcept {
        for (std::size_t s = 0; s < units_; ++s)
            if (unit_address_[s] == unit) return has(answered_, s) && !has(offline_, s);
        return false;
    }

    // Every entry has succeeded at least once: Anybus "Data Valid" (§E); true for an empty
    // list.
    bool all_succeeded_once() const noexcept {
        const std::size_t n = list_.size();
        if (n > max_transactions) return false;
        const std::uint32_t all =
            n == max_transactions ? ~std::uint32_t{0} : (std::uint32_t{1} << n) - 1u;
        return (succeeded_ & all) == all;
    }

    // The outcome of the entry's last transaction ({} before it ran, or when it succeeded);
    // errc::invalid_argument for an index beyond the list.
    ferrule::error last_error(std::size_t index) const noexcept {
        if (index >= list_.size() || index >= max_transactions) return errc::invalid_argument;
        return errors_[index];
    }

    std::size_t size() const noexcept { return list_.size(); }

    // Units of the list that are offline: how many, and the lowest address (0 when none).
    std::size_t offline_count() const noexcept {
        std::size_t c = 0;
        for (std::size_t s = 0; s < units_; ++s) c += has(offline_, s) ? 1u : 0u;
        return c;
    }
    std::uint8_t first_offline() const noexcept {
        std::uint8_t first = 0;
        for (std::size_t s = 0; s < units_; ++s)
            if (has(offline_, s) && (first == 0 || unit_address_[s] < first))
                first = unit_address_[s];
        return first;
    }

private:
    static bool has(std::uint32_t mask, std::size_t bit) noexcept {
        return (mask >> bit & 1u) != 0;
    }
    static void set(std::uint32_t& mask, std::size_t bit, bool on) noexcept {
        const std::uint32_t b = std::uint32_t{1} << bit;
        mask = on ? mask | b : mask & ~b;
    }

    bool due(std::size_t i, std::span<const std::uint8_t> outputs, time_point now) const noexcept {
        const transaction& t = list_[i];
        const std::size_t wb = detail::write_bytes(t);
        if (std::size_t{t.output_offset} + wb > outputs.size()) return false;
        switch (t.update) {
        case update::cyclic: return !has(started_, i) || !within(now, last_start_[i], t.interval);
        case update::on_change:
            return !has(written_, i) ||
                   !std::equal(outputs.begin() + t.output_offset,
                               outputs.begin() + t.output_offset + wb, written_bytes_[i].begin());
        case update::trigger:
            return t.trigger_offset < outputs.size() &&
                   outputs[t.trigger_offset] != trigger_seen_[i];
        }
        return false;
    }

    job start(std::size_t i, std::span<const std::uint8_t> outputs, time_point now) noexcept {
        const transaction& t = list_[i];
        set(started_, i, true);
        last_start_[i] = now;
        if (t.update == update::trigger) trigger_seen_[i] = outputs[t.trigger_offset];
        modbus::request r;
        r.function = t.function;
        r.address = t.address;
        r.quantity = t.count;
        if (const std::size_t wb = detail::write_bytes(t); wb != 0) {
            // Kept as sent, so done() knows what was written; written again until it succeeds.
            const auto from = outputs.subspan(t.output_offset, wb);
            std::copy(from.begin(), from.end(), written_bytes_[i].begin());
            set(written_, i, false);
            detail::copy_swapped(t.swap, from, std::span(data_).first(wb));
            r.data = std::span<const std::uint8_t>(data_).first(wb);
            if (t.function == modbus::function::write_single_register) {
                r.value = load_be16(data_.data());
                r.quantity = 0;
            }
            if (t.function == modbus::function::read_write_multiple_registers) {
                r.write_address = t.write_address;
                r.write_quantity = t.write_count;
            }
        }
        return job{i, t.unit, r};
    }

    std::span<const transaction> list_;
    node_policy policy_;
    std::size_t cursor_ = 0; // the entry last started
    time_point last_now_ = time_point::min();

    // Per entry.
    std::array<std::uint8_t, max_transactions> unit_of_{}; // slot of its unit
    std::array<time_point, max_transactions> last_start_{};
    std::array<ferrule::error, max_transactions> errors_{};
    std::array<std::uint8_t, max_transactions> trigger_seen_{};
    std::array<std::array<std::uint8_t, max_write_bytes>, max_transactions> written_bytes_{};
    std::uint32_t started_ = 0;
    std::uint32_t succeeded_ = 0;      // at least once
    std::uint32_t trigger_primed_ = 0; // trigger_seen_ taken from the outputs
    std::uint32_t written_ = 0;        // succeeded since it last took written_bytes_

    // Per unit of the list, in order of first appearance.
    std::size_t units_ = 0;
    std::array<std::uint8_t, max_transactions> unit_address_{};
    std::array<unsigned, max_transactions> unit_failures_{}; // in a row, up to offline_after
    std::array<time_point, max_transactions> unit_since_{};  // went offline or last probed
    std::uint32_t offline_ = 0;
    std::uint32_t answered_ = 0;

    std::array<std::uint8_t, max_write_bytes> data_{}; // write data of the last job
};

} // namespace ferrule::gateway
