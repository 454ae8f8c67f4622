// LECOM parameter values V1…Vn (S1 p.8-18/8-19, S2 §5.4):
//
//   VD  decimal      [-]d…d[.d…d]  up to 6 integer and 4 decimal digits, -214748.3648 …
//                    214748.3647; no point without decimals; kept as FIX32 (value × 10⁴)
//   VH  hex          'H' + 2, 4 or 8 upper-case hex digits (byte, word, dword)
//   VS  string       'S' + visible ASCII; the drive only sends them (e.g. C200)
//   VO  octet string 'O' + one hex digit per nibble, high nibble first
//
// No floating point: decimal values are integers scaled by 10⁴, as Lenze's FIX32 type is.
// The same text is what a user types, so parse_value() also reads command-line input.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/lecom/code.hpp"

namespace ferrule::lecom {

enum class value_format : std::uint8_t { decimal, hex, string, octets };

struct value {
    static constexpr std::int32_t scale = 10'000; // FIX32: four decimal places
    static constexpr std::uint8_t max_decimals = 4;
    static constexpr std::uint8_t max_integer_digits = 6;
    // The manual gives both 12 and 20 characters for VS (lecom.md §1.10): take the larger.
    static constexpr std::size_t max_string = 20;
    static constexpr std::size_t max_octets = 16;

    value_format format = value_format::decimal;
    std::int32_t fixed = 0;                       // decimal: value × 10⁴
    std::uint32_t hex = 0;                        // hex
    std::uint8_t digits = 0;                      // decimal: digits after the point; hex: 2, 4 or 8
    std::array<std::uint8_t, max_string> bytes{}; // string characters or octets
    std::uint8_t size = 0;

    constexpr std::span<const std::uint8_t> data() const noexcept { return {bytes.data(), size}; }
    std::string_view text() const noexcept {
        return {reinterpret_cast<const char*>(bytes.data()), size};
    }
    // Integer part of a decimal value (truncated towards zero).
    constexpr std::int32_t whole() const noexcept { return fixed / scale; }

