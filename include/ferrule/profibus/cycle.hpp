// A class-1 master's cycle over several DP-V0 slaves, as a master_session: each pass brings
// up the slaves that are not exchanging data (FDL_Status, Slave_Diag, Set_Prm, Chk_Cfg,
// Slave_Diag until ready: the start-up of §B.6, as bring_up() does it) and exchanges the I/O
// of the others, in list order. A DH reply makes the master read the slave's diagnosis at
// once (§B.3); a slave that no longer says it is ready, or whose exchange fails, is brought
// up again — in the next pass after a failed exchange, `retry_after` after a failed
// bring-up.
//
// The session never reports `done`: when one transaction finishes it starts the next, so
// poll_driver steps it from a super-loop without blocking, and the asio driver runs it. When
// every slave waits for its retry time it waits until the first one is due.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/master.hpp"
#include "ferrule/profibus/services.hpp"

namespace ferrule::profibus {

struct cycle_slave {
    std::uint8_t address = 0;
    prm_data prm{};
    std::span<const std::uint8_t> cfg{};
    std::span<const std::uint8_t> outputs{}; // sent every pass
    std::span<std::uint8_t> inputs{};        // written every pass

    // Kept by the cycle.
    bool exchanging = false;
    slave_diag diag{}; // the last diagnosis read (its extended part is not kept)
    ferrule::error last_error{};
    time_point retry_at{};
    std::uint32_t exchanges = 0;
    std::uint32_t failures = 0; // failed exchanges and bring-ups
    std::uint32_t bring_ups = 0;
    std::uint32_t diag_reads = 0; // after DH
};

struct cycle_config {
    duration retry_after = std::chrono::seconds(1);
    unsigned diag_polls = 10;
};

class cycle {
public:
    cycle(master& m, std::span<cycle_slave> slaves, const cycle_config& c = {}) noexcept
        : m_(m), slaves_(slaves), cfg_(c) {}

    // Passes that carried at least one transaction, and the Data_Exchanges of the last one.
    std::uint32_t passes() const noexcept { return passes_; }
    std::size_t last_pass_exchanges() const noexcept { return last_pass_exchanges_; }

    // --- master_session ----------------------------------------------------------------
    session_action next(time_point now) noexcept {
        session_action a = m_.next(now);
        if (a.what == session_action::kind::done) {
            harvest(now);
            a = m_.next(now);
        }
        if (a.what != session_action::kind::idle) return a;
        if (slaves_.empty()) return a;
        if (!start(now)) return session_action::wait_until(first_retry());
        return m_.next(now);
    }
    void on_receive(std::span<const std::uint8_t> in, time_point now) noexcept {
        m_.on_receive(in, now);
    }
    void on_transport_error(ferrule::error ec) noexcept { m_.on_transport_error(ec); }
    // Outcome of the last finished transaction.
    ferrule::error error() const noexcept { return last_error_; }

private:
    // What the slave under the cursor does next; `enter`: the cursor has just reached it.
    enum class step : std::uint8_t {
        enter,
        fdl_status,
        first_diag,
        set_prm,
        chk_cfg,
        ready_diag,
        exchange,
        dh_diag
    };

    cycle_slave& current() noexcept { return slaves_[index_]; }

    // Starts the next transaction of the pass; false when every slave waits for retry_at.
    bool start(time_point now) noexcept {
        for (std::size_t visited = 0; visited <= slaves_.size(); ++visited) {
            if (index_ == slaves_.size()) end_pass();
            if (step_ == step::enter && !enter(now)) {
                advance();
                continue;
            }
            if (const auto ec = begin_step()) {
                bring_up_failed(ec, now);
                continue;
            }
            ++pass_transactions_;
            return true;
        }
        return false;
    }

    bool enter(time_point now) noexcept {
        cycle_slave& s = current();
        if (s.exchanging) {
            step_ = step::exchange;
            return true;
        }
        if (before(now, s.retry_at)) return false;
        ++s.bring_ups;
        m_.reset_fcb(s.address);
        polls_ = 0;
        step_ = step::fdl_status;
        return true;
    }

