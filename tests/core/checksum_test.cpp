#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <string_view>

#include "ferrule/core/checksum.hpp"

namespace {
std::span<const std::uint8_t> ascii(std::string_view s) {
    return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}
} // namespace

TEST_CASE("crc16_modbus check value and a Modbus golden frame", "[core][checksum]") {
    // CRC-16/MODBUS catalogue check value for "123456789".
    CHECK(ferrule::crc16_modbus(ascii("123456789")) == 0x4B37);
    // Read holding registers, slave 1, address 0, 1 register: 01 03 00 00 00 01 84 0A.
    const std::array<std::uint8_t, 6> req{0x01, 0x03, 0x00, 0x00, 0x00, 0x01};
    const auto crc = ferrule::crc16_modbus(req);
    CHECK((crc & 0xFF) == 0x84);
    CHECK((crc >> 8) == 0x0A);
    // Incremental form equals one pass.
    const auto half = ferrule::crc16_modbus(std::span(req).first(3));
    CHECK(ferrule::crc16_modbus(std::span(req).subspan(3), half) == crc);
    static_assert(ferrule::crc16_modbus(std::span<const std::uint8_t>{}) == 0xFFFF);
}

TEST_CASE("xor_bcc check value and the MOVILINK manual telegram", "[core][checksum]") {
    // XOR of "123456789" = 0x31 (CRC catalogue style check value for XOR-8).
    CHECK(ferrule::xor_bcc(ascii("123456789")) == 0x31);
    // SEW SC01 Fig. 20: 02 01 05 00 06 3A 98 01 F4, BCC 57h.
    const std::array<std::uint8_t, 9> t{0x02, 0x01, 0x05, 0x00, 0x06, 0x3A, 0x98, 0x01, 0xF4};
    CHECK(ferrule::xor_bcc(t) == 0x57);
    CHECK(ferrule::xor_bcc({}) == 0x00);
}

TEST_CASE("sum8 check value and wrap-around", "[core][checksum]") {
    // Sum of "123456789" = 477 = 0x1DD -> 0xDD.
    CHECK(ferrule::sum8(ascii("123456789")) == 0xDD);
    const std::array<std::uint8_t, 3> t{0xFF, 0x02, 0x00};
    CHECK(ferrule::sum8(t) == 0x01);
}

TEST_CASE("crc16_modbus: the bitwise and the table-driven form agree", "[core][checksum]") {
    using ferrule::detail::crc16_modbus_bitwise;
    using ferrule::detail::crc16_modbus_table_driven;
    CHECK(crc16_modbus_bitwise(ascii("123456789"), 0xFFFF) == 0x4B37);
    CHECK(crc16_modbus_table_driven(ascii("123456789"), 0xFFFF) == 0x4B37);
    // Every byte value from every starting register value a byte before could leave.
    std::array<std::uint8_t, 1> b{};
    unsigned differ = 0;
    for (unsigned crc = 0; crc < 0x10000; crc += 0x0101)
        for (unsigned v = 0; v < 256; ++v) {
            b[0] = static_cast<std::uint8_t>(v);
            const auto c = static_cast<std::uint16_t>(crc);
            if (crc16_modbus_bitwise(b, c) != crc16_modbus_table_driven(b, c)) ++differ;
        }
    CHECK(differ == 0);
    // A whole RTU frame: the CRC over the frame with its CRC appended is 0.
    const std::array<std::uint8_t, 8> frame{0x01, 0x03, 0x00, 0x00, 0x00, 0x01, 0x84, 0x0A};
    CHECK(crc16_modbus_bitwise(frame, 0xFFFF) == 0);
    CHECK(crc16_modbus_table_driven(frame, 0xFFFF) == 0);
}
