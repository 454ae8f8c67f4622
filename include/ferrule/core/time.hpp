// Time as a parameter. Sessions never read a clock: they are told `now` as a
// ferrule::time_point (nanoseconds since an arbitrary epoch) and answer with deadlines.
// Streams map their own clock onto it (mock_serial: virtual time; host ports: steady_clock).
#pragma once

#include <chrono>
#include <cstdint>

namespace ferrule {

struct session_clock {
    using rep = std::int64_t;
    using period = std::nano;
    using duration = std::chrono::nanoseconds;
    using time_point = std::chrono::time_point<session_clock>;
    static constexpr bool is_steady = true;
};

using duration = session_clock::duration;
using time_point = session_clock::time_point;

inline constexpr time_point never = time_point::max();

// a < b. Sessions compare time points with this rather than `<`: for time_point, C++20 picks
// std::chrono's constrained operator<=>, which GCC at -Os (Cortex-M) calls out of line at
// every comparison; comparing the counts is a few inline instructions (120 B less in the
// Modbus client).
constexpr bool before(time_point a, time_point b) noexcept {
    return a.time_since_epoch().count() < b.time_since_epoch().count();
}
// The earlier of a and b.
constexpr time_point earliest(time_point a, time_point b) noexcept {
    return before(b, a) ? b : a;
}
// The later of a and b.
constexpr time_point latest(time_point a, time_point b) noexcept {
    return before(a, b) ? b : a;
}

} // namespace ferrule
