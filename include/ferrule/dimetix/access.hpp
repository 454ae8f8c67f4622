// Blocking Dimetix access over any byte_stream: one call, one command, driven by
// ferrule::run(). For a non-blocking main loop use sensor + poll_driver.
#pragma once

#include <cstdint>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/dimetix/command.hpp"
#include "ferrule/dimetix/reply.hpp"
#include "ferrule/dimetix/sensor.hpp"

namespace ferrule::dimetix {

// Any command; the answer as check_answers() accepted it (ID and mnemonic of `c`).
template <session_stream S>
result<reply> transact(S& stream, sensor& s, const command& c) {
    if (auto ec = s.start(c)) return ec;
    if (auto ec = run(stream, s)) return ec;
    return s.reply();
}

// sNc until gN? (S1 §8.2.1; the paper's start-up), up to connect_attempts times.
template <session_stream S>
ferrule::error connect(S& stream, sensor& s, std::uint8_t id) {
    if (auto ec = s.start_connect(id)) return ec;
    return run(stream, s);
}

// Single distance measurement sNg (S1 §8.2.2): distance in 0.1 mm, plus signal, temperature
// and speed when the user output format (sNuo 300 / 301) carries them.
template <session_stream S>
result<measurement> measure(S& stream, sensor& s, std::uint8_t id) {
    const auto r = transact(stream, s, distance(id));
    if (!r) return r.error();
    return measurement_of(*r);
}

// Sensor temperature sNt in 0.1 °C (S1 §8.2.8).
template <session_stream S>
result<std::int32_t> temperature(S& stream, sensor& s, std::uint8_t id) {
    const auto r = transact(stream, s, dimetix::temperature(id));
    if (!r) return r.error();
    return r->values[0];
}

// Relative signal strength sNm+0, typ. 0…25 000 (S1 §8.2.7).
template <session_stream S>
result<std::int32_t> signal_strength(S& stream, sensor& s, std::uint8_t id) {
    const auto r = transact(stream, s, signal(id, false));
    if (!r) return r.error();
    return r->values[0];
}

// sNf+t: tracking into the one-value buffer, read with read_buffer() (S1 §8.2.5).
template <session_stream S>
ferrule::error start_buffered_tracking(S& stream, sensor& s, std::uint8_t id,
                                       std::int32_t sampling_ms) {
    return transact(stream, s, tracking_buffered(id, sampling_ms)).error();
}

struct buffered_distance {
    std::int32_t distance = 0; // 0.1 mm
    buffer_status status = buffer_status::no_new_value;
};

// sNq (S1 §8.2.6). A device error (e.g. @E210 without sNf) keeps its buffer status in
// s.reply().buffer_status.
template <session_stream S>
result<buffered_distance> read_buffer(S& stream, sensor& s, std::uint8_t id) {
    const auto r = transact(stream, s, dimetix::read_buffer(id));
    if (!r) return r.error();
    return buffered_distance{r->values[0], static_cast<buffer_status>(r->buffer_status)};
}

// sNc: stops tracking / measuring, laser off (S1 §8.2.1).
template <session_stream S>
ferrule::error stop(S& stream, sensor& s, std::uint8_t id) {
    return transact(stream, s, stop_clear(id)).error();
}

// sNo: laser on as a pointing aid until sNc (S1 §8.2.10).
template <session_stream S>
ferrule::error laser_on(S& stream, sensor& s, std::uint8_t id) {
    return transact(stream, s, dimetix::laser_on(id)).error();
}

// sNre: the stored error codes, newest first; 0 = no error, 200 = boot marker (S1 §8.2.9).
template <session_stream S>
result<reply> read_error_stack(S& stream, sensor& s, std::uint8_t id) {
    return transact(stream, s, dimetix::read_error_stack(id));
}

// sNce (S1 §8.2.9).
template <session_stream S>
ferrule::error clear_error_stack(S& stream, sensor& s, std::uint8_t id) {
    return transact(stream, s, dimetix::clear_error_stack(id)).error();
}

} // namespace ferrule::dimetix
