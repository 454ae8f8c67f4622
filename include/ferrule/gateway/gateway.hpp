// gateway::core: the PROFIBUS-DP ↔ Modbus RTU gateway, sans-I/O: a DP-V0 slave on one line, a
// Modbus RTU client on the other (seeds/002, protocols/modbus_profibus.md §E). Firmware with two
// UARTs and the host app share it; each line gets its own driver:
//
//   DP line      on_dp_receive(bytes, end), next_dp(now), dp_wake_at()
//   Modbus line  on_modbus_receive(bytes, now), on_modbus_error(ec), next_modbus(now)
//
// Transparent mode (the paper's): the DP outputs carry a Modbus request PDU, e.g.
// 06 C8 00 00 25; the gateway adds the drive's address and the CRC and sends
// 01 06 C8 00 00 25 76 71; the drive's reply PDU comes back in the DP inputs. A command is
// new when the outputs change (all zero: no command). The paper's reliability scheme: the
// DP side (up to 12 Mbit/s) outruns the drive (2400…19200 baud), so commands wait in
// `command_buffers` buffers (2: the paper's double buffer with empty flags); a command that
// finds them all full is not taken and is counted and reported as overflow: in the status
// word, in extended diagnosis, and by DH so that the master fetches it. Replies wait the same
// way until a Data_Exchange has carried them to the master. Nothing is overwritten silently:
//     commands = delivered + failed + discarded + waiting,   and overflowed besides.
//
// Mapped mode (commercial gateways, §E): a transaction list (scan_list.hpp) moves registers
// between drives and fixed places of the DP images.
//
// Both: an optional status word in the first two input bytes (Anybus layout, §E): bit 13
// data valid, bits 12…8 a code — 0x1F no error, 0x01 one drive missing (bits 7…0 its unit),
// 0x02 several missing (their number), 0x03 buffer overflow (the overflow count, low byte),
// 0x04 exception from a drive (its code). Extended diagnosis: one device-related block
// (§B.7) of 8 bytes — header, flags (bit 0 command overflow, 1 reply overflow, 2 drive
// missing, 3 exception, 4 invalid command), overflow count (big-endian), live list of units
// 1…32 (bit n-1 of the 32-bit big-endian field: unit n answers). Ext_Diag is set while a
// drive is missing or an overflow is latched: an overflow stays reported until the master
// has read a diagnosis that shows it (the count goes on, whatever the flags).
//
// When DP is lost (watchdog, Unlock, new parameters, Clear_Data) waiting commands are
// discarded and, with dp_loss = clear, the safe writes (FC 6, e.g. a stop word) go out once;
// freeze leaves the drives as they are. A drive that stops answering is offline: its inputs
// are zeroed (drive_loss = clear) or kept (freeze).
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/gateway/scan_list.hpp"
#include "ferrule/modbus/client.hpp"
#include "ferrule/modbus/error.hpp"
#include "ferrule/modbus/pdu.hpp"
#include "ferrule/profibus/slave.hpp"

