// DP-V0 slave session (the station's side of the line), sans-I/O
// (protocols/modbus_profibus.md §B.3-§B.7):
//
//   * states Wait_Prm → Wait_Cfg → Data_Exchange (§B.6); FDL_Status, Slave_Diag and Get_Cfg
//     are answered in every state
//   * Set_Prm (SAP 61), as Lock_Req / Unlock_Req say (prm_lock, services.hpp):
//     - Lock_Req alone: all parameters; the ident number must be the slave's, else Prm_Fault
//       and Wait_Prm; the slave is locked to the sending master (Diag.Master_Add); WD_On arms
//       the watchdog (WD_Fact_1 × WD_Fact_2 × 10 ms); then Wait_Cfg
//     - neither: only min_TSDR and User_Prm_Data are taken; the state, the lock, the
//       watchdog, the group and Sync/Freeze stay as they were
//     - Unlock_Req (with or without Lock_Req): released for other masters (Master_Add 0xFF)
//       and back to Wait_Prm; no parameter is taken
//     min_TSDR (non-zero) sets the station delay; User_Prm_Data is kept for the application.
//     A locked slave takes Set_Prm, Chk_Cfg, Data_Exchange and Global_Control only from its
//     master: others get a short acknowledgement and are not acted upon, and their
//     Slave_Diag shows the locking master in Master_Add (they set Master_Lock themselves)
//   * Chk_Cfg (SAP 62): the identifier bytes must equal the slave's configuration, else
//     Cfg_Fault and Wait_Prm; in Wait_Prm it is acknowledged and not acted upon; Get_Cfg
//     (SAP 59) answers the configuration
//   * Data_Exchange (default SAP, SRD): outputs of the configured length replace the
//     outputs and the reply carries the inputs, DL, or DH while new diagnosis waits for the
//     master (it then fetches Slave_Diag, §B.3); outputs of another length send the slave
//     back to Wait_Prm. Outside Data_Exchange the reply is RS (SAP not activated, §B.6)
//   * Global_Control (SAP 58, SDN, no reply) to 127 or to the slave, for its groups: Clear_Data
//     sets the outputs to zero (the safe state) and keeps them there until a Global_Control
//     without it; Freeze holds the inputs the replies carry until the next Freeze or
//     Unfreeze; Sync holds the outputs received until the next Sync or Unsync
//   * Rd_Inp (56) and Rd_Outp (57) in Data_Exchange; other SAPs (Set_Slave_Add 55 included)
//     get RS
//   * FCB/FCV (§B.3): a request with FCV = 1 and the same FCB as the preceding request from
//     the same master gets the stored reply again and is not executed a second time
//   * watchdog: in Data_Exchange with WD_On, no request from the master for the watchdog time
//     sends the slave back to Wait_Prm with its outputs at zero
//   * the reply goes out min_TSDR bit times after the request's last character (11 tbit until
//     Set_Prm says otherwise); max TSDR (60 tbit up to 187.5 kbit/s) is the master's limit
//
// Requests for other stations, broadcasts other than Global_Control (§B.3), replies of other
// stations, tokens and broken telegrams are counted and not answered.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/result.hpp"
#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/profibus/constants.hpp"
#include "ferrule/profibus/fdl.hpp"
#include "ferrule/profibus/services.hpp"

namespace ferrule::profibus {

struct slave_config {
    std::uint32_t baud = 19'200;
    std::uint8_t address = 8;
    std::uint16_t ident = 0;
    std::span<const std::uint8_t> cfg{}; // identifier bytes; must outlive the session
    std::uint8_t group = 0;              // Set_Prm's Group_Ident replaces it
    bool sd2_for_8_bytes = false;        // send an 8-byte data unit as SD2 (as an ET200S does)
};

enum class slave_state : std::uint8_t { wait_prm, wait_cfg, data_exchange };

struct slave_stats {
    std::uint32_t requests = 0; // telegrams for this station that were acted upon
    std::uint32_t replies = 0;
    std::uint32_t repeats = 0; // answered with the stored reply (FCB unchanged)
    std::uint32_t bad_checksums = 0;
    std::uint32_t malformed = 0;
    std::uint32_t not_ours = 0; // for other stations, replies, tokens
    std::uint32_t prm_faults = 0;
    std::uint32_t cfg_faults = 0;
    std::uint32_t length_faults = 0; // Data_Exchange outputs of the wrong length
    std::uint32_t watchdog_expiries = 0;
    std::uint32_t data_exchanges = 0; // executed (repeats not counted)
    std::uint32_t global_controls = 0;
    std::uint32_t diag_reads = 0; // Slave_Diag answered (repeats not counted)
};

class slave {
public:
    static constexpr std::size_t max_io = max_data; // inputs or outputs
    static constexpr std::size_t max_ext_diag = max_data - 2 - diag::standard_size;

