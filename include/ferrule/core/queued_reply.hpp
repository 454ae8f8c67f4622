// A slave's reply waiting for its time on the line: the bytes and when they are due. The
// device side of every protocol answers a request only after a turnaround (MOVILINK's start
// pause, LECOM's processing time t3, Modbus t3.5), and drops the reply when the master moves
// on first; this is that one piece of state and the next() that hands it out.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule {

template <std::size_t Capacity>
class queued_reply {
public:
    // Where the reply is encoded before queue().
    std::span<std::uint8_t, Capacity> buffer() noexcept { return tx_; }
    // The first `size` bytes of buffer() go out at `due`.
    void queue(std::size_t size, time_point due) noexcept {
        size_ = size;
        due_ = due;
        queued_ = true;
    }
    // The master has moved on: the reply is not sent.
    void drop() noexcept { queued_ = false; }
    bool queued() const noexcept { return queued_; }
    // When the reply is due; `never` when none is queued.
    time_point due() const noexcept { return queued_ ? scheduled(due_) : never; }

    // idle: none queued; wait: until it is due; send: the reply, now (and it is no longer
    // queued).
    session_action next(time_point now) noexcept {
        if (!queued_) return session_action::idle();
        if (before(now, due_)) return session_action::wait_until(due_);
        queued_ = false;
        return session_action::send({tx_.data(), size_}, false);
    }

    // next() of a slave with the application in the loop: done while a request waits for
    // the application (`request_waits`), else next(now); a reply handed out is counted in
    // `replies`.
    session_action next(time_point now, bool request_waits, std::uint32_t& replies) noexcept {
        if (request_waits) return session_action::done();
        const session_action a = next(now);
        if (a.what == session_action::kind::send) ++replies;
        return a;
    }

private:
    std::array<std::uint8_t, Capacity> tx_{};
    std::size_t size_ = 0;
    time_point due_{};
    bool queued_ = false;
};

} // namespace ferrule