namespace ferrule::gateway {

enum class mode : std::uint8_t { transparent, mapped };
enum class dp_loss : std::uint8_t { freeze, clear };
enum class drive_loss : std::uint8_t { freeze, clear };

struct safe_write {
    std::uint8_t unit = 1;
    std::uint16_t address = 0;
    std::uint16_t value = 0;
};

struct config {
    profibus::slave_config dp{};
    modbus::client_config modbus{};
    gateway::mode mode = mode::transparent;
    std::uint8_t drive = 1;                      // transparent: the drive's unit
    std::size_t command_buffers = 2;             // transparent: 1…max_buffers
    bool status_word = false;                    // the first two input bytes
    std::span<const transaction> transactions{}; // mapped; must outlive the gateway
    node_policy nodes{};                         // mapped
    gateway::dp_loss on_dp_loss = dp_loss::clear;
    std::span<const safe_write> safe_writes{}; // must outlive the gateway
    gateway::drive_loss on_drive_loss = drive_loss::clear;
};

struct stats {
    std::uint32_t commands = 0;        // transparent: new commands taken from the DP outputs
    std::uint32_t delivered = 0;       // sent and answered (exception responses included)
    std::uint32_t failed = 0;          // sent, not answered after the retries
    std::uint32_t overflowed = 0;      // found every buffer full: not taken
    std::uint32_t discarded = 0;       // waiting when DP was lost: not sent
    std::uint32_t invalid = 0;         // outputs that hold no Modbus request
    std::uint32_t replies = 0;         // replies a Data_Exchange carried to the master
    std::uint32_t reply_overflows = 0; // replies with no free buffer or too long for the inputs
    std::uint32_t exceptions = 0;      // exception responses from drives
    std::uint32_t safe_writes = 0;     // sent after a DP loss
    std::uint32_t transactions = 0;    // mapped: Modbus transactions ended
    std::uint32_t dp_losses = 0;
};

namespace status {
inline constexpr std::uint16_t data_valid = 0x2000;
inline constexpr std::uint8_t no_error = 0x1F;
inline constexpr std::uint8_t node_missing = 0x01;
inline constexpr std::uint8_t nodes_missing = 0x02;
inline constexpr std::uint8_t buffer_overflow = 0x03;
inline constexpr std::uint8_t other_error = 0x04;
} // namespace status

namespace diag_flags {
inline constexpr std::uint8_t command_overflow = 0x01;
inline constexpr std::uint8_t reply_overflow = 0x02;
inline constexpr std::uint8_t drive_missing = 0x04;
inline constexpr std::uint8_t exception = 0x08;
inline constexpr std::uint8_t invalid_command = 0x10;
} // namespace diag_flags
inline constexpr std::size_t diag_block_size = 8;

class core {
public:
    static constexpr std::size_t max_buffers = 4;
    using client_type = modbus::basic_client<modbus::link_mode::rtu>;

    explicit core(const config& c) noexcept
        : cfg_(c), dp_(c.dp), mb_(rtu(c.modbus)), list_(c.transactions, c.nodes),
          buffers_(std::clamp<std::size_t>(c.command_buffers, 1, max_buffers)) {
        refresh();
    }

    // --- DP line --------------------------------------------------------------------------
    void on_dp_receive(std::span<const std::uint8_t> bytes, time_point end) noexcept {
        const std::uint32_t exchanges = dp_.stats().data_exchanges;
        dp_.on_receive(bytes, end);
        watch_dp();
        if (dp_.stats().diag_reads != overflow_reads_ && (overflow_ || reply_overflow_)) {
            // The master has read the overflow: the latch opens.
            overflow_ = reply_overflow_ = false;
            refresh();
        }
        if (dp_.stats().data_exchanges == exchanges) return;
        // The reply just queued carries the inputs shown: that reply is delivered.
        if (shown_) {
            shown_ = false;
            ++stats_.replies;
            if (replies_.size() > 0)
                show(replies_.pop());
            else if (clear_when_shown_)
                clear_reply_area();
        }
        if (cfg_.mode == mode::transparent) take_command();
        refresh();
    }

    session_action next_dp(time_point now) noexcept {
        const session_action a = dp_.next(now);
        watch_dp();
        return a;
    }
    time_point dp_wake_at() const noexcept { return dp_.wake_at(); }

    // --- Modbus line ----------------------------------------------------------------------
    void on_modbus_receive(std::span<const std::uint8_t> bytes, time_point now) noexcept {
        mb_.on_receive(bytes, now);
    }
    void on_modbus_error(ferrule::error ec) noexcept { mb_.on_transport_error(ec); }

    session_action next_modbus(time_point now) noexcept {
        for (;;) {
            if (mb_.busy() || in_flight_ != flight::none) {
                const session_action a = mb_.next(now);
                if (a.what != session_action::kind::done) return a;
                finish(now);
                continue;
            }
            if (!start_next(now)) {
                // Mapped: the next cyclic transaction or reconnect; new outputs or a DP loss
                // come with the DP line's events.
                const time_point t =
                    cfg_.mode == mode::mapped && dp_active_ ? list_.wake_at() : never;
                return t == never || !before(now, t) ? session_action::idle()
                                                     : session_action::wait_until(t);
            }
        }
    }