    slave() noexcept : slave(slave_config{}) {}
    explicit slave(const slave_config& cfg) noexcept : cfg_(cfg) {
        if (const auto s = cfg_io_sizes(cfg.cfg); s && s->inputs <= max_io && s->outputs <= max_io)
            io_ = *s;
        group_ = cfg.group;
    }

    // Bytes from the line whose last one ended at `end`.
    void on_receive(std::span<const std::uint8_t> bytes, time_point end) noexcept {
        fdl_decoder::step s;
        do {
            s = rx_.feed(bytes);
            bytes = bytes.subspan(s.consumed);
            if (s.what == fdl_decoder::status::error) {
                if (s.ec == errc::bad_checksum)
                    ++stats_.bad_checksums;
                else
                    ++stats_.malformed;
            }
            if (s.what == fdl_decoder::status::frame) handle(rx_.telegram(), end);
        } while (s.what != fdl_decoder::status::need_more);
    }

    // send: the reply, now; wait: until the reply is due or the watchdog runs out; idle.
    session_action next(time_point now) noexcept {
        check_watchdog(now);
        if (!reply_due_)
            return wake_at() == never ? session_action::idle()
                                      : session_action::wait_until(wake_at());
        if (before(now, reply_at_)) return session_action::wait_until(reply_at_);
        reply_due_ = false;
        ++stats_.replies;
        return session_action::send({tx_.data(), tx_size_}, false);
    }

    time_point wake_at() const noexcept {
        if (reply_due_) return scheduled(reply_at_);
        if (watchdog_armed()) return scheduled(last_request_ + watchdog_);
        return never;
    }

    slave_state state() const noexcept { return state_; }
    std::size_t input_size() const noexcept { return io_.inputs; }
    std::size_t output_size() const noexcept { return io_.outputs; }

    // The outputs as the slave applies them (zeros after Clear_Data or the watchdog).
    std::span<const std::uint8_t> outputs() const noexcept {
        return {outputs_.data(), io_.outputs};
    }
    // The inputs the next Data_Exchange reply carries (unless frozen).
    void set_inputs(std::span<const std::uint8_t> in) noexcept {
        std::copy_n(in.begin(), std::min(in.size(), io_.inputs), inputs_.begin());
    }
    std::span<const std::uint8_t> inputs() const noexcept { return {inputs_.data(), io_.inputs}; }

    // Extended diagnosis blocks (§B.7) and whether they report a fault (Ext_Diag). A change
    // makes the next Data_Exchange reply DH. Blocks beyond max_ext_diag are cut off and
    // Ext_Diag_Overflow is set.
    void set_ext_diag(std::span<const std::uint8_t> blocks, bool fault) noexcept {
        const std::size_t n = std::min(blocks.size(), max_ext_diag);
        const bool overflow = blocks.size() > max_ext_diag;
        const bool same =
            n == ext_size_ && fault == ext_fault_ && overflow == ext_overflow_ &&
            std::equal(blocks.begin(), blocks.begin() + static_cast<long>(n), ext_.begin());
        if (same) return;
        std::copy_n(blocks.begin(), n, ext_.begin());
        ext_size_ = n;
        ext_fault_ = fault;
        ext_overflow_ = overflow;
        diag_changed_ = true;
    }
    // Stat_Diag keeps the master fetching diagnosis (§B.6) until it is cleared.
    void set_stat_diag(bool on) noexcept {
        if (on == stat_diag_) return;
        stat_diag_ = on;
        diag_changed_ = true;
    }