    ferrule::error begin_step() noexcept {
        const cycle_slave& s = current();
        switch (step_) {
        case step::fdl_status: return m_.start_fdl_status(s.address);
        case step::set_prm: return m_.start_set_prm(s.address, s.prm);
        case step::chk_cfg: return m_.start_chk_cfg(s.address, s.cfg);
        case step::exchange: return m_.start_data_exchange(s.address, s.outputs);
        case step::first_diag:
        case step::ready_diag:
        case step::dh_diag: return m_.start_slave_diag(s.address);
        case step::enter: break;
        }
        return errc::invalid_argument;
    }

    void harvest(time_point now) noexcept {
        last_error_ = m_.error();
        const ferrule::error ec = last_error_;
        switch (step_) {
        case step::fdl_status: return then(ec, step::first_diag, now);
        case step::first_diag: return then(ec, step::set_prm, now);
        case step::set_prm: return then(ec, step::chk_cfg, now);
        case step::chk_cfg: return then(ec, step::ready_diag, now);
        case step::ready_diag: return ready_polled(ec, now);
        case step::exchange: return exchanged(ec, now);
        case step::dh_diag: return diagnosis_read(ec, now);
        case step::enter: break;
        }
        m_.clear();
    }

    // A start-up step done: on to `next`, or the bring-up has failed.
    void then(ferrule::error ec, step next, time_point now) noexcept {
        m_.clear();
        if (ec) return bring_up_failed(ec, now);
        step_ = next;
    }

    void ready_polled(ferrule::error ec, time_point now) noexcept {
        const slave_diag d = m_.diag();
        m_.clear();
        if (ec) return bring_up_failed(ec, now);
        if (const auto verdict = start_up_verdict(d, m_.config().address)) {
            if (verdict == device_errc::master_lock || ++polls_ >= cfg_.diag_polls)
                bring_up_failed(verdict, now);
            return;
        }
        current().exchanging = true;
        step_ = step::exchange; // exchanged in this pass, as soon as it is ready
    }

    void exchanged(ferrule::error ec, time_point now) noexcept {
        cycle_slave& s = current();
        const auto in = m_.reply();
        if (!ec && in.size() != s.inputs.size()) ec = errc::malformed;
        const bool dh = m_.data_high();
        m_.clear();
        if (ec) {
            last_error_ = ec;
            ++s.failures;
            s.last_error = ec;
            s.exchanging = false;
            s.retry_at = now;
            return advance();
        }
        std::copy(in.begin(), in.end(), s.inputs.begin());
        ++s.exchanges;
        ++pass_exchanges_;
        if (dh) {
            step_ = step::dh_diag;
            return;
        }
        advance();
    }

    void diagnosis_read(ferrule::error ec, time_point now) noexcept {
        cycle_slave& s = current();
        const slave_diag d = m_.diag();
        m_.clear();
        if (ec) {
            s.last_error = ec;
            return advance();
        }
        ++s.diag_reads;
        s.diag = d;
        s.diag.ext = {};
        if (!d.ready()) {
            s.exchanging = false;
            s.retry_at = now;
        }
        advance();
    }

    void bring_up_failed(ferrule::error ec, time_point now) noexcept {
        cycle_slave& s = current();
        ++s.failures;
        s.last_error = ec;
        last_error_ = ec;
        s.exchanging = false;
        s.retry_at = now + cfg_.retry_after;
        advance();
    }

    void advance() noexcept {
        ++index_;
        step_ = step::enter;
    }

    void end_pass() noexcept {
        if (pass_transactions_ > 0) {
            ++passes_;
            last_pass_exchanges_ = pass_exchanges_;
        }
        pass_transactions_ = 0;
        pass_exchanges_ = 0;
        index_ = 0;
    }

    time_point first_retry() const noexcept {
        time_point t = never;
        for (const cycle_slave& s : slaves_)
            if (!s.exchanging) t = earliest(t, scheduled(s.retry_at));
        return t;
    }

    master& m_;
    std::span<cycle_slave> slaves_;
    cycle_config cfg_;
    std::size_t index_ = 0;
    step step_ = step::enter;
    unsigned polls_ = 0;
    std::size_t pass_transactions_ = 0;
    std::size_t pass_exchanges_ = 0;
    std::size_t last_pass_exchanges_ = 0;
    std::uint32_t passes_ = 0;
    ferrule::error last_error_{};
};

static_assert(master_session<cycle>);

} // namespace ferrule::profibus