    const profibus::slave& dp() const noexcept { return dp_; }
    const client_type& modbus() const noexcept { return mb_; }
    const scan_list& transactions() const noexcept { return list_; }
    const gateway::stats& stats() const noexcept { return stats_; }
    std::size_t waiting_commands() const noexcept { return commands_.size(); }
    std::span<const std::uint8_t> inputs() const noexcept { return dp_.inputs(); }
    std::uint16_t status_word() const noexcept { return status_; }
    bool online(std::uint8_t unit) const noexcept {
        return cfg_.mode == mode::mapped ? list_.online(unit) : unit == cfg_.drive && drive_ok_;
    }

private:
    // A fixed ring of PDUs (commands or replies).
    struct pdu_ring {
        struct slot {
            std::array<std::uint8_t, modbus::max_pdu> bytes{};
            std::size_t size = 0;
            std::span<const std::uint8_t> view() const noexcept { return {bytes.data(), size}; }
        };
        std::array<slot, max_buffers> slots{};
        std::size_t head = 0;
        std::size_t count = 0;

        std::size_t size() const noexcept { return count; }
        bool push(std::span<const std::uint8_t> pdu, std::size_t capacity) noexcept {
            if (count >= capacity || pdu.size() > modbus::max_pdu) return false;
            slot& s = slots[(head + count) % max_buffers];
            std::copy(pdu.begin(), pdu.end(), s.bytes.begin());
            s.size = pdu.size();
            ++count;
            return true;
        }
        const slot& front() const noexcept { return slots[head]; }
        slot pop() noexcept {
            const slot s = slots[head];
            head = (head + 1) % max_buffers;
            --count;
            return s;
        }
        void truncate(std::size_t n) noexcept { count = std::min(count, n); }
    };

    static modbus::client_config rtu(modbus::client_config c) noexcept {
        c.rtu = true;
        return c;
    }

    // DP is active in Data_Exchange without Clear_Data; leaving it is a DP loss.
    void watch_dp() noexcept {
        const bool active =
            dp_.state() == profibus::slave_state::data_exchange && !dp_.clear_data();
        if (active == dp_active_) return;
        dp_active_ = active;
        if (active) return;
        ++stats_.dp_losses;
        // The command on the wire finishes; the others are not sent.
        const std::size_t keep = in_flight_ == flight::command ? 1 : 0;
        stats_.discarded += static_cast<std::uint32_t>(commands_.size() - keep);
        commands_.truncate(keep);
        last_taken_.fill(0);
        if (cfg_.on_dp_loss == dp_loss::clear) safe_pending_ = cfg_.safe_writes.size();
        refresh();
    }

    // Transparent: the outputs are a request PDU; a change is a new command.
    void take_command() noexcept {
        const auto out = dp_.outputs();
        if (std::equal(out.begin(), out.end(), last_taken_.begin())) return;
        std::copy(out.begin(), out.end(), last_taken_.begin());
        if (std::all_of(out.begin(), out.end(), [](std::uint8_t b) { return b == 0; })) return;
        const std::size_t n = modbus::expected_request_length(out);
        if (n == 0 || n == modbus::no_frame || n > out.size() ||
            !modbus::parse_request(out.first(n))) {
            ++stats_.invalid;
            invalid_ = true;
            return;
        }
        invalid_ = false;
        if (!commands_.push(out.first(n), buffers_)) {
            ++stats_.overflowed;
            latch_overflow(overflow_);
            return;
        }
        ++stats_.commands;
    }

    void latch_overflow(bool& flag) noexcept {
        flag = true;
        overflow_reads_ = dp_.stats().diag_reads;
    }

