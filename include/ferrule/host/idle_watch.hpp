// idle_watch: how long a server connection's peer keeps the server waiting, and the end of the
// wait. Two limits, each zero for none:
//
//   * idle_timeout, counted from the last complete request (from the start before the first):
//     the server may close connections it considers idle (Modbus TCP guide §4.2.1)
//   * request_timeout, counted from the first byte of a request not yet complete, so that a
//     peer sending a byte now and then holds no connection: bytes alone never reset a limit
//
// The owner says begun() when a byte of a request comes (while one is under way, that
// changes nothing), completed() when a request is complete, and start()s the watch once. Its
// timer rests at the nearest deadline, never more than request_timeout ahead, so neither call
// costs a timer call: a request that begins later has a later deadline than the one the timer
// rests at.
#pragma once

#include <asio/any_io_executor.hpp>
#include <asio/steady_timer.hpp>

#include <chrono>
#include <cstdint>
#include <system_error>
#include <utility>

#include "ferrule/host/serial_stream.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule::host {

// The time limits of a server connection (zero: none).
struct connection_limits {
    duration idle_timeout{};
    duration request_timeout{};
};

class idle_watch {
public:
    enum class expiry : std::uint8_t { idle, request };

    explicit idle_watch(const ::asio::any_io_executor& ex) : timer_(ex) {}

    void begun() noexcept {
        if (in_request_) return;
        in_request_ = true;
        first_byte_ = steady_now();
    }
    void completed() noexcept {
        in_request_ = false;
        last_request_ = steady_now();
    }

    // Calls on_expiry(expiry) once a limit is passed; `keep_alive` (the owner's shared_ptr)
    // rides along the timer's wait.
    template <class KeepAlive, class OnExpiry>
    void start(const connection_limits& limits, KeepAlive keep_alive, OnExpiry on_expiry) {
        limits_ = limits;
        last_request_ = steady_now();
        if (limits_.idle_timeout == duration::zero() && limits_.request_timeout == duration::zero())
            return;
        wait(std::move(keep_alive), std::move(on_expiry));
    }

    void cancel() { timer_.cancel(); }

private:
    // The limit passed at `now`, if any.
    bool passed(time_point now, expiry& which) const noexcept {
        const bool request_limit = limits_.request_timeout != duration::zero();
        if (request_limit && in_request_ && !before(now, first_byte_ + limits_.request_timeout)) {
            which = expiry::request;
            return true;
        }
        const bool idle_limit = limits_.idle_timeout != duration::zero();
        which = expiry::idle;
        return idle_limit && !before(now, last_request_ + limits_.idle_timeout);
    }

    // When to look again: the nearest deadline, and no later than a request beginning now
    // would need.
    time_point next_look(time_point now) const noexcept {
        time_point at = never;
        if (limits_.request_timeout != duration::zero())
            at = (in_request_ ? first_byte_ : now) + limits_.request_timeout;
        if (limits_.idle_timeout != duration::zero())
            at = earliest(at, last_request_ + limits_.idle_timeout);
        return at;
    }

    template <class KeepAlive, class OnExpiry>
    void wait(KeepAlive keep_alive, OnExpiry on_expiry) {
        const time_point now = steady_now();
        timer_.expires_after(
            std::chrono::duration_cast<std::chrono::steady_clock::duration>(next_look(now) - now));
        timer_.async_wait([this, keep_alive, on_expiry](std::error_code e) mutable {
            if (e) return;
            expiry which{};
            if (passed(steady_now(), which)) return on_expiry(which);
            wait(std::move(keep_alive), std::move(on_expiry));
        });
    }

    ::asio::steady_timer timer_;
    connection_limits limits_{};
    time_point last_request_{};
    time_point first_byte_{};
    bool in_request_ = false;
};

} // namespace ferrule::host