    slave_diag diagnosis() const noexcept {
        slave_diag d;
        d.status1 = static_cast<std::uint8_t>(
            (state_ != slave_state::data_exchange ? diag::station_not_ready : 0) |
            (cfg_fault_ ? diag::cfg_fault : 0) | (ext_fault_ ? diag::ext_diag : 0) |
            (prm_fault_ ? diag::prm_fault : 0));
        d.status2 = static_cast<std::uint8_t>(
            diag::always_one | (state_ == slave_state::wait_prm ? diag::prm_req : 0) |
            (stat_diag_ ? diag::stat_diag : 0) | (watchdog_on_ ? diag::wd_on : 0) |
            (frozen_ ? diag::freeze_mode : 0) | (synced_ ? diag::sync_mode : 0));
        d.status3 = ext_overflow_ ? diag::ext_diag_overflow : std::uint8_t{0};
        d.master = master_;
        d.ident = cfg_.ident;
        d.ext = {ext_.data(), ext_size_};
        return d;
    }

    std::uint8_t master_address() const noexcept { return master_; }
    std::span<const std::uint8_t> user_prm() const noexcept {
        return {user_prm_.data(), user_prm_size_};
    }
    duration watchdog() const noexcept { return watchdog_on_ ? watchdog_ : duration::zero(); }
    bool clear_data() const noexcept { return clear_; }
    bool frozen() const noexcept { return frozen_; }
    bool synced() const noexcept { return synced_; }
    const slave_stats& stats() const noexcept { return stats_; }
    const slave_config& config() const noexcept { return cfg_; }

private:
    void handle(const telegram& t, time_point end) noexcept {
        const bool ours = t.da == cfg_.address || t.da == broadcast_address;
        if (t.frame == frame::sd4 || t.frame == frame::short_ack || !t.is_request() || !ours) {
            ++stats_.not_ours;
            return;
        }
        check_watchdog(end);
        // A new request: the master has moved on from any reply not yet sent.
        reply_due_ = false;
        const auto fn = static_cast<request_fn>(t.function());
        if (fn == request_fn::sdn_high || fn == request_fn::sdn_low) {
            if (t.dsap == static_cast<std::uint8_t>(sap::global_control))
                global(t, end);
            else
                ++stats_.not_ours;
            return;
        }
        if (t.da == broadcast_address) { // only SDN is broadcast: no station answers (§B.3)
            ++stats_.not_ours;
            return;
        }
        if (fn == request_fn::fdl_status) {
            ++stats_.requests;
            return reply_short_telegram(t, response_fn::ok, end);
        }
        if (fn != request_fn::srd_high && fn != request_fn::srd_low) {
            ++stats_.requests;
            return reply_short_telegram(t, response_fn::sap_not_active, end);
        }
        // FCB/FCV (§B.3): the same FCB again from the same master is a repeat.
        if (t.fcv() && have_last_ && t.sa == last_sa_ && t.fcb() == last_fcb_) {
            ++stats_.repeats;
            ++stats_.requests;
            note_master_activity(t, end);
            std::copy_n(last_reply_.begin(), last_reply_size_, tx_.begin());
            tx_size_ = last_reply_size_;
            reply_at_ = end + bit_times(cfg_.baud, min_tsdr_);
            reply_due_ = true;
            return;
        }
        have_last_ = true;
        last_sa_ = t.sa;
        last_fcb_ = t.fcb();
        ++stats_.requests;
        note_master_activity(t, end);
        srd(t, end);
        // Kept for a repeat: FDL_Status and Global_Control in between do not replace it.
        std::copy_n(tx_.begin(), tx_size_, last_reply_.begin());
        last_reply_size_ = tx_size_;
    }

    void srd(const telegram& t, time_point end) noexcept {
        if (t.dsap == no_sap) return data_exchange(t, end);
        switch (static_cast<sap>(t.dsap)) {
        case sap::slave_diag: {
            std::array<std::uint8_t, max_data> du{};
            const auto n = encode_slave_diag(diagnosis(), du);
            diag_changed_ = false;
            ++stats_.diag_reads;
            return reply_data(t, response_fn::data_low, {du.data(), n.value_or(0)}, end);
        }
        case sap::set_prm: return set_prm(t, end);
        case sap::chk_cfg: return chk_cfg(t, end);
        case sap::get_cfg: return reply_data(t, response_fn::data_low, cfg_.cfg, end);
        case sap::read_inputs:
            if (state_ != slave_state::data_exchange) break;
            return reply_data(t, response_fn::data_low, reply_inputs(), end);
        case sap::read_outputs:
            if (state_ != slave_state::data_exchange) break;
            return reply_data(t, response_fn::data_low, outputs(), end);
        default: break;
        }
        reply_short_telegram(t, response_fn::sap_not_active, end);
    }

