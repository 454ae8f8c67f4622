// Checksums used by the protocols in ferrule.
//   xor_bcc      MOVILINK BCC (SEW Serial Communication 11/2001 p.25), LECOM BCC
//   crc16_modbus Modbus RTU CRC (Modbus over Serial Line V1.02 §6.2.2), poly 0xA001 reflected
//   sum8         PROFIBUS FCS (IEC 61158-4-3: arithmetic sum without carry)
//
// crc16_modbus is table-driven (one lookup per byte, a 512-byte table) unless the build
// optimises for size (-Os, which defines __OPTIMIZE_SIZE__): then it shifts bit by bit, eight
// steps per byte and no table, as the firmware examples are built. FERRULE_CRC16_TABLE=1 or
// 0 chooses either way.
#pragma once

#include <array>
#include <cstdint>
#include <span>

namespace ferrule {

constexpr std::uint8_t xor_bcc(std::span<const std::uint8_t> data) noexcept {
    std::uint8_t bcc = 0;
    for (auto b : data) bcc ^= b;
    return bcc;
}

constexpr std::uint8_t sum8(std::span<const std::uint8_t> data) noexcept {
    std::uint8_t sum = 0;
    for (auto b : data) sum = static_cast<std::uint8_t>(sum + b);
    return sum;
}

#ifndef FERRULE_CRC16_TABLE
#ifdef __OPTIMIZE_SIZE__
#define FERRULE_CRC16_TABLE 0
#else
#define FERRULE_CRC16_TABLE 1
#endif
#endif

namespace detail {
// One byte into the CRC, bit by bit (SL §6.2.2's procedure).
constexpr std::uint16_t crc16_modbus_byte(std::uint16_t crc, std::uint8_t b) noexcept {
    crc ^= b;
    for (int k = 0; k < 8; ++k)
        crc = (crc & 1u) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001u)
                         : static_cast<std::uint16_t>(crc >> 1);
    return crc;
}

constexpr std::array<std::uint16_t, 256> make_crc16_modbus_table() noexcept {
    std::array<std::uint16_t, 256> t{};
    for (unsigned i = 0; i < 256; ++i) t[i] = crc16_modbus_byte(0, static_cast<std::uint8_t>(i));
    return t;
}
inline constexpr auto crc16_modbus_table = make_crc16_modbus_table();

constexpr std::uint16_t crc16_modbus_bitwise(std::span<const std::uint8_t> data,
                                             std::uint16_t crc) noexcept {
    for (auto b : data) crc = crc16_modbus_byte(crc, b);
    return crc;
}

constexpr std::uint16_t crc16_modbus_table_driven(std::span<const std::uint8_t> data,
                                                  std::uint16_t crc) noexcept {
    for (auto b : data)
        crc = static_cast<std::uint16_t>((crc >> 8) ^ crc16_modbus_table[(crc ^ b) & 0xFFu]);
    return crc;
}
} // namespace detail

// Incremental form: feed `crc` from a previous call to continue a running CRC.
constexpr std::uint16_t crc16_modbus(std::span<const std::uint8_t> data,
                                     std::uint16_t crc = 0xFFFF) noexcept {
#if FERRULE_CRC16_TABLE
    return detail::crc16_modbus_table_driven(data, crc);
#else
    return detail::crc16_modbus_bitwise(data, crc);
#endif
}

} // namespace ferrule
