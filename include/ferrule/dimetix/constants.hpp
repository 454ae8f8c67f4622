// Dimetix D-Series ASCII protocol: wire constants. Source (see docs/dimetix.md):
//   S1  Dimetix AG, D-Series Laser Distance Sensor, Technical Reference Manual V1.14 (2023)
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>

#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule::dimetix {

using namespace std::chrono_literals;

// Factory communication setting 7: 19200 baud, 7 data bits, even parity, 1 stop bit
// (S1 §6.6 p.35, §8.3.1 p.44).
inline constexpr serial_format default_format{19200, 7, parity::even, 1};

// Device IDs 0..99 on RS-422/485 (S1 §8.3.2 p.44); factory ID 0.
inline constexpr std::uint8_t max_id = 99;

// Every command and every answer ends with CR LF (S1 §8.1.1 p.40).
inline constexpr std::uint8_t cr = 0x0D;
inline constexpr std::uint8_t lf = 0x0A;

// Longest line accepted, CR LF included. The manual sets no limit; the longest documented
// answer is `gNg+00000234+008384+254+000500` (sNuo+301, S1 §8.4.1 p.50): 33 bytes with a
// 2-digit ID. The error stack `gNre+aaa+aaa…` has no documented length: 80 bytes hold 18
// entries, more than the 8 values a reply keeps (reply::truncated says when there were more).
inline constexpr std::size_t max_line_length = 80;
// Longest request: `sNN` + 5-letter mnemonic + 4 parameters of sign + 10 digits + CR LF.
inline constexpr std::size_t max_request_length = 3 + 5 + 4 * 11 + 2;

// A single measurement takes 0.05…4 s (S1 §4.1 p.11): the answer can come 4 s after the
// command plus its transfer time. The manual gives no host timeout; 5 s leaves 1 s margin.
inline constexpr duration measurement_timeout = 5s;
// Configuration and information commands answer without measuring; the manual gives no time
// (dimetix.md §6), 500 ms is a margin for the sensor's processing, configurable.
inline constexpr duration command_timeout = 500ms;

// Sampling time of sNh+ / sNf+ / sNA+ in 1 ms, 0 = as fast as possible (S1 §8.2.4-8.2.5 p.41-42).
inline constexpr std::int32_t max_sampling_time_ms = 86'400'000;

// Buffer status of sNq (S1 §8.2.6 p.42).
enum class buffer_status : std::uint8_t {
    no_new_value = 0, // no new measurement since the last sNq
    new_value = 1,    // one new measurement
    overwritten = 2,  // more than one: older values were overwritten
};

// Device type answered to sNdt / dt by every D-Series sensor (S1 §8.5.3 p.52).
inline constexpr std::int32_t d_series_device_type = 401;
// Generation code in the dg answer: 0x54 = D-Series (S1 §8.5.4 p.53).
inline constexpr std::int32_t d_series_generation = 84;

} // namespace ferrule::dimetix
