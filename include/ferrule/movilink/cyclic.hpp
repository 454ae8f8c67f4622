// Cyclic process-data exchange with a drive, as a PLC does it: every cycle the current PO
// words go out and the PI words come back; a parameter service requested meanwhile rides
// in the next cycle on the matching PARAM+nPD type, so process data never pauses.
// A master_session itself (it restarts the exchange when one finishes), so the blocking
// run(), poll_driver and the asio driver all drive it.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "ferrule/core/session.hpp"
#include "ferrule/movilink/master.hpp"

namespace ferrule::movilink {

class cyclic {
public:
    // `words` PD words per cycle (1-3); `acyclic_types` selects TYP 0x8x, which the drive does
    // not watch with its RS-485 timeout (SC01 p.17): cyclic types are the safe default.
    constexpr cyclic(master& m, std::uint8_t address, std::size_t words = 3,
                     bool acyclic_types = false) noexcept
        : m_(m), address_(address), words_(words), acyclic_(acyclic_types) {}

    // The words sent from the next cycle on.
    void set_po(std::size_t i, std::uint16_t v) noexcept {
        if (i < words_) po_[i] = v;
    }
    std::uint16_t po(std::size_t i) const noexcept { return i < words_ ? po_[i] : 0; }
    // The words of the last good reply.
    std::uint16_t pi(std::size_t i) const noexcept { return i < words_ ? pi_[i] : 0; }

    // Queues one parameter service; false if one is already waiting or running.
    bool request_parameter(param_channel req) noexcept {
        if (param_state_ != param_state::none && param_state_ != param_state::finished)
            return false;
        param_req_ = req;
        param_state_ = param_state::queued;
        return true;
    }
    bool parameter_done() const noexcept { return param_state_ == param_state::finished; }
    ferrule::error parameter_error() const noexcept { return param_error_; }
    std::uint32_t parameter_value() const noexcept { return param_value_; }

    std::uint32_t cycles() const noexcept { return cycles_; }
    std::uint32_t failed_cycles() const noexcept { return failed_; }
    // Outcome of the last finished cycle.
    ferrule::error error() const noexcept { return last_error_; }

    // --- master_session ----------------------------------------------------------------
    session_action next(time_point now) noexcept {
        session_action a = m_.next(now);
        if (a.what == session_action::kind::done) {
            harvest();
            a = m_.next(now);
        }
        if (a.what == session_action::kind::idle) {
            if (m_.fault_latched()) return session_action::done();
            if (auto ec = start()) {
                last_error_ = ec;
                return session_action::done();
            }
            a = m_.next(now);
        }
        return a;
    }
    void on_receive(std::span<const std::uint8_t> in, time_point now) noexcept {
        m_.on_receive(in, now);
    }
    // The cycle ends with `ec`; error() says so once it is counted, at the next next().
    void on_transport_error(ferrule::error ec) noexcept { m_.on_transport_error(ec); }

private:
    enum class param_state : std::uint8_t { none, queued, running, finished };

    ferrule::error start() noexcept {
        const std::span<const std::uint16_t> po(po_.data(), words_);
        if (param_state_ == param_state::queued) {
            param_state_ = param_state::running;
            return m_.start_parameter(address_, pd_type(words_, true, acyclic_), param_req_, po);
        }
        return m_.start_exchange(address_, pd_type(words_, false, acyclic_), po);
    }

    void harvest() noexcept {
        ++cycles_;
        last_error_ = m_.error();
        const bool ok = !last_error_;
        if (ok)
            for (std::size_t i = 0; i < words_; ++i) pi_[i] = m_.reply().pd[i];
        else
            ++failed_;
        if (param_state_ == param_state::running) {
            param_state_ = param_state::finished;
            param_error_ = last_error_;
            param_value_ = ok ? m_.reply().param.data : 0;
        }
        m_.clear();
    }

    master& m_;
    std::uint8_t address_;
    std::size_t words_;
    bool acyclic_;
    std::array<std::uint16_t, max_pd_words> po_{};
    std::array<std::uint16_t, max_pd_words> pi_{};
    param_channel param_req_{};
    param_state param_state_ = param_state::none;
    ferrule::error param_error_{};
    std::uint32_t param_value_ = 0;
    std::uint32_t cycles_ = 0;
    std::uint32_t failed_ = 0;
    ferrule::error last_error_{};
};

} // namespace ferrule::movilink