    bool locked_by_other(std::uint8_t sa) const noexcept {
        return master_ != diag::no_master && sa != master_;
    }

    void set_prm(const telegram& t, time_point end) noexcept {
        if (!locked_by_other(t.sa)) take_prm(parse_prm(t.data), t.sa);
        reply_ack(end);
    }

    void take_prm(const result<prm_data>& p, std::uint8_t sa) noexcept {
        const prm_lock lock = p ? p->lock_request() : prm_lock::lock;
        if (lock == prm_lock::unlock) {
            to_wait_prm();
            master_ = diag::no_master;
            return;
        }
        if (!p || p->user.size() > user_prm_.size() ||
            (lock == prm_lock::lock &&
             (p->ident != cfg_.ident ||
              (p->watchdog_on() && (p->wd_fact1 == 0 || p->wd_fact2 == 0))))) {
            ++stats_.prm_faults;
            prm_fault_ = true;
            to_wait_prm();
            return;
        }
        // Without Lock_Req only these two may be overwritten.
        if (p->min_tsdr != 0) min_tsdr_ = p->min_tsdr;
        std::copy(p->user.begin(), p->user.end(), user_prm_.begin());
        user_prm_size_ = p->user.size();
        if (lock == prm_lock::overwrite) return;
        prm_fault_ = false;
        master_ = sa;
        watchdog_on_ = p->watchdog_on();
        watchdog_ = p->watchdog();
        group_ = p->group;
        if (state_ == slave_state::data_exchange) zero_outputs();
        state_ = slave_state::wait_cfg;
    }

    void chk_cfg(const telegram& t, time_point end) noexcept {
        if (locked_by_other(t.sa)) return reply_ack(end);
        // Before parameters it is acknowledged and not acted upon: the master's next
        // Slave_Diag shows why (Prm_Req, Prm_Fault), as masters send Set_Prm and Chk_Cfg
        // back to back before they look (§B.6).
        if (state_ == slave_state::wait_prm) return reply_ack(end);
        if (!std::equal(t.data.begin(), t.data.end(), cfg_.cfg.begin(), cfg_.cfg.end())) {
            ++stats_.cfg_faults;
            cfg_fault_ = true;
            to_wait_prm();
            return reply_ack(end);
        }
        cfg_fault_ = false;
        state_ = slave_state::data_exchange;
        reply_ack(end);
    }

    void data_exchange(const telegram& t, time_point end) noexcept {
        if (state_ != slave_state::data_exchange || locked_by_other(t.sa))
            return reply_short_telegram(t, response_fn::sap_not_active, end);
        if (t.data.size() != io_.outputs) {
            // "Output length false": back to parameterization (§B.5).
            ++stats_.length_faults;
            to_wait_prm();
            return reply_short_telegram(t, response_fn::sap_not_active, end);
        }
        ++stats_.data_exchanges;
        if (!clear_) {
            auto& target = synced_ ? pending_outputs_ : outputs_;
            std::copy(t.data.begin(), t.data.end(), target.begin());
        }
        const auto fn = diag_changed_ ? response_fn::data_high : response_fn::data_low;
        if (io_.inputs == 0 && fn == response_fn::data_low) return reply_ack(end);
        reply_data(t, fn, reply_inputs(), end);
    }

    void global(const telegram& t, time_point end) noexcept {
        if (t.data.size() < 2 || state_ != slave_state::data_exchange || locked_by_other(t.sa)) {
            ++stats_.not_ours;
            return;
        }
        const global_control g{t.data[0], t.data[1]};
        if (g.group != 0 && (g.group & group_) == 0) {
            ++stats_.not_ours;
            return;
        }
        ++stats_.requests;
        ++stats_.global_controls;
        note_master_activity(t, end);
        clear_ = (g.command & control::clear_data) != 0;
        if (clear_) zero_outputs();
        if (g.command & control::sync) {
            if (synced_) outputs_ = pending_outputs_;
            synced_ = true;
            pending_outputs_ = outputs_;
        } else if (g.command & control::unsync) {
            if (synced_) outputs_ = pending_outputs_;
            synced_ = false;
        }
        if (g.command & control::freeze) {
            frozen_ = true;
            frozen_inputs_ = inputs_;
        } else if (g.command & control::unfreeze) {
            frozen_ = false;
        }
    }

