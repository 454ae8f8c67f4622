// PROFIBUS-DP master (class 1, DP-V0), sans-I/O: one transaction at a time
// (protocols/modbus_profibus.md §B).
//
//   service          request                          reply
//   FDL_Status       SD1, FC 0x49 (no FCB)            SD1, response FC OK
//   Slave_Diag       SRD_HI, DSAP 60, SSAP 62         DL/DH, SAPs swapped, 6+ diagnosis bytes
//   Set_Prm          SRD_HI, DSAP 61, SSAP 62         SC
//   Chk_Cfg          SRD_HI, DSAP 62, SSAP 62         SC
//   Get_Cfg          SRD_HI, DSAP 59, SSAP 62         DL, configuration bytes
//   Rd_Inp/Rd_Outp   SRD_HI, DSAP 56/57, SSAP 62      DL, inputs/outputs
//   Data_Exchange    SRD_HI, default SAP, outputs     DL/DH with inputs; SC without inputs
//   Global_Control   SDN_HI, DSAP 58 (DA 127: all)    none
//
// Behaviour:
//   * before each request the line has been idle for 33 tbit (TSYN, §B.1), counted from the
//     end of the last byte on the line: our request (its wire time from the serial format)
//     or the last byte received. A reply that arrives before the request's computed end (a
//     pty) ends the request's hold at once
//   * the reply's first character must have arrived within the slot time TSL after the
//     request's end (§B.1 table; from the baud rate unless configured); once bytes have
//     begun, the telegram may take until that deadline + the wire time of the longest one
//   * FCB/FCV per slave (§B.3): the first SRD to a slave carries FCV=0, FCB=1; every new
//     request after it FCV=1 and the FCB toggled; a retry keeps its FCB. FDL_Status and
//     Global_Control carry neither (pyprofibus, golden telegrams §B.9). A transaction that
//     ends without a telegram from the slave starts the slave over (FCV=0): whether it saw
//     the last FCB is unknown
//   * the reply must come from the slave asked to us (else errc::unexpected_address), be a
//     response FC with the service's SAPs swapped (DSAP 62, SSAP = the service SAP) and the
//     service's shape (else errc::malformed). UE/RR/RS/NR are the slave's answer:
//     device_category() errors, not resent. Timeouts, FCS errors, garbage, a wrong address
//     or shape are resent up to `retries` times; after garbage or an FCS error the attempt
//     ends once the line has been idle for TSYN
//   * Global_Control gets no reply: the line is kept idle for TSYN, then the transaction
//     ends with errc::no_response_expected
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
#include "ferrule/profibus/constants.hpp"
#include "ferrule/profibus/error.hpp"
#include "ferrule/profibus/fdl.hpp"
#include "ferrule/profibus/services.hpp"

