// The transport concept: whatever carries bytes (mock_serial, a pty, a UART HAL,
// an asio port behind an adapter). The stream owns its clock.
#pragma once

#include "ferrule/core/error.hpp"
#include "ferrule/core/time.hpp"
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <span>

namespace ferrule {

struct io_result {
    std::size_t bytes = 0;
    error ec{};
};

template <class S>
concept byte_stream = requires(S& s, std::span<const std::uint8_t> out, std::span<std::uint8_t> in,
                               typename S::time_point deadline) {
    { s.now() } -> std::same_as<typename S::time_point>;
    { s.write(out) } -> std::same_as<io_result>;              // all bytes or an error
    { s.read_some(in, deadline) } -> std::same_as<io_result>; // >= 1 byte, or timeout at deadline
};

// Streams driven by ferrule's drivers express time as ferrule::time_point.
template <class S>
concept session_stream = byte_stream<S> && std::same_as<typename S::time_point, time_point>;

// Optional: drop whatever has been received but not read (stale bytes before a request).
template <class S>
concept discards_input = requires(S& s) {
    s.discard_input();
};

// Optional: wait until everything written has left the transmitter.
template <class S>
concept drains_output = requires(S& s) {
    s.drain();
};

} // namespace ferrule
