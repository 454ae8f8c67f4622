// The device side of a line, sans-I/O: a slave or server (or a simulated device) that hears
// what masters send and answers. Like a master session it reads no clock and owns no port: it
// is told when the bytes it hears ended and asked, with `now`, what to do. Drivers bring the
// I/O: station_driver (core/driver.hpp, a firmware super-loop), host::serve and
// host::pty_server, sim_line (on a mock_serial line).
//
//   s.on_receive(bytes, end)  bytes heard on the line or connection, the last one ended at `end`
//   s.next(now)               one session_action:
//                               send  put `bytes` on the line now, then ask again (a station
//                                     may owe several replies); discard_input is never set
//                               wait  nothing to send before `deadline` (a reply is due then,
//                                     a frame ends by silence, a watchdog runs out)
//                               idle  nothing until more bytes come
//                               done  a request waits for the application (the slaves with the
//                                     application in the loop: has_request(), then respond()
//                                     or consume())
//   cs.wake_at()              when next() wants to be called; `never` when only new bytes
//                             (or the application) can change anything
//
// A station never fails: what it cannot frame or answer it counts and stays silent, as the
// protocols ask of a device. Transport errors end the driver, not the station.
#pragma once

#include <concepts>
#include <cstdint>
#include <span>

#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule {

template <class S>
concept station = requires(S& s, const S& cs, std::span<const std::uint8_t> in, time_point t) {
    s.on_receive(in, t);
    { s.next(t) } -> std::same_as<session_action>;
    { cs.wake_at() } -> std::same_as<time_point>;
};

} // namespace ferrule
