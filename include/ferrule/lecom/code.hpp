// LECOM code addresses (S1 p.8-16…8-18, S2 §5.3):
//
//   standard   C1 C2, codes 0…6229 by the "790 rule":
//                a = code % 790, k = code / 790, C1 = '0' + a / 10, C2 = '0' + a % 10 + 10 k
//              (111 → ";1", 1002 → "E<"); no subcode
//   extended   '!' CH1…CH4 SC1 SC2: code 0…65535 and subcode 0…255 in upper-case hex
//              (1002 / 0 → "!03EA00")
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/lecom/constants.hpp"

namespace ferrule::lecom {

// The documented range of standard addressing; 6229 already gives C2 = 0x7F (lecom.md §1.7).
inline constexpr std::uint16_t max_standard_code = 6229;
inline constexpr std::size_t standard_code_length = 2;
inline constexpr std::size_t extended_code_length = 7;

struct code_address {
    std::uint16_t code = 0;
    std::uint8_t subcode = 0;
    bool extended = false;

    constexpr std::size_t length() const noexcept {
        return extended ? extended_code_length : standard_code_length;
    }
    friend constexpr bool operator==(const code_address&, const code_address&) = default;
};

// Code `c` the way simple drivers write it: standard addressing up to 6229, extended above.
constexpr code_address code(std::uint16_t c) noexcept {
    return {c, 0, c > max_standard_code};
}
constexpr code_address extended_code(std::uint16_t c, std::uint8_t subcode) noexcept {
    return {c, subcode, true};
}

// Can `a` be written? Standard addressing has no subcode and ends at 6229.
constexpr bool is_valid(const code_address& a) noexcept {
    return a.extended || (a.code <= max_standard_code && a.subcode == 0);
}

namespace detail {
// Upper-case hex digit of the nibble n (0…15).
constexpr std::uint8_t hex_digit(unsigned n) noexcept {
    return static_cast<std::uint8_t>(n < 10 ? '0' + n : 'A' + n - 10);
}

// Upper-case hex digit value, or -1 (S1 p.8-18 shows only `A-F`).
constexpr int hex_value(std::uint8_t c) noexcept {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}
} // namespace detail

// Writes the code field (2 or 7 bytes) to `out`; precondition is_valid(a), out.size() >= length.
constexpr std::size_t encode_code(const code_address& a, std::uint8_t* out) noexcept {
    if (!a.extended) {
        const unsigned rest = a.code % 790u;
        const unsigned block = a.code / 790u;
        out[0] = static_cast<std::uint8_t>('0' + rest / 10);
        out[1] = static_cast<std::uint8_t>('0' + rest % 10 + 10 * block);
        return standard_code_length;
    }
    out[0] = extended_mark;
    const std::uint32_t v = std::uint32_t{a.code} << 8 | a.subcode; // CCCCSS
    for (int i = 0; i < 6; ++i) out[1 + i] = detail::hex_digit((v >> (20 - 4 * i)) & 0xF);
    return extended_code_length;
}

namespace detail {
// Reads the code field at the start of `in` into `a`; false if there is none.
constexpr bool read_code(std::span<const std::uint8_t> in, code_address& a) noexcept {
    if (!in.empty() && in[0] == extended_mark) {
        if (in.size() < extended_code_length) return false;
        unsigned v = 0;
        for (std::size_t i = 1; i < extended_code_length; ++i) {
            const int d = hex_value(in[i]);
            if (d < 0) return false;
            v = v << 4 | static_cast<unsigned>(d);
        }
        a = {static_cast<std::uint16_t>(v >> 8), static_cast<std::uint8_t>(v & 0xFF), true};
        return true;
    }
    if (in.size() < standard_code_length) return false;
    // C1 '0'…'N' (tens of code % 790: 0…78), C2 '0'…0x7F (units + 10 × block).
    if (in[0] < '0' || in[0] > '0' + 78 || in[1] < '0' || in[1] > 0x7F) return false;
    const unsigned t = in[0] - '0';
    const unsigned u = in[1] - '0';
    const unsigned c = (u / 10) * 790 + t * 10 + u % 10;
    if (c > max_standard_code) return false;
    a = {static_cast<std::uint16_t>(c), 0, false};
    return true;
}
} // namespace detail

// Reads a code field at the start of `in`: `!` + 6 hex digits, else two characters.
// The number of bytes it took is a.length().
inline result<code_address> parse_code(std::span<const std::uint8_t> in) noexcept {
    code_address a;
    if (!detail::read_code(in, a)) return errc::malformed;
    return a;
}

} // namespace ferrule::lecom
