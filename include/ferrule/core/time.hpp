// Time as a parameter. Sessions never read a clock: they are told `now` as a
// ferrule::time_point and answer with deadlines. Streams map their own clock onto it
// (mock_serial: virtual time; host ports: steady_clock; a firmware: its tick counter).
//
// Two representations, chosen at compile time for the whole program:
//   default          int64 nanoseconds since an arbitrary epoch (host, tests): no wrap.
//   FERRULE_TICK_32  a 32-bit unsigned tick of one microsecond, which wraps after 2^32 us
//                    (71.6 minutes), and int32 microsecond durations (at most 35.8 minutes):
//                    on a 32-bit MCU no deadline costs 64-bit arithmetic.
// FERRULE_TICK_32 is a compile definition rather than a config header so that every
// translation unit of a program sees the same time_point (a firmware build defines it for
// all its sources; see examples/firmware/CMakeLists.txt).
//
// With the 32-bit tick, points are compared by their signed difference (before(),
// earliest(), latest()), which is right while the two points are less than half the range
// (35.8 minutes) apart: a session's deadlines are milliseconds to seconds from `now`. What a
// master keeps across transactions, the quiet line before its next request, may be older
// than that when the master has been idle: it is measured as the time elapsed since it was
// set (within(), line_hold), right for up to the whole range. The LECOM poller's due times
// and the PROFIBUS cycle's retry times are points: right while it is stepped at least every
// 35.8 minutes, as a poll loop is.
#pragma once

#include <chrono>
#include <cstdint>

namespace ferrule {

#if defined(FERRULE_TICK_32)

struct session_clock {
    using rep = std::uint32_t;
    using period = std::micro;
    // Durations are signed (a gap can be negative); points wrap, so they are unsigned:
    // point ± duration is computed modulo 2^32.
    using duration = std::chrono::duration<std::int32_t, std::micro>;
    using time_point = std::chrono::time_point<session_clock, std::chrono::duration<rep, period>>;
    static constexpr bool is_steady = true;
};

#else

struct session_clock {
    using rep = std::int64_t;
    using period = std::nano;
    using duration = std::chrono::nanoseconds;
    using time_point = std::chrono::time_point<session_clock>;
    static constexpr bool is_steady = true;
};

#endif

using duration = session_clock::duration;
using time_point = session_clock::time_point;

// "No deadline": what wake_at() and the like answer when nothing is scheduled. With the
// 32-bit tick it is a reserved count that earliest() and latest() know; a function that
// answers a real point through the same channel passes it through scheduled() first.
inline constexpr time_point never = time_point::max();

#if defined(FERRULE_TICK_32)

// a < b: the signed difference, so right across the wrap (see above). Sessions compare time
// points with this rather than `<`, which would compare the raw counts.
constexpr bool before(time_point a, time_point b) noexcept {
    const auto difference = static_cast<std::int32_t>((a - b).count());
    return difference < 0;
}
// The earlier of a and b; `never` is later than every point.
constexpr time_point earliest(time_point a, time_point b) noexcept {
    if (a == never) return b;
    if (b == never) return a;
    return before(b, a) ? b : a;
}
// The later of a and b; `never` is later than every point.
constexpr time_point latest(time_point a, time_point b) noexcept {
    if (a == never || b == never) return never;
    return before(a, b) ? b : a;
}
// A real point t as an answer that may also be `never`: the one count that `never` reserves
// comes once every 71.6 minutes and is answered one microsecond later instead.
constexpr time_point scheduled(time_point t) noexcept {
    return t == never ? t + duration{1} : t;
}
// now lies less than `span` (>= 0) after `from`, measured as the unsigned time elapsed since
// `from`: right for a `from` up to 71.6 minutes back (a session left idle), where before()
// is right up to half of that.
constexpr bool within(time_point now, time_point from, duration span) noexcept {
    return (now - from).count() < static_cast<std::uint32_t>(span.count());
}

#else

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
// A real point as an answer that may also be `never` (no point reaches int64's maximum).
constexpr time_point scheduled(time_point t) noexcept {
    return t;
}
// now lies less than `span` (>= 0) after `from`.
constexpr bool within(time_point now, time_point from, duration span) noexcept {
    return before(now, from + span);
}

#endif

// The quiet line a master keeps before its next request, which outlives the transaction
// that set it: "nothing before end()", kept as when it was set and for how long, so that it
// is over however long the session has been idle since (within()), where a kept point
// compared with before() would read as ahead again once half the 32-bit range has passed.
// Set and extended at `now`, the time the session was told last.
class line_hold {
public:
    constexpr line_hold() noexcept = default;
    // Nothing before from + span.
    constexpr line_hold(time_point from, duration span) noexcept : from_(from), span_(span) {}

    constexpr bool holds(time_point now) const noexcept {
        return span_ != duration::zero() && within(now, from_, span_);
    }
    constexpr time_point end() const noexcept { return from_ + span_; }
    // Nothing before `until` (nothing: when it has passed).
    constexpr void set(time_point now, time_point until) noexcept {
        from_ = now;
        span_ = before(now, until) ? duration(until - now) : duration::zero();
    }
    // Nothing before `until` either.
    constexpr void extend(time_point now, time_point until) noexcept {
        if (!holds(now) || before(end(), until)) set(now, until);
    }
    constexpr void release() noexcept { span_ = duration::zero(); }

private:
    time_point from_{};
    duration span_{};
};

// t (a point or `never`) has come by `now`.
constexpr bool reached(time_point t, time_point now) noexcept {
    return t != never && !before(now, t);
}

#if defined(FERRULE_TICK_32)
// ceil(num / den seconds) at the clock's resolution, for a time that follows from a rate
// (bits at a baud rate), both below 2^32: 1/den s in 1/256 us, rounded up, times num, rounded
// up again; a 32-bit division and a 32 × 32-bit product, no 64-bit division on a 32-bit MCU.
// At most num/256 + 1 us longer than exact, never shorter: no timeout is shorter than the
// manual's.
constexpr duration ceil_seconds(std::uint64_t num, std::uint64_t den) noexcept {
    const auto d = static_cast<std::uint32_t>(den);
    const std::uint32_t unit = (256'000'000u + d - 1) / d;
    const std::uint64_t t = std::uint64_t{static_cast<std::uint32_t>(num)} * unit;
    return duration{static_cast<std::int32_t>((t + 255) >> 8)};
}
#else
// ceil(num / den seconds) at the clock's resolution, for a time that follows from a rate
// (bits at a baud rate): rounded up, so no timeout is shorter than the manual's.
constexpr duration ceil_seconds(std::uint64_t num, std::uint64_t den) noexcept {
    constexpr std::uint64_t per_second = duration::period::den;
    return duration{static_cast<duration::rep>((num * per_second + den - 1) / den)};
}
#endif

} // namespace ferrule
