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

// Longest value text: 'O' + two digits per octet.
inline constexpr std::size_t max_value_length = 1 + 2 * value::max_octets;

// Writes the value text to `out` (max_value_length bytes); returns its length. A decimal
// gets value::digits decimals, or more where its fraction needs them; other fields are
// written as the factories above made them. A value they could not have made (a hand-built
// one with 40 hex digits, 30 octets, a control character in a string…) is not written:
// the result is 0 and `out` holds no value text.
constexpr std::size_t encode_value(const value& v, std::uint8_t* out) noexcept {
    std::uint8_t* p = out;
    switch (v.format) {
    case value_format::decimal: {
        if (v.digits > value::max_decimals) return 0;
        if (v.fixed < 0) *p++ = '-';
        std::uint32_t mag = v.fixed < 0 ? 0u - static_cast<std::uint32_t>(v.fixed)
                                        : static_cast<std::uint32_t>(v.fixed);
        // Drop the zeros of the fraction that neither the value nor v.digits asks for.
        unsigned decimals = value::max_decimals;
        while (decimals > v.digits && mag % 10 == 0) {
            mag /= 10;
            --decimals;
        }
        // Digits from the last one, the point after `decimals` of them, one before it.
        std::uint8_t tmp[12];
        unsigned n = 0;
        for (unsigned i = 1; mag != 0 || i <= decimals + 1; ++i) {
            tmp[n++] = static_cast<std::uint8_t>('0' + mag % 10);
            mag /= 10;
            if (i == decimals) tmp[n++] = '.';
        }
        while (n > 0) *p++ = tmp[--n];
        break;
    }
    case value_format::hex:
        if ((v.digits != 2 && v.digits != 4 && v.digits != 8) ||
            (v.digits < 8 && v.hex >> (4 * v.digits) != 0))
            return 0;
        *p++ = 'H';
        for (int i = v.digits - 1; i >= 0; --i) *p++ = detail::hex_digit((v.hex >> (4 * i)) & 0xF);
        break;
    case value_format::string:
        if (v.size > value::max_string) return 0;
        *p++ = 'S';
        for (std::size_t i = 0; i < v.size; ++i) {
            if (!detail::is_visible(v.bytes[i])) return 0;
            *p++ = v.bytes[i];
        }
        break;
    case value_format::octets:
        if (v.size > value::max_octets) return 0;
        *p++ = 'O';
        for (std::size_t i = 0; i < v.size; ++i) {
            *p++ = detail::hex_digit(v.bytes[i] >> 4);
            *p++ = detail::hex_digit(v.bytes[i] & 0xF);
        }
        break;
    }
    return static_cast<std::size_t>(p - out); // 0 for a format that is none of the four
}

namespace detail {
// Could the factories above have made `v`? Only such a value is encoded.
constexpr bool is_encodable(const value& v) noexcept {
    std::array<std::uint8_t, max_value_length> scratch; // written, never read
    return encode_value(v, scratch.data()) != 0;
}

// VD: [-]d…d[.d…d], at most 6 integer and 4 decimal digits, within FIX32.
constexpr bool read_decimal(std::span<const std::uint8_t> in, value& v) noexcept {
    const bool negative = !in.empty() && in[0] == '-';
    std::uint32_t mag = 0; // the digits, the point left out: at most 214748 9999
    unsigned counts[2]{};  // digits before and after the point
    bool point = false;
    for (std::size_t i = negative; i < in.size(); ++i) {
        const std::uint8_t c = in[i];
        // "the decimal point must not be transmitted if the value does not have digits
        // after the decimal point" (S1 p.8-19)
        if (c == '.' && !point && counts[0] != 0) {
            point = true;
            continue;
        }
        if (c < '0' || c > '9') return false;
        mag = mag * 10 + (c - '0');
        if (point ? ++counts[1] > value::max_decimals
                  : ++counts[0] > value::max_integer_digits || mag > 214748)
            return false; // beyond ±214748.3648 whatever follows
    }
    if (counts[0] == 0 || (point && counts[1] == 0)) return false;
    for (unsigned d = counts[1]; d < value::max_decimals; ++d) mag *= 10;
    if (mag > 0x7FFF'FFFFu + unsigned{negative}) return false; // ±214748.364x
    v.fixed = static_cast<std::int32_t>(negative ? 0u - mag : mag);
    v.digits = static_cast<std::uint8_t>(counts[1]);
    return true;
}

// Reads a value text into `v`, a default value; false if it is none.
constexpr bool read_value(std::span<const std::uint8_t> in, value& v) noexcept {
    if (in.empty()) return false;
    const auto body = in.subspan(1);
    const std::size_t n = body.size();
    switch (in[0]) {
    case 'H':
    case 'O': {
        // VH: 2, 4 or 8 digits of one number; VO: two digits per octet.
        const bool octets = in[0] == 'O';
        if (octets ? n % 2 != 0 || n > 2 * value::max_octets : n != 2 && n != 4 && n != 8)
            return false;
        std::uint32_t acc = 0;
        for (std::size_t i = 0; i < n; ++i) {
            const int d = hex_value(body[i]);
            if (d < 0) return false;
            acc = acc << 4 | static_cast<unsigned>(d);
            if (octets && i % 2 != 0) v.bytes[v.size++] = static_cast<std::uint8_t>(acc);
        }
        if (octets) {
            v.format = value_format::octets;
        } else {
            v.format = value_format::hex;
            v.hex = acc;
            v.digits = static_cast<std::uint8_t>(n);
        }
        return true;
    }
    case 'S':
        if (n > value::max_string) return false;
        v.format = value_format::string;
        for (auto c : body) {
            if (!is_visible(c)) return false;
            v.bytes[v.size++] = c;
        }
        return true;
    default: return read_decimal(in, v);
    }
}
} // namespace detail

// Reads a value text (V1…Vn of a telegram, or what a user typed).
inline result<value> parse_value(std::span<const std::uint8_t> in) noexcept {
    value v;
    if (!detail::read_value(in, v)) return errc::malformed;
    return v;
}

inline result<value> parse_value(std::string_view text) noexcept {
    return parse_value(std::span<const std::uint8_t>(
        reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

} // namespace ferrule::lecom
