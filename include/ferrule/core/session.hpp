// What a sans-I/O master session asks of its driver. A session is told `now` and the
// bytes that arrived; it answers with one action: send these bytes, wait (for bytes or
// until a deadline), or "done" (the transaction's result is ready).
#pragma once

#include <concepts>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule {

struct session_action {
    enum class kind : std::uint8_t {
        idle, // no transaction started
        send, // write `bytes` now (drop stale input first if `discard_input`)
        wait, // read until `deadline`; hand any bytes to on_receive(), then ask again
        done, // the transaction has finished; its result is in the session
    };
    kind what = kind::idle;
    bool discard_input = false;
    time_point deadline{}; // kind::wait only
    std::span<const std::uint8_t> bytes{};

    static constexpr session_action idle() noexcept { return {}; }
    static constexpr session_action done() noexcept { return {kind::done}; }
    static constexpr session_action wait_until(time_point t) noexcept {
        return {kind::wait, false, t, {}};
    }
    static constexpr session_action send(std::span<const std::uint8_t> b,
                                         bool discard_first) noexcept {
        return {kind::send, discard_first, {}, b};
    }
};

template <class M>
concept master_session = requires(M& m, time_point t, std::span<const std::uint8_t> in,
                                  ferrule::error ec) {
    { m.next(t) } -> std::same_as<session_action>;
    m.on_receive(in, t);
    m.on_transport_error(ec);
    { m.error() } -> std::same_as<ferrule::error>; // the finished transaction's outcome
};

} // namespace ferrule
