// idle_watch: closes what has been silent too long — a server connection whose peer has sent
// nothing for `timeout` (Modbus TCP guide §4.2.1; an MP controller's idle channels). touch()
// on every activity; start() once. The timer rests at the last activity + timeout and checks
// again when it fires, so activity costs no timer call.
#pragma once

#include <asio/any_io_executor.hpp>
#include <asio/steady_timer.hpp>

#include <chrono>
#include <system_error>
#include <utility>

#include "ferrule/asio/serial_stream.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule::host {

class idle_watch {
public:
    explicit idle_watch(const ::asio::any_io_executor& ex) : timer_(ex) {}

    void touch() noexcept { last_ = steady_now(); }
    time_point last() const noexcept { return last_; }

    // Calls on_idle() once nothing has touched the watch for `timeout` (zero: never);
    // `keep_alive` (the owner's shared_ptr) rides along the timer's wait.
    template <class KeepAlive, class OnIdle>
    void start(duration timeout, KeepAlive keep_alive, OnIdle on_idle) {
        if (timeout == duration::zero()) return;
        timer_.expires_after(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
            last_ + timeout - steady_now()));
        timer_.async_wait([this, timeout, keep_alive, on_idle](std::error_code e) mutable {
            if (e) return;
            if (steady_now() - last_ >= timeout) return on_idle();
            start(timeout, std::move(keep_alive), std::move(on_idle));
        });
    }

    void cancel() { timer_.cancel(); }

private:
    ::asio::steady_timer timer_;
    time_point last_{};
};

} // namespace ferrule::host
