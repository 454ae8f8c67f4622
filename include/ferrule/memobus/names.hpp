// Register names of the MP series as MPE720 writes them, and the MEMOBUS addresses they
// stand for. A controller serving Extended MEMOBUS maps coils to MB, input relays to IB,
// hold registers to MW and input registers to IW (protocols/memobus.md §3.4, [S3 p=420]):
//
//   MW00100   hold register, word number in decimal (0…65534, §3.4)     SFC 03 06 09 0B 0D 0E 10
//   IW0010    input register (0…65535)                                   SFC 04 0A
//   MB00100A  bit A (10) of MW00100: the decimal word number, then ONE   SFC 01 05 0F
//             hex digit for the bit; its coil address is word × 16 + bit
//   IB00100   bit 0 of IW0010, likewise; input relay address             SFC 02
//
// The notes give input registers and relays only as MEMOBUS addresses 0…65535 (§3.4), not
// how MPE720 numbers IW: read as decimal like MW (UNCERTAIN; the MP may number I/O registers
// in hex). A hex letter in the word number is refused, so a hex spelling such as IWC000 fails
// rather than naming another register.
//
// Prefixes are case-insensitive; 1…5 word digits. A name so written whose word number is
// beyond its area (MW65535, IW99999) is errc::out_of_range; anything else is
// errc::invalid_argument.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"

namespace ferrule::memobus {

enum class register_kind : std::uint8_t { mw, iw, mb, ib };

struct register_ref {
    register_kind kind = register_kind::mw;
    std::uint16_t word = 0;
    std::uint8_t bit = 0; // 0…15, MB and IB only
    friend constexpr bool operator==(const register_ref&, const register_ref&) = default;
};

constexpr bool is_bit(register_kind k) noexcept {
    return k == register_kind::mb || k == register_kind::ib;
}

// The bit address of MB / IB for SFC 01 02 05 0F: word × 16 + bit (a coil address is a bit
// address, 0…65535, [S3 p=385]); above 65535 for words past 4095, which MEMOBUS cannot reach.
constexpr std::uint32_t bit_address(const register_ref& r) noexcept {
    return std::uint32_t{r.word} * 16u + r.bit;
}

// The longest name: MB + 5 digits + 1 hex digit.
inline constexpr std::size_t max_register_name = 8;

// The last word number of an area: MW (and its bits) end at 65534, IW at 65535 (§3.4).
constexpr std::uint16_t last_word(register_kind k) noexcept {
    return k == register_kind::mw || k == register_kind::mb ? 65534 : 65535;
}

namespace detail {
constexpr char upper(char c) noexcept {
    return c >= 'a' && c <= 'z' ? static_cast<char>(c - 'a' + 'A') : c;
}
constexpr int hex_digit(char c) noexcept {
    if (c >= '0' && c <= '9') return c - '0';
    c = upper(c);
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}
} // namespace detail

// The area a name's first two letters stand for (MW, IW, MB, IB in any case), or nullopt: with
// last_word(), what a name beyond its area (errc::out_of_range) may reach.
constexpr std::optional<register_kind> area_of(std::string_view name) noexcept {
    if (name.size() < 2) return std::nullopt;
    const char area = detail::upper(name[0]);
    const char size = detail::upper(name[1]);
    if (area != 'M' && area != 'I') return std::nullopt;
    if (size == 'W') return area == 'M' ? register_kind::mw : register_kind::iw;
    if (size == 'B') return area == 'M' ? register_kind::mb : register_kind::ib;
    return std::nullopt;
}

namespace detail {
// A name's register, or why it is none.
struct parsed_name {
    register_ref ref{};
    errc fault{}; // errc{}: a register
};

constexpr parsed_name parse_name(std::string_view name) noexcept {
    constexpr parsed_name none{{}, errc::invalid_argument};
    const auto kind = area_of(name);
    if (name.size() < 3 || !kind) return none;
    register_ref r;
    r.kind = *kind;
    std::string_view digits = name.substr(2);
    if (is_bit(r.kind)) {
        const int b = hex_digit(digits.back());
        if (b < 0) return none;
        r.bit = static_cast<std::uint8_t>(b);
        digits.remove_suffix(1);
    }
    if (digits.empty() || digits.size() > 5) return none;
    std::uint32_t word = 0;
    for (const char c : digits) {
        if (c < '0' || c > '9') return none;
        word = word * 10 + static_cast<std::uint32_t>(c - '0');
    }
    if (word > last_word(r.kind)) return {r, errc::out_of_range};
    r.word = static_cast<std::uint16_t>(word);
    return {r, {}};
}
} // namespace detail

// The register a name stands for, or nullopt; usable in constant expressions.
constexpr std::optional<register_ref> try_parse_register(std::string_view name) noexcept {
    const auto p = detail::parse_name(name);
    if (p.fault != errc{}) return std::nullopt;
    return p.ref;
}

// The same as a result: errc::out_of_range for a name whose word number is beyond its area
// (MW00000…MW65534, IW0000…IW65535), errc::invalid_argument for anything else that is no
// register name.
inline result<register_ref> parse_register(std::string_view name) noexcept {
    const auto p = detail::parse_name(name);
    if (p.fault != errc{}) return p.fault;
    return p.ref;
}

// The name in MPE720's spelling (MW00100, IW0010, MB00100A, IB00100) into `out`; its length,
// or errc::buffer_too_small. MW and MB words have 5 digits, IW and IB words at least 4.
// invalid_argument for a bit above 15 or a hold register word of 65535.
inline result<std::size_t> format_register(const register_ref& r, std::span<char> out) noexcept {
    const bool hold = r.kind == register_kind::mw || r.kind == register_kind::mb;
    if (r.bit > 15 || r.word > last_word(r.kind) || (!is_bit(r.kind) && r.bit != 0))
        return errc::invalid_argument;
    const std::size_t digits = hold || r.word >= 10000 ? 5 : 4;
    const std::size_t n = 2 + digits + (is_bit(r.kind) ? 1 : 0);
    if (out.size() < n) return errc::buffer_too_small;
    out[0] = hold ? 'M' : 'I';
    out[1] = is_bit(r.kind) ? 'B' : 'W';
    unsigned w = r.word;
    for (std::size_t i = 0; i < digits; ++i) {
        out[2 + digits - 1 - i] = static_cast<char>('0' + w % 10);
        w /= 10;
    }
    if (is_bit(r.kind)) out[n - 1] = "0123456789ABCDEF"[r.bit];
    return n;
}

} // namespace ferrule::memobus