    std::span<const std::uint8_t> reply_inputs() const noexcept {
        return {frozen_ ? frozen_inputs_.data() : inputs_.data(), io_.inputs};
    }

    void note_master_activity(const telegram& t, time_point end) noexcept {
        if (master_ == diag::no_master || t.sa == master_) last_request_ = end;
    }

    bool watchdog_armed() const noexcept {
        return watchdog_on_ && state_ == slave_state::data_exchange;
    }

    void check_watchdog(time_point now) noexcept {
        if (!watchdog_armed() || before(now, last_request_ + watchdog_)) return;
        ++stats_.watchdog_expiries;
        to_wait_prm();
        master_ = diag::no_master;
    }

    void to_wait_prm() noexcept {
        state_ = slave_state::wait_prm;
        zero_outputs();
        frozen_ = synced_ = clear_ = false;
    }

    void zero_outputs() noexcept {
        outputs_.fill(0);
        pending_outputs_.fill(0);
    }

    // Replies: SD1 without data, SD1/SD2/SD3 with, the short acknowledgement.
    void reply_short_telegram(const telegram& t, response_fn fn, time_point end) noexcept {
        reply_data(t, fn, {}, end);
    }

    void reply_data(const telegram& t, response_fn fn, std::span<const std::uint8_t> data,
                    time_point end) noexcept {
        telegram r;
        r.da = t.sa;
        r.sa = cfg_.address;
        r.fc = response_code(fn);
        if (t.dsap != no_sap && !data.empty()) {
            r.dsap = t.ssap; // SAPs swapped in the reply (§B.4)
            r.ssap = t.dsap;
        }
        r.data = data;
        queue(r, end);
    }

    void reply_ack(time_point end) noexcept {
        telegram r;
        r.frame = frame::short_ack;
        queue(r, end);
    }

    void queue(const telegram& r, time_point end) noexcept {
        const auto n = encode(r, tx_, {.sd2_for_8_bytes = cfg_.sd2_for_8_bytes});
        if (!n) return;
        tx_size_ = *n;
        reply_at_ = end + bit_times(cfg_.baud, min_tsdr_);
        reply_due_ = true;
    }

    slave_config cfg_;
    io_sizes io_{};
    fdl_decoder rx_{};
    slave_stats stats_{};
    slave_state state_ = slave_state::wait_prm;
    std::array<std::uint8_t, max_io> inputs_{};
    std::array<std::uint8_t, max_io> frozen_inputs_{};
    std::array<std::uint8_t, max_io> outputs_{};
    std::array<std::uint8_t, max_io> pending_outputs_{}; // received while synced
    std::array<std::uint8_t, max_data> user_prm_{};
    std::size_t user_prm_size_ = 0;
    std::array<std::uint8_t, max_ext_diag> ext_{};
    std::size_t ext_size_ = 0;
    std::array<std::uint8_t, max_telegram> tx_{};
    std::size_t tx_size_ = 0;
    std::array<std::uint8_t, max_telegram> last_reply_{}; // of the last SRD
    std::size_t last_reply_size_ = 0;
    time_point reply_at_{};
    time_point last_request_{};
    duration watchdog_{};
    std::uint8_t master_ = diag::no_master;
    std::uint8_t min_tsdr_ = min_tsdr_bits;
    std::uint8_t group_ = 0;
    std::uint8_t last_sa_ = 0;
    bool last_fcb_ = false;
    bool have_last_ = false;
    bool reply_due_ = false;
    bool watchdog_on_ = false;
    bool prm_fault_ = false;
    bool cfg_fault_ = false;
    bool ext_fault_ = false;
    bool ext_overflow_ = false;
    bool stat_diag_ = false;
    bool diag_changed_ = false;
    bool clear_ = false;
    bool frozen_ = false;
    bool synced_ = false;
};

static_assert(station<slave>);

} // namespace ferrule::profibus
