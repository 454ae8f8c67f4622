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

} // namespace ferrule
