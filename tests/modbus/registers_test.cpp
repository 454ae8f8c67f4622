// Typed register values in the four word orders, both ways.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>

#include "ferrule/modbus/registers.hpp"

using namespace ferrule::modbus;
using regs = std::array<std::uint16_t, 2>;

TEST_CASE("modbus u32 and i32 in the four word orders", "[modbus][registers]") {
    const std::uint32_t v = 0x12345678; // A=12 B=34 C=56 D=78
    CHECK(from_u32(v, word_order::abcd) == regs{0x1234, 0x5678});
    CHECK(from_u32(v, word_order::badc) == regs{0x3412, 0x7856});
    CHECK(from_u32(v, word_order::cdab) == regs{0x5678, 0x1234});
    CHECK(from_u32(v, word_order::dcba) == regs{0x7856, 0x3412});
    for (auto o : {word_order::abcd, word_order::badc, word_order::cdab, word_order::dcba}) {
        const auto r = from_u32(v, o);
        CHECK(to_u32(r[0], r[1], o) == v);
        const auto n = from_i32(-123456789, o);
        CHECK(to_i32(n[0], n[1], o) == -123456789);
    }
    CHECK(from_u32(v) == regs{0x1234, 0x5678});
    CHECK(to_i32(0xFFFF, 0xFFFE) == -2);
    CHECK(to_i32(0xFFFE, 0xFFFF, word_order::cdab) == -2);
}

TEST_CASE("modbus float in the four word orders", "[modbus][registers]") {
    // 1.0f = 0x3F800000; -2.5f = 0xC0200000.
    CHECK(from_f32(1.0f, word_order::abcd) == regs{0x3F80, 0x0000});
    CHECK(from_f32(1.0f, word_order::badc) == regs{0x803F, 0x0000});
    CHECK(from_f32(1.0f, word_order::cdab) == regs{0x0000, 0x3F80});
    CHECK(from_f32(1.0f, word_order::dcba) == regs{0x0000, 0x803F});
    CHECK(to_f32(0x0000, 0x20C0, word_order::dcba) == -2.5f);
    for (auto o : {word_order::abcd, word_order::badc, word_order::cdab, word_order::dcba}) {
        const auto r = from_f32(3.14159f, o);
        CHECK(to_f32(r[0], r[1], o) == 3.14159f);
    }
    static_assert(to_f32(0x3F80, 0x0000) == 1.0f);
}

TEST_CASE("modbus u16 and i16: byte-swapped orders swap the register's bytes",
          "[modbus][registers]") {
    CHECK(to_u16(0x1234) == 0x1234);
    CHECK(to_u16(0x1234, word_order::cdab) == 0x1234);
    CHECK(to_u16(0x1234, word_order::badc) == 0x3412);
    CHECK(to_u16(0x1234, word_order::dcba) == 0x3412);
    CHECK(to_i16(0xFFFE) == -2);
    CHECK(to_i16(0xFEFF, word_order::badc) == -2);
    CHECK(from_i16(-2) == 0xFFFE);
    CHECK(from_i16(-2, word_order::dcba) == 0xFEFF);
    CHECK(from_u16(0xABCD, word_order::badc) == 0xCDAB);
}

TEST_CASE("modbus register bytes are big-endian", "[modbus][registers]") {
    std::array<std::uint8_t, 4> data{};
    put_register(data, 0, 0x1234);
    put_register(data, 1, 0xABCD);
    CHECK(data == std::array<std::uint8_t, 4>{0x12, 0x34, 0xAB, 0xCD});
    CHECK(register_at(data, 1) == 0xABCD);
    CHECK(to_u32(register_at(data, 0), register_at(data, 1)) == 0x1234ABCD);
}
