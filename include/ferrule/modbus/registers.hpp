// Typed values in Modbus registers. A register is 16 bits, sent big-endian (AP §4.2); how a
// 32-bit value spreads over two registers is each device's choice. With the value's bytes
// A B C D (A most significant):
//   abcd  register 0 = AB, register 1 = CD   (big-endian, "high word first")
//   badc  register 0 = BA, register 1 = DC   (bytes swapped in each word)
//   cdab  register 0 = CD, register 1 = AB   (low word first; common on PLCs)
//   dcba  register 0 = DC, register 1 = BA   (little-endian)
// For a 16-bit value (bytes A B) badc and dcba swap its bytes, abcd and cdab keep them.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/bytes.hpp"

namespace ferrule::modbus {

enum class word_order : std::uint8_t { abcd, badc, cdab, dcba };

namespace detail {
constexpr std::uint16_t swap_bytes(std::uint16_t v) noexcept {
    return static_cast<std::uint16_t>((v >> 8) | (v << 8));
}
constexpr bool swaps_bytes(word_order o) noexcept {
    return o == word_order::badc || o == word_order::dcba;
}
constexpr bool swaps_words(word_order o) noexcept {
    return o == word_order::cdab || o == word_order::dcba;
}
} // namespace detail

// Register `index` of big-endian register bytes (response::data of FC 3, 4, 23).
constexpr std::uint16_t register_at(std::span<const std::uint8_t> data,
                                    std::size_t index) noexcept {
    return load_be16(&data[2 * index]);
}
// Writes register `index` into big-endian register bytes (request::data of FC 16, 23).
constexpr void put_register(std::span<std::uint8_t> data, std::size_t index,
                            std::uint16_t value) noexcept {
    store_be16(&data[2 * index], value);
}

// --- 16 bits ---------------------------------------------------------------------------------
constexpr std::uint16_t to_u16(std::uint16_t reg, word_order o = word_order::abcd) noexcept {
    return detail::swaps_bytes(o) ? detail::swap_bytes(reg) : reg;
}
constexpr std::int16_t to_i16(std::uint16_t reg, word_order o = word_order::abcd) noexcept {
    return static_cast<std::int16_t>(to_u16(reg, o));
}
constexpr std::uint16_t from_u16(std::uint16_t v, word_order o = word_order::abcd) noexcept {
    return to_u16(v, o); // its own inverse
}
constexpr std::uint16_t from_i16(std::int16_t v, word_order o = word_order::abcd) noexcept {
    return from_u16(static_cast<std::uint16_t>(v), o);
}

// --- 32 bits: two registers, r0 sent first -------------------------------------------------
constexpr std::uint32_t to_u32(std::uint16_t r0, std::uint16_t r1,
                               word_order o = word_order::abcd) noexcept {
    if (detail::swaps_bytes(o)) {
        r0 = detail::swap_bytes(r0);
        r1 = detail::swap_bytes(r1);
    }
    const std::uint16_t hi = detail::swaps_words(o) ? r1 : r0;
    const std::uint16_t lo = detail::swaps_words(o) ? r0 : r1;
    return std::uint32_t{hi} << 16 | lo;
}
constexpr std::int32_t to_i32(std::uint16_t r0, std::uint16_t r1,
                              word_order o = word_order::abcd) noexcept {
    return static_cast<std::int32_t>(to_u32(r0, r1, o));
}
constexpr float to_f32(std::uint16_t r0, std::uint16_t r1,
                       word_order o = word_order::abcd) noexcept {
    return std::bit_cast<float>(to_u32(r0, r1, o));
}

// The two registers of `v`, r0 first.
constexpr std::array<std::uint16_t, 2> from_u32(std::uint32_t v,
                                                word_order o = word_order::abcd) noexcept {
    auto hi = static_cast<std::uint16_t>(v >> 16);
    auto lo = static_cast<std::uint16_t>(v);
    if (detail::swaps_bytes(o)) {
        hi = detail::swap_bytes(hi);
        lo = detail::swap_bytes(lo);
    }
    if (detail::swaps_words(o)) return {lo, hi};
    return {hi, lo};
}
constexpr std::array<std::uint16_t, 2> from_i32(std::int32_t v,
                                                word_order o = word_order::abcd) noexcept {
    return from_u32(static_cast<std::uint32_t>(v), o);
}
constexpr std::array<std::uint16_t, 2> from_f32(float v, word_order o = word_order::abcd) noexcept {
    return from_u32(std::bit_cast<std::uint32_t>(v), o);
}

} // namespace ferrule::modbus
