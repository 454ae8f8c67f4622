// sim_line: up to N simulated stations on one mock_serial line, as its mock_peer. What every
// protocol's simulated bus (movilink::sim::bus, lecom::sim::bus, modbus::sim::bus) shares:
//
//   * every station hears the master's bytes with their wire timing (on_receive(bytes, end))
//   * a station whose wake_at() has come is asked next(now) until it has nothing more to
//     send (a sensor may owe several lines); what it hands out goes on the line then; the
//     stations do not hear each other's replies
//   * fault knobs act on the next k replies, whichever station sends them (reply_faults)
//
// A Station is a ferrule::station (core/station.hpp); for advance(), it also has advance(now)
// (runs its device model up to `now`). Each protocol's bus adds its own add().
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/session.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/sim/mock_serial.hpp"

namespace ferrule {

template <station Station, std::size_t N>
class sim_line : public mock_peer, public reply_faults {
public:
    std::size_t size() const noexcept { return size_; }
    Station& operator[](std::size_t i) noexcept { return stations_[i]; }
    const Station& operator[](std::size_t i) const noexcept { return stations_[i]; }

    // Runs every station's device model up to `now`.
    void advance(time_point now) noexcept {
        for (auto& st : active()) st.advance(now);
    }

    // --- mock_peer -----------------------------------------------------------------------
    void on_receive(mock_serial&, std::span<const std::uint8_t> bytes, time_point end) override {
        for (auto& st : active()) st.on_receive(bytes, end);
    }

    time_point wake_at() const noexcept override {
        time_point t = never;
        for (const auto& st : active()) t = earliest(t, st.wake_at());
        return t;
    }

    void on_wake(mock_serial& line, time_point now) override {
        for (auto& st : active()) {
            if (!reached(st.wake_at(), now)) continue;
            for (;;) {
                const session_action a = st.next(now);
                if (a.what != session_action::kind::send) break;
                deliver(line, a.bytes, now);
            }
        }
    }

protected:
    // `st` at the end of the line; nullptr when all N places are taken.
    Station* place(const Station& st) {
        if (size_ == N) return nullptr;
        stations_[size_] = st;
        return &stations_[size_++];
    }

private:
    std::span<Station> active() noexcept { return {stations_.data(), size_}; }
    std::span<const Station> active() const noexcept { return {stations_.data(), size_}; }

    std::array<Station, N> stations_; // each default-constructed
    std::size_t size_ = 0;
};

} // namespace ferrule
