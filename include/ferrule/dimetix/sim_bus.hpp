// A simulated RS-422/485 line with up to N D-Series sensors, as the mock_peer of a
// mock_serial (S1 §5.8: up to 100 devices with distinct IDs on one line).
//
//   * every sensor hears the host's bytes; the addressed one answers when its answer is due
//   * the sensors do not hear each other
//   * fault knobs act on the next k answer lines, whichever sensor sends them: drop the
//     line (the host sees a timeout), flip bits of one byte, or send it later
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/mock_serial.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/dimetix/constants.hpp"
#include "ferrule/dimetix/sim_sensor.hpp"

namespace ferrule::dimetix::sim {

// Fault knobs (drop / corrupt / delay the next replies): see ferrule::reply_faults.
template <std::size_t N>
class bus final : public mock_peer, public reply_faults {
public:
    // A sensor on the line; nullptr when all N places are taken.
    d_series* add(const d_series_config& cfg = {}) {
        if (size_ == N) return nullptr;
        sensors_[size_] = d_series(cfg);
        return &sensors_[size_++];
    }

    std::size_t size() const noexcept { return size_; }
    d_series& operator[](std::size_t i) noexcept { return sensors_[i]; }
    const d_series& operator[](std::size_t i) const noexcept { return sensors_[i]; }

    // Power cycle of every sensor: each sends its startup string gN? (S1 §8.1.5).
    void power_on(time_point now) noexcept {
        for (auto& s : active()) s.power_on(now);
    }

    // --- mock_peer -----------------------------------------------------------------------
    void on_receive(mock_serial&, std::span<const std::uint8_t> bytes, time_point end) override {
        for (auto& s : active()) s.on_receive(bytes, end);
    }

    time_point wake_at() const noexcept override {
        time_point t = never;
        for (const auto& s : active()) t = std::min(t, s.wake_at());
        return t;
    }

    void on_wake(mock_serial& line, time_point now) override {
        for (auto& s : active()) {
            for (;;) {
                const session_action a = s.next(now);
                if (a.what != session_action::kind::send) break;
                deliver(line, a.bytes, now);
            }
        }
    }

private:
    std::span<d_series> active() noexcept { return {sensors_.data(), size_}; }
    std::span<const d_series> active() const noexcept { return {sensors_.data(), size_}; }

    std::array<d_series, N> sensors_;
    std::size_t size_ = 0;
};

} // namespace ferrule::dimetix::sim