    friend constexpr bool operator==(const value&, const value&) = default;
};

// Decimal digits a FIX32 number needs: 35.4 needs 1, 35 none.
constexpr std::uint8_t needed_decimals(std::int32_t fixed) noexcept {
    std::uint8_t need = value::max_decimals;
    for (std::int32_t f = fixed % value::scale; need > 0 && f % 10 == 0; f /= 10) --need;
    return need;
}

// VD from a FIX32 number; `decimals` digits are written (at least as many as needed).
constexpr value decimal_fixed(std::int32_t fixed, std::uint8_t decimals = 0) noexcept {
    value v;
    v.fixed = fixed;
    v.digits = decimals > value::max_decimals ? value::max_decimals : decimals;
    return v;
}

// VD from a whole number; empty if beyond ±214748.
inline result<value> decimal(std::int32_t whole) noexcept {
    if (whole > 214748 || whole < -214748) return errc::invalid_argument;
    return decimal_fixed(whole * value::scale);
}

// VH with 2, 4 or 8 digits.
inline result<value> hex(std::uint32_t v, std::uint8_t digits = 4) noexcept {
    if ((digits != 2 && digits != 4 && digits != 8) || (digits < 8 && v >> (4 * digits) != 0))
        return errc::invalid_argument;
    value out;
    out.format = value_format::hex;
    out.hex = v;
    out.digits = digits;
    return out;
}

namespace detail {
constexpr bool is_visible(std::uint8_t c) noexcept {
    return c >= 0x20 && c <= 0x7E;
}
} // namespace detail

// VS of visible ASCII characters (space included), at most value::max_string.
inline result<value> string(std::string_view s) noexcept {
    if (s.size() > value::max_string) return errc::invalid_argument;
    value out;
    out.format = value_format::string;
    for (char c : s) {
        if (!detail::is_visible(static_cast<std::uint8_t>(c))) return errc::invalid_argument;
        out.bytes[out.size++] = static_cast<std::uint8_t>(c);
    }
    return out;
}

inline result<value> octets(std::span<const std::uint8_t> b) noexcept {
    if (b.size() > value::max_octets) return errc::invalid_argument;
    value out;
    out.format = value_format::octets;
    for (auto x : b) out.bytes[out.size++] = x;
    return out;
}

namespace detail {
// Could the factories above have made `v`? encode_value() needs this: a hand-built value
// with 40 hex digits or 30 octets would not fit max_value_length.
constexpr bool is_encodable(const value& v) noexcept {
    switch (v.format) {
    case value_format::decimal: return v.digits <= value::max_decimals;
    case value_format::hex:
        return (v.digits == 2 || v.digits == 4 || v.digits == 8) &&
               (v.digits == 8 || v.hex >> (4 * v.digits) == 0);
    case value_format::string:
        if (v.size > value::max_string) return false;
        for (std::size_t i = 0; i < v.size; ++i)
            if (!is_visible(v.bytes[i])) return false;
        return true;
    case value_format::octets: return v.size <= value::max_octets;
    }
    return false;
}
} // namespace detail

// Longest value text: 'O' + two digits per octet.
inline constexpr std::size_t max_value_length = 1 + 2 * value::max_octets;

// Writes the value text to `out` (max_value_length bytes); returns its length. A decimal
// gets value::digits decimals, or more where its fraction needs them; other fields are
// written as the factories above made them.
constexpr std::size_t encode_value(const value& v, std::uint8_t* out) noexcept {
    std::uint8_t* p = out;
    switch (v.format) {
    case value_format::decimal: {
        if (v.fixed < 0) *p++ = '-';
        const std::uint32_t mag = v.fixed < 0 ? 0u - static_cast<std::uint32_t>(v.fixed)
                                              : static_cast<std::uint32_t>(v.fixed);
        std::uint32_t whole = mag / value::scale;
        std::uint8_t tmp[10];
        int n = 0;
        do {
            tmp[n++] = static_cast<std::uint8_t>('0' + whole % 10);
            whole /= 10;
        } while (whole != 0);
        while (n > 0) *p++ = tmp[--n];
        const std::uint8_t need = needed_decimals(v.fixed);
        const int decimals = v.digits > need ? v.digits : need;
        if (decimals > 0) {
            *p++ = '.';
            std::uint32_t frac = mag % value::scale;
            for (int i = 0; i < decimals && i < value::max_decimals; ++i) {
                frac *= 10;
                *p++ = static_cast<std::uint8_t>('0' + frac / value::scale);
                frac %= value::scale;
            }
        }
        break;
    }
    case value_format::hex:
        *p++ = 'H';
        for (int i = v.digits - 1; i >= 0; --i) *p++ = detail::hex_digit((v.hex >> (4 * i)) & 0xF);
        break;
    case value_format::string:
        *p++ = 'S';
        for (std::size_t i = 0; i < v.size; ++i) *p++ = v.bytes[i];
        break;
    case value_format::octets:
        *p++ = 'O';
        for (std::size_t i = 0; i < v.size; ++i) {
            *p++ = detail::hex_digit(v.bytes[i] >> 4);
            *p++ = detail::hex_digit(v.bytes[i] & 0xF);
        }
        break;
    }
    return static_cast<std::size_t>(p - out);
}

namespace detail {
inline result<value> parse_decimal(std::span<const std::uint8_t> in) noexcept {
    std::size_t i = 0;
    const bool negative = !in.empty() && in[0] == '-';
    i += negative;
    std::int64_t whole = 0;
    const std::size_t first = i;
    while (i < in.size() && in[i] >= '0' && in[i] <= '9') {
        if (i - first == value::max_integer_digits) return errc::malformed;
        whole = whole * 10 + (in[i++] - '0');
    }
    if (i == first) return errc::malformed;
    std::int64_t frac = 0;
    std::uint8_t decimals = 0;
    if (i < in.size() && in[i] == '.') {
        ++i;
        // "the decimal point must not be transmitted if the value does not have digits
        // after the decimal point" (S1 p.8-19)
        while (i < in.size() && in[i] >= '0' && in[i] <= '9') {
            if (decimals == value::max_decimals) return errc::malformed;
            frac = frac * 10 + (in[i++] - '0');
            ++decimals;
        }
        if (decimals == 0) return errc::malformed;
    }
    if (i != in.size()) return errc::malformed;
    for (std::uint8_t d = decimals; d < value::max_decimals; ++d) frac *= 10;
    std::int64_t fixed = whole * value::scale + frac;
    if (negative) fixed = -fixed;
    if (fixed > INT32_MAX || fixed < INT32_MIN) return errc::malformed; // ±214748.364x
    value v;
    v.fixed = static_cast<std::int32_t>(fixed);
    v.digits = decimals;
    return v;
}
} // namespace detail

// Reads a value text (V1…Vn of a telegram, or what a user typed).
inline result<value> parse_value(std::span<const std::uint8_t> in) noexcept {
    if (in.empty()) return errc::malformed;
    value v;
    const auto body = in.subspan(1);
    switch (in[0]) {
    case 'H': {
        if (body.size() != 2 && body.size() != 4 && body.size() != 8) return errc::malformed;
        v.format = value_format::hex;
        for (auto c : body) {
            const int d = detail::hex_value(c);
            if (d < 0) return errc::malformed;
            v.hex = v.hex << 4 | static_cast<unsigned>(d);
        }
        v.digits = static_cast<std::uint8_t>(body.size());
        return v;
    }
    case 'S':
        if (body.size() > value::max_string) return errc::malformed;
        v.format = value_format::string;
        for (auto c : body) {
            if (!detail::is_visible(c)) return errc::malformed;
            v.bytes[v.size++] = c;
        }
        return v;
    case 'O':
        if (body.size() % 2 != 0 || body.size() > 2 * value::max_octets) return errc::malformed;
        v.format = value_format::octets;
        for (std::size_t i = 0; i < body.size(); i += 2) {
            const int hi = detail::hex_value(body[i]);
            const int lo = detail::hex_value(body[i + 1]);
            if (hi < 0 || lo < 0) return errc::malformed;
            v.bytes[v.size++] = static_cast<std::uint8_t>(hi << 4 | lo);
        }
        return v;
    default: return detail::parse_decimal(in);
    }
}

inline result<value> parse_value(std::string_view text) noexcept {
    return parse_value(std::span<const std::uint8_t>(
        reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

} // namespace ferrule::lecom
