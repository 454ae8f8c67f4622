// Checksums used by the protocols in ferrule.
//   xor_bcc      MOVILINK BCC (SEW Serial Communication 11/2001 p.25), LECOM BCC
//   crc16_modbus Modbus RTU CRC (Modbus over Serial Line V1.02 §6.2.2), poly 0xA001 reflected
//   sum8         PROFIBUS FCS (IEC 61158-4-3: arithmetic sum without carry)
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

namespace detail {
constexpr std::array<std::uint16_t, 256> make_crc16_modbus_table() noexcept {
    std::array<std::uint16_t, 256> t{};
    for (unsigned i = 0; i < 256; ++i) {
        std::uint16_t c = static_cast<std::uint16_t>(i);
        for (int k = 0; k < 8; ++k)
            c = (c & 1u) ? static_cast<std::uint16_t>((c >> 1) ^ 0xA001u)
                         : static_cast<std::uint16_t>(c >> 1);
        t[i] = c;
    }
    return t;
}
inline constexpr auto crc16_modbus_table = make_crc16_modbus_table();
} // namespace detail

// Incremental form: feed `crc` from a previous call to continue a running CRC.
constexpr std::uint16_t crc16_modbus(std::span<const std::uint8_t> data,
                                     std::uint16_t crc = 0xFFFF) noexcept {
    for (auto b : data)
        crc =
            static_cast<std::uint16_t>((crc >> 8) ^ detail::crc16_modbus_table[(crc ^ b) & 0xFFu]);
    return crc;
}

} // namespace ferrule