    bool start_next(time_point now) noexcept {
        if (safe_pending_ > 0) {
            const safe_write& w = cfg_.safe_writes[cfg_.safe_writes.size() - safe_pending_];
            --safe_pending_;
            modbus::request r;
            r.function = modbus::function::write_single_register;
            r.address = w.address;
            r.value = w.value;
            if (mb_.start(w.unit, r)) return true; // refused: try the next one
            ++stats_.safe_writes;
            in_flight_ = flight::safe;
            return true;
        }
        if (!dp_active_) return false;
        if (cfg_.mode == mode::transparent) {
            if (commands_.size() == 0) return false;
            const auto req = modbus::parse_request(commands_.front().view());
            if (!req || mb_.start(cfg_.drive, *req)) {
                commands_.pop();
                ++stats_.failed;
                return true;
            }
            in_flight_ = flight::command;
            return true;
        }
        const auto job = list_.next(dp_.outputs(), now);
        if (!job) return false;
        if (mb_.start(job->unit, job->request)) {
            list_.done(job->index, errc::invalid_argument, {}, image(), now);
            return true;
        }
        job_ = job->index;
        in_flight_ = flight::job;
        return true;
    }

    void finish(time_point now) noexcept {
        const ferrule::error ec = mb_.error();
        const bool answered = !ec || ec.domain() == &modbus::device_domain;
        if (ec.domain() == &modbus::device_domain) {
            ++stats_.exceptions;
            last_exception_ = static_cast<std::uint8_t>(ec.value());
        }
        switch (in_flight_) {
        case flight::command:
            commands_.pop();
            ++(answered ? stats_.delivered : stats_.failed);
            drive_ok_ = answered;
            if (answered) {
                reply(mb_.response_pdu());
            } else if (cfg_.on_drive_loss == drive_loss::clear) {
                // Replies from before the loss still reach the master first.
                clear_when_shown_ = true;
                if (!shown_) clear_reply_area();
            }
            break;
        case flight::job:
            ++stats_.transactions;
            list_.done(job_, ec, mb_.reply(), image(), now);
            if (!list_.online(mb_.unit()) && cfg_.on_drive_loss == drive_loss::clear)
                clear_inputs_of(mb_.unit());
            break;
        case flight::safe:
        case flight::none: break;
        }
        in_flight_ = flight::none;
        mb_.clear();
        refresh();
    }

    // A reply PDU for the DP master: shown at once when the inputs are free, else waits.
    void reply(std::span<const std::uint8_t> pdu) noexcept {
        clear_when_shown_ = false;
        if (pdu.size() > image().size() - pdu_offset() ||
            (shown_ && !replies_.push(pdu, buffers_))) {
            ++stats_.reply_overflows;
            latch_overflow(reply_overflow_);
            return;
        }
        if (!shown_) {
            typename pdu_ring::slot s;
            std::copy(pdu.begin(), pdu.end(), s.bytes.begin());
            s.size = pdu.size();
            show(s);
        }
    }

    void show(const typename pdu_ring::slot& s) noexcept {
        const auto in = image().subspan(pdu_offset());
        std::fill(in.begin(), in.end(), std::uint8_t{0});
        std::copy_n(s.bytes.begin(), std::min(s.size, in.size()), in.begin());
        shown_ = true;
    }

    void clear_reply_area() noexcept {
        const auto in = image().subspan(pdu_offset());
        std::fill(in.begin(), in.end(), std::uint8_t{0});
        clear_when_shown_ = false;
    }

    // The input image: as many bytes as the configuration has inputs.
    std::span<std::uint8_t> image() noexcept { return {image_.data(), dp_.input_size()}; }

    std::size_t pdu_offset() const noexcept {
        return std::min<std::size_t>(cfg_.status_word ? 2 : 0, dp_.input_size());
    }

    void clear_inputs_of(std::uint8_t unit) noexcept {
        for (const transaction& t : cfg_.transactions) {
            if (t.unit != unit) continue;
            const bool reads = t.function == modbus::function::read_holding_registers ||
                               t.function == modbus::function::read_input_registers ||
                               t.function == modbus::function::read_write_multiple_registers;
            if (!reads) continue;
            const auto in = image();
            const std::size_t end = std::min<std::size_t>(t.input_offset + 2u * t.count, in.size());
            if (t.input_offset < end)
                std::fill(in.begin() + t.input_offset, in.begin() + static_cast<long>(end),
                          std::uint8_t{0});
        }
    }

