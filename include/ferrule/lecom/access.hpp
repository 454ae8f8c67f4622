// Blocking LECOM access over any byte_stream: one call, one transaction, driven by
// ferrule::run(). For a non-blocking main loop use master + poll_driver, or poller.
#pragma once

#include <cstdint>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/lecom/code.hpp"
#include "ferrule/lecom/master.hpp"
#include "ferrule/lecom/value.hpp"

namespace ferrule::lecom {

// RECEIVE: the value of code `c` of drive `address` (01…99, not x0).
template <session_stream S>
result<value> read(S& stream, master& m, std::uint8_t address, code_address c) {
    if (auto ec = m.start_read(address, c)) return ec;
    if (auto ec = run(stream, m)) return ec;
    return m.reply().value;
}

// SEND: writes `v` to code `c`. A write to 00 or x0 reaches a group and is not acknowledged
// (S1 p.8-24): it returns {} once the drives' processing time has passed.
template <session_stream S>
ferrule::error write(S& stream, master& m, std::uint8_t address, code_address c, const value& v) {
    if (auto ec = m.start_write(address, c, v)) return ec;
    const ferrule::error ec = run(stream, m);
    if (ec == errc::no_response_expected) return {};
    return ec;
}

} // namespace ferrule::lecom
