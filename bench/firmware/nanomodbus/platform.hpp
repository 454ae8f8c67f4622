// nanoMODBUS's platform functions on the board's USART2 (19200 8E1, polling, no interrupt),
// for the images that docs/PERFORMANCE.md sets beside ferrule's firmware examples. nanoMODBUS
// blocks: read() waits up to byte_timeout_ms for each byte (a negative timeout: for ever).
#pragma once

#include <cstdint>

extern "C" {
#include "nanomodbus.h"
}

#include "board.hpp"

namespace bench {

constexpr ferrule::serial_format format{19200, 8, ferrule::parity::even, 1};

inline int32_t read_usart2(uint8_t* buf, uint16_t count, int32_t byte_timeout_ms, void*) {
    auto& u = board::usart<board::usart2_base>();
    for (uint16_t n = 0; n < count; ++n) {
        const std::uint32_t start = board::ticks_ms;
        while (!(u.sr & board::sr_rxne))
            if (byte_timeout_ms >= 0 &&
                board::ticks_ms - start > static_cast<std::uint32_t>(byte_timeout_ms))
                return n;
        buf[n] = static_cast<uint8_t>(u.dr & 0xFFu);
    }
    return count;
}

inline int32_t write_usart2(const uint8_t* buf, uint16_t count, int32_t, void*) {
    auto& u = board::usart<board::usart2_base>();
    for (uint16_t n = 0; n < count; ++n) {
        while (!(u.sr & board::sr_txe)) {
        }
        u.dr = buf[n];
    }
    while (!(u.sr & board::sr_tc)) {
    } // RS-485: release the bus only after the last bit
    return count;
}

inline nmbs_platform_conf usart2_platform() {
    nmbs_platform_conf p;
    nmbs_platform_conf_create(&p);
    p.transport = NMBS_TRANSPORT_RTU;
    p.read = read_usart2;
    p.write = write_usart2;
    return p;
}

} // namespace bench