    std::uint32_t live_list() const noexcept {
        std::uint32_t bits = 0;
        for (std::uint8_t unit = 1; unit <= 32; ++unit)
            if (online(unit)) bits |= std::uint32_t{1} << (unit - 1);
        return bits;
    }

    std::size_t missing(std::uint8_t& first) const noexcept {
        first = 0;
        if (cfg_.mode == mode::transparent) {
            if (drive_ok_) return 0;
            first = cfg_.drive;
            return 1;
        }
        first = list_.first_offline();
        return list_.offline_count();
    }

    // Status word, extended diagnosis and the input image the slave answers with.
    void refresh() noexcept {
        std::uint8_t first = 0;
        const std::size_t lost = missing(first);
        const bool overflow = overflow_ || reply_overflow_;
        std::uint8_t code = status::no_error;
        std::uint8_t data = 0;
        if (overflow) {
            code = status::buffer_overflow;
            data = static_cast<std::uint8_t>(stats_.overflowed + stats_.reply_overflows);
        } else if (lost == 1) {
            code = status::node_missing;
            data = first;
        } else if (lost > 1) {
            code = status::nodes_missing;
            data = static_cast<std::uint8_t>(lost);
        } else if (last_exception_ != 0) {
            code = status::other_error;
            data = last_exception_;
        }
        const bool valid = cfg_.mode == mode::mapped ? list_.all_succeeded_once()
                                                     : stats_.delivered > 0 && drive_ok_;
        status_ = static_cast<std::uint16_t>((valid ? status::data_valid : 0) | code << 8 | data);
        if (cfg_.status_word && dp_.input_size() >= 2) {
            image_[0] = static_cast<std::uint8_t>(status_ >> 8);
            image_[1] = static_cast<std::uint8_t>(status_);
        }
        dp_.set_inputs(image());

        const std::uint8_t flags =
            static_cast<std::uint8_t>((overflow_ ? diag_flags::command_overflow : 0) |
                                      (reply_overflow_ ? diag_flags::reply_overflow : 0) |
                                      (lost > 0 ? diag_flags::drive_missing : 0) |
                                      (last_exception_ != 0 ? diag_flags::exception : 0) |
                                      (invalid_ ? diag_flags::invalid_command : 0));
        const std::uint32_t overflows = stats_.overflowed + stats_.reply_overflows;
        const std::uint32_t live = live_list();
        const std::array<std::uint8_t, diag_block_size> block{
            static_cast<std::uint8_t>(profibus::diag::block_device | diag_block_size),
            flags,
            static_cast<std::uint8_t>(overflows >> 8),
            static_cast<std::uint8_t>(overflows),
            static_cast<std::uint8_t>(live >> 24),
            static_cast<std::uint8_t>(live >> 16),
            static_cast<std::uint8_t>(live >> 8),
            static_cast<std::uint8_t>(live)};
        dp_.set_ext_diag(block, overflow || lost > 0);
    }

    enum class flight : std::uint8_t { none, command, job, safe };

    config cfg_;
    profibus::slave dp_;
    client_type mb_;
    scan_list list_;
    std::size_t buffers_;
    pdu_ring commands_{};
    pdu_ring replies_{};
    std::array<std::uint8_t, profibus::slave::max_io> last_taken_{};
    std::array<std::uint8_t, profibus::slave::max_io> image_{};
    gateway::stats stats_{};
    std::size_t safe_pending_ = 0;
    std::size_t job_ = 0;
    flight in_flight_ = flight::none;
    std::uint16_t status_ = 0;
    std::uint8_t last_exception_ = 0;
    bool dp_active_ = false;
    bool shown_ = false;               // the inputs show a reply no Data_Exchange has carried yet
    bool overflow_ = false;            // latched until a diagnosis read shows it
    bool reply_overflow_ = false;      // likewise
    std::uint32_t overflow_reads_ = 0; // the slave's diag_reads when an overflow was latched
    bool invalid_ = false;
    bool clear_when_shown_ = false; // a drive was lost: zero the reply area once it is free
    bool drive_ok_ = true;
};

} // namespace ferrule::gateway