namespace ferrule::profibus {

// Slot time TSL in bit times by baud rate (Felser "time ratios", §B.1).
constexpr unsigned slot_time_bits(std::uint32_t baud) noexcept {
    if (baud <= 187'500) return 100;
    if (baud <= 500'000) return 200;
    if (baud <= 1'500'000) return 300;
    if (baud <= 3'000'000) return 400;
    if (baud <= 6'000'000) return 600;
    return 1000;
}

struct master_config {
    serial_format format = profibus::format(19200);
    std::uint8_t address = 2;              // this master's station address
    duration slot_time = duration::zero(); // TSL; 0: from the baud rate (slot_time_bits)
    unsigned retries = 1;                  // resends after the first attempt
    unsigned fault_threshold = 0; // failed attempts in a row that latch the fault; 0: never
};

// Transactions end as succeeded, failed or (Global_Control) neither. The attempt counters
// (timeouts … device_errors) count each failed attempt once, retries included.
struct master_stats {
    std::uint32_t transactions = 0;
    std::uint32_t succeeded = 0;
    std::uint32_t failed = 0;         // device errors and transport errors included
    std::uint32_t unacknowledged = 0; // Global_Control sent (SDN, no reply)
    std::uint32_t timeouts = 0;
    std::uint32_t bad_checksums = 0;
    std::uint32_t malformed = 0; // garbage, a wrong SAP, FC or shape
    std::uint32_t unexpected_addresses = 0;
    std::uint32_t device_errors = 0; // UE, RR, RS, NR
    std::uint32_t resends = 0;
    std::uint32_t data_high = 0; // Data_Exchange replies with DH
};

enum class service : std::uint8_t {
    fdl_status,
    slave_diag,
    set_prm,
    chk_cfg,
    get_cfg,
    read_inputs,
    read_outputs,
    data_exchange,
    global_control,
};

class master {
public:
    constexpr explicit master(const master_config& cfg = {}) noexcept
        : cfg_(cfg), syn_time_(bit_times(cfg.format.baud, syn_bits)) {
        if (cfg_.slot_time == duration::zero())
            cfg_.slot_time = bit_times(cfg_.format.baud, slot_time_bits(cfg_.format.baud));
    }

    // Each start returns errc::busy while a transaction runs, errc::invalid_argument for a
    // slave address outside 0…126 (or this master's), or a data unit that does not fit.
    ferrule::error start_fdl_status(std::uint8_t da) noexcept {
        return begin(service::fdl_status, da, {});
    }
    ferrule::error start_slave_diag(std::uint8_t da) noexcept {
        return begin(service::slave_diag, da, {});
    }
    ferrule::error start_set_prm(std::uint8_t da, const prm_data& p) noexcept {
        if (busy()) return errc::busy;
        const auto n = encode_prm(p, du_);
        if (!n) return n.error();
        return begin(service::set_prm, da, {du_.data(), *n});
    }
    ferrule::error start_chk_cfg(std::uint8_t da, std::span<const std::uint8_t> cfg) noexcept {
        return begin(service::chk_cfg, da, cfg);
    }
    ferrule::error start_get_cfg(std::uint8_t da) noexcept {
        return begin(service::get_cfg, da, {});
    }
    ferrule::error start_read_inputs(std::uint8_t da) noexcept {
        return begin(service::read_inputs, da, {});
    }
    ferrule::error start_read_outputs(std::uint8_t da) noexcept {
        return begin(service::read_outputs, da, {});
    }
    ferrule::error start_data_exchange(std::uint8_t da,
                                       std::span<const std::uint8_t> outputs) noexcept {
        return begin(service::data_exchange, da, outputs);
    }
    // DA 127 reaches every slave; the group bits of `gc` select among them (§B.5).
    ferrule::error start_global_control(const global_control& gc,
                                        std::uint8_t da = broadcast_address) noexcept {
        const std::array<std::uint8_t, 2> du{gc.command, gc.group};
        return begin(service::global_control, da, du);
    }

    // The next request to `da` is a first one again: FCV=0, FCB=1 (§B.3).
    void reset_fcb(std::uint8_t da) noexcept {
        if (da <= max_station_address) fcb_[da] = frame_count::first;
    }

    session_action next(time_point now) noexcept {
        switch (state_) {
        case state::idle: return session_action::idle();
        case state::done: return session_action::done();
        case state::pending_send:
            if (hold_.holds(now)) return session_action::wait_until(hold_.end());
            return send(now);
        case state::no_reply: {
            const time_point quiet = tx_end_ + syn_time();
            if (before(now, quiet)) return session_action::wait_until(quiet);
            finish(errc::no_response_expected);
            return session_action::done();
        }
        case state::awaiting: {
            const time_point deadline = deadline_now();
            if (before(now, deadline)) return session_action::wait_until(deadline);
            expire();
            return next(now);
        }
        }
        return session_action::idle();
    }

    void on_receive(std::span<const std::uint8_t> in, time_point now) noexcept {
        if (in.empty()) return;
        // A reply before our request's computed wire end: the link is faster than the serial
        // format says (a pty), so the request's hold ends now.
        if (state_ == state::awaiting && before(now, tx_end_)) hold_.release();
        hold(now, now); // the line is busy until now
        last_rx_ = now;
        if (state_ != state::awaiting) return;
        heard_ = true;
        fdl_decoder::step s;
        do {
            s = decoder_.feed(in);
            in = in.subspan(s.consumed);
            if (s.what == fdl_decoder::status::error && !decode_error_) decode_error_ = s.ec;
            if (s.what == fdl_decoder::status::frame) evaluate(decoder_.telegram());
        } while (s.what != fdl_decoder::status::need_more && state_ == state::awaiting);
    }

    void on_transport_error(ferrule::error ec) noexcept {
        if (!busy()) return;
        ++stats_.failed;
        reset_fcb(da_);
        finish(ec);
    }

    // Outcome of the finished transaction: empty on success; errc::no_response_expected for
    // Global_Control; otherwise the cause of the last failed attempt, a ferrule::errc or a
    // profibus::device_domain error.
    ferrule::error error() const noexcept { return error_; }
    // The finished transaction succeeded: error() is empty.
    bool succeeded() const noexcept { return !error_; }
    // The data unit (SAP bytes excluded) of the last successful reply: diagnosis, cfg bytes,
    // inputs; empty for a short acknowledgement. Valid until the next start.
    std::span<const std::uint8_t> reply() const noexcept { return {rx_.data(), rx_size_}; }
    // The last successful Slave_Diag's diagnosis; ext spans the session's buffer, valid until
    // the next start.
    const slave_diag& diag() const noexcept { return diag_; }
    // The last Data_Exchange reply was DH: the slave has new diagnosis to fetch (§B.3).
    bool data_high() const noexcept { return data_high_; }
    // Function and frame of the last reply (ok for a short acknowledgement).
    profibus::response_fn response_fn() const noexcept { return response_fn_; }
    profibus::frame reply_frame() const noexcept { return reply_frame_; }
    // The request as last sent.
    std::span<const std::uint8_t> request_bytes() const noexcept { return {tx_.data(), tx_size_}; }
    profibus::service service() const noexcept { return service_; }
    std::uint8_t slave() const noexcept { return da_; }
    unsigned attempts() const noexcept { return attempts_; }
    bool busy() const noexcept {
        return state_ == state::pending_send || state_ == state::awaiting ||
               state_ == state::no_reply;
    }
    // Done -> idle once the result has been read (a new start does this too).
    void clear() noexcept {
        if (state_ == state::done) state_ = state::idle;
    }

    const master_stats& stats() const noexcept { return stats_; }
    const master_config& config() const noexcept { return cfg_; }

    // fault_threshold failed attempts in a row latch a fault: every start then returns
    // errc::fault_latched until reset_fault().
    bool fault_latched() const noexcept { return latch_.fault_latched(); }
    unsigned consecutive_failures() const noexcept { return latch_.consecutive_failures(); }
    void reset_fault() noexcept { latch_.reset_fault(); }
    duration syn_time() const noexcept { return syn_time_; }

private:
    enum class state : std::uint8_t { idle, pending_send, awaiting, no_reply, done };
    enum class frame_count : std::uint8_t { first, fcb0, fcb1 }; // the FCB last sent

    static constexpr std::uint8_t service_sap(profibus::service s) noexcept {
        switch (s) {
        case service::slave_diag: return static_cast<std::uint8_t>(sap::slave_diag);
        case service::set_prm: return static_cast<std::uint8_t>(sap::set_prm);
        case service::chk_cfg: return static_cast<std::uint8_t>(sap::chk_cfg);
        case service::get_cfg: return static_cast<std::uint8_t>(sap::get_cfg);
        case service::read_inputs: return static_cast<std::uint8_t>(sap::read_inputs);
        case service::read_outputs: return static_cast<std::uint8_t>(sap::read_outputs);
        case service::global_control: return static_cast<std::uint8_t>(sap::global_control);
        case service::fdl_status:
        case service::data_exchange: return no_sap;
        }
        return no_sap;
    }

    ferrule::error begin(profibus::service s, std::uint8_t da,
                         std::span<const std::uint8_t> du) noexcept {
        if (busy()) return errc::busy;
        if (latch_.fault_latched()) return errc::fault_latched;
        const bool sdn = s == service::global_control;
        if (da == cfg_.address || da > (sdn ? broadcast_address : max_station_address))
            return errc::invalid_argument;
        telegram t;
        t.da = da;
        t.sa = cfg_.address;
        t.dsap = service_sap(s);
        t.ssap = t.dsap == no_sap ? no_sap : master_sap;
        t.data = du;
        frame_count sent = frame_count::first;
        if (s == service::fdl_status) {
            t.fc = request_code(request_fn::fdl_status, false, false);
        } else if (sdn) {
            t.fc = request_code(request_fn::sdn_high, false, false);
        } else {
            // §B.3: FCV=0, FCB=1 first; then FCV=1 and the FCB toggled.
            const frame_count last = fcb_[da];
            const bool fcb = last != frame_count::fcb1;
            t.fc = request_code(request_fn::srd_high, fcb, last != frame_count::first);
            sent = fcb ? frame_count::fcb1 : frame_count::fcb0;
        }
        const auto n = encode(t, tx_);
        if (!n) return n.error();
        tx_size_ = *n;
        if (s != service::fdl_status && !sdn) fcb_[da] = sent;
        service_ = s;
        da_ = da;
        attempts_ = 0;
        error_ = {};
        rx_size_ = 0;
        response_fn_ = response_fn::ok;
        if (s == service::data_exchange) data_high_ = false;
        ++stats_.transactions;
        state_ = state::pending_send;
        return {};
    }

    session_action send(time_point now) noexcept {
        if (++attempts_ > 1) ++stats_.resends;
        tx_end_ = now + cfg_.format.chars_time(tx_size_);
        last_rx_ = tx_end_;
        hold(now, tx_end_);
        decoder_.reset();
        decode_error_ = {};
        heard_ = false;
        answered_ = false;
        if (service_ == service::global_control) {
            ++stats_.unacknowledged;
            state_ = state::no_reply;
        } else {
            state_ = state::awaiting;
        }
        return session_action::send({tx_.data(), tx_size_}, true);
    }

    time_point deadline_now() const noexcept {
        const time_point base = tx_end_ + cfg_.slot_time;
        if (!decode_error_ && !decoder_.in_frame()) return base;
        // Bytes have begun: a telegram has no gaps (§B.1), the longest one fits in this.
        const time_point late = base + cfg_.format.chars_time(max_telegram);
        if (!decode_error_) return late;
        // Garbage or an FCS error: the attempt ends when the line has been idle for TSYN,
        // that is when a character begun by then would have arrived.
        const time_point idle = last_rx_ + syn_time() + cfg_.format.char_time();
        return earliest(idle, late);
    }

    void expire() noexcept {
        if (decode_error_ || decoder_.in_frame()) {
            // The idle line ends what was received: a telegram in it still counts.
            fdl_decoder::step s;
            do {
                s = decoder_.finish();
                if (s.what == fdl_decoder::status::error && !decode_error_) decode_error_ = s.ec;
                if (s.what == fdl_decoder::status::frame) {
                    evaluate(decoder_.telegram());
                    if (state_ != state::awaiting) return;
                }
            } while (s.what != fdl_decoder::status::need_more);
        }
        if (decode_error_)
            fail(decode_error_, true);
        else
            fail(heard_ ? errc::malformed : errc::timeout, true);
    }

    void evaluate(const telegram& t) noexcept {
        if (t.frame == frame::sd4) {
            fail(errc::malformed, true);
            return;
        }
        const bool ack = t.frame == frame::short_ack;
        if (!ack && (t.sa != da_ || t.da != cfg_.address)) {
            fail(errc::unexpected_address, true);
            return;
        }
        answered_ = true;
        if (ack) {
            accept(t, response_fn::ok);
            return;
        }
        if (t.is_request()) {
            fail(errc::malformed, true);
            return;
        }
        const auto fn = static_cast<profibus::response_fn>(t.function());
        if (const ferrule::error ec = response_error(fn)) {
            response_fn_ = fn;
            fail(ec, false);
            return;
        }
        accept(t, fn);
    }

    // Checks the reply's shape for the service (§B.4, §B.5) and keeps its data.
    void accept(const telegram& t, profibus::response_fn fn) noexcept {
        const bool ack = t.frame == frame::short_ack;
        const bool data = fn == response_fn::data_low || fn == response_fn::data_high;
        const std::uint8_t sap = service_sap(service_);
        const bool saps = sap == no_sap ? t.dsap == no_sap && t.ssap == no_sap
                                        : t.dsap == master_sap && t.ssap == sap;
        bool ok = false;
        switch (service_) {
        case service::fdl_status:
            ok = !ack && t.frame == frame::sd1 && fn == response_fn::ok;
            break;
        case service::slave_diag:
            ok = !ack && data && saps && t.data.size() >= diag::standard_size;
            break;
        case service::set_prm:
        case service::chk_cfg:
            // The short acknowledgement, or a telegram without data unit.
            ok = ack || ((fn == response_fn::ok || fn == response_fn::data_low) && t.data.empty());
            break;
        case service::get_cfg:
        case service::read_inputs:
        case service::read_outputs: ok = !ack && data && saps; break;
        case service::data_exchange: ok = ack || (data && saps); break;
        case service::global_control: break;
        }
        if (!ok) {
            fail(errc::malformed, true);
            return;
        }
        // The decoder's buffer is reused by the next feed(): keep the data unit.
        rx_size_ = ack ? 0 : t.data.size();
        for (std::size_t i = 0; i < rx_size_; ++i) rx_[i] = t.data[i];
        response_fn_ = fn;
        reply_frame_ = t.frame;
        if (service_ == service::slave_diag) diag_ = *parse_slave_diag(reply());
        if (service_ == service::data_exchange) {
            data_high_ = fn == response_fn::data_high;
            if (data_high_) ++stats_.data_high;
        }
        latch_.succeeded();
        ++stats_.succeeded;
        finish({});
    }

    void fail(ferrule::error ec, bool may_retry) noexcept {
        if (ec == errc::timeout)
            ++stats_.timeouts;
        else if (ec == errc::bad_checksum)
            ++stats_.bad_checksums;
        else if (ec == errc::unexpected_address)
            ++stats_.unexpected_addresses;
        else if (ec.domain() == &device_domain)
            ++stats_.device_errors;
        else
            ++stats_.malformed;
        if (latch_.retry(attempts_, cfg_.retries, cfg_.fault_threshold, may_retry)) {
            error_ = ec; // the cause so far, replaced by the final outcome
            state_ = state::pending_send;
            return;
        }
        ++stats_.failed;
        if (!answered_) reset_fcb(da_);
        finish(ec);
    }

    void finish(ferrule::error ec) noexcept {
        error_ = ec;
        state_ = state::done;
    }

    // No request before the line has been idle for TSYN after t (§B.1).
    void hold(time_point now, time_point t) noexcept { hold_.extend(now, t + syn_time()); }

    master_config cfg_;
    duration syn_time_; // TSYN, taken once: a division by the baud rate
    master_stats stats_{};
    state state_ = state::idle;
    profibus::service service_ = service::fdl_status;
    std::array<frame_count, max_station_address + 1> fcb_{};
    std::array<std::uint8_t, max_telegram> tx_{};
    std::size_t tx_size_ = 0;
    std::array<std::uint8_t, max_data> du_{}; // Set_Prm's data unit
    std::array<std::uint8_t, max_data> rx_{};
    std::size_t rx_size_ = 0;
    fdl_decoder decoder_{};
    slave_diag diag_{};
    line_hold hold_{};
    time_point tx_end_{};
    time_point last_rx_{};
    ferrule::error error_{};
    ferrule::error decode_error_{}; // garbage or an FCS error in this attempt
    unsigned attempts_ = 0;
    fault_latch latch_{};
    std::uint8_t da_ = 0;
    profibus::response_fn response_fn_ = response_fn::ok;
    profibus::frame reply_frame_ = frame::sd1;
    bool data_high_ = false;
    bool heard_ = false;    // bytes since the request
    bool answered_ = false; // a telegram from the slave asked in this attempt
};

static_assert(master_session<master>);

} // namespace ferrule::profibus
