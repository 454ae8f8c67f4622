// A simulated Modbus RTU (RS-485) line: up to N stations, each a modbus::server with a
// simulated VFD behind it, as the mock_peer of a mock_serial (the gateway paper's set-up,
// seeds/002: a PLC's requests reach VFDs over Modbus RTU).
//
//   * every station hears the client's bytes; the addressed one executes the request when its
//     last character has arrived and puts the reply on the line t3.5 + processing_time later
//     (Modbus over Serial Line V1.02 §2.5.1.1); a broadcast is executed by all, answered by
//     none
//   * the stations do not hear each other's replies
//   * fault knobs act on the next k replies, whichever station sends them: drop the reply
//     (the client sees a timeout), flip bits of one byte (a CRC error), or send it later
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/mock_serial.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/modbus/sim_station.hpp"

namespace ferrule::modbus::sim {

// Fault knobs (drop / corrupt / delay the next replies): see ferrule::reply_faults.
template <std::size_t N>
class bus final : public mock_peer, public reply_faults {
public:
    // A station at the end of the line answering `cfg.units`; nullptr when all N places are
    // taken.
    station* add(const server_config& cfg = {}) {
        if (size_ == N) return nullptr;
        station& st = stations_[size_++];
        st = station(cfg);
        return &st;
    }

    std::size_t size() const noexcept { return size_; }
    station& operator[](std::size_t i) noexcept { return stations_[i]; }
    const station& operator[](std::size_t i) const noexcept { return stations_[i]; }

    // Runs every drive's speed model up to `now`.
    void advance(time_point now) noexcept {
        for (auto& st : active()) st.drive().advance(now);
    }

    // --- mock_peer -----------------------------------------------------------------------
    void on_receive(mock_serial&, std::span<const std::uint8_t> bytes, time_point end) override {
        for (auto& st : active()) st.on_receive(bytes, end);
    }

    time_point wake_at() const noexcept override {
        time_point t = never;
        for (const auto& st : active()) t = std::min(t, st.wake_at());
        return t;
    }

    void on_wake(mock_serial& line, time_point now) override {
        for (auto& st : active()) {
            if (st.wake_at() > now) continue;
            const session_action a = st.next(now);
            if (a.what == session_action::kind::send) deliver(line, a.bytes, now);
        }
    }

private:
    std::span<station> active() noexcept { return {stations_.data(), size_}; }
    std::span<const station> active() const noexcept { return {stations_.data(), size_}; }

    std::array<station, N> stations_{};
    std::size_t size_ = 0;
};

} // namespace ferrule::modbus::sim
