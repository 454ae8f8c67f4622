// UART character format and the timing that follows from it. Every protocol's gaps
// and timeouts are expressed in character times, so this is the one place they come from.
#pragma once

#include <cstdint>
#include <string_view>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule {

enum class parity : std::uint8_t { none, even, odd };

struct serial_format {
    std::uint32_t baud = 9600;
    std::uint8_t data_bits = 8;
    ferrule::parity parity = ferrule::parity::even;
    std::uint8_t stop_bits = 1;

    // start bit + data + parity + stop bits
    constexpr unsigned bits_per_char() const noexcept {
        return 1u + data_bits + (parity == ferrule::parity::none ? 0u : 1u) + stop_bits;
    }
    // Time one character occupies on the wire, rounded up to the clock's resolution.
    constexpr duration char_time() const noexcept { return chars_time(1); }
    // Wire time of n back-to-back characters (computed exactly, rounded up once).
    constexpr duration chars_time(std::uint64_t n) const noexcept;

    friend constexpr bool operator==(const serial_format&, const serial_format&) = default;

    // "8E1", "7E1", "8N1", "8O2" …
    static result<serial_format> parse(std::string_view spec, std::uint32_t baud = 9600) noexcept {
        if (spec.size() != 3) return errc::invalid_argument;
        serial_format f;
        f.baud = baud;
        if (spec[0] < '5' || spec[0] > '8') return errc::invalid_argument;
        f.data_bits = static_cast<std::uint8_t>(spec[0] - '0');
        switch (spec[1]) {
        case 'N':
        case 'n': f.parity = ferrule::parity::none; break;
        case 'E':
        case 'e': f.parity = ferrule::parity::even; break;
        case 'O':
        case 'o': f.parity = ferrule::parity::odd; break;
        default: return errc::invalid_argument;
        }
        if (spec[2] != '1' && spec[2] != '2') return errc::invalid_argument;
        f.stop_bits = static_cast<std::uint8_t>(spec[2] - '0');
        if (baud == 0) return errc::invalid_argument;
        return f;
    }
};

// chars_time() with the product that depends on the format alone taken once, for a session
// that times every request: built in its constexpr constructor, so at compile time when the
// session is constinit.
#if defined(FERRULE_TICK_32)
// With the 32-bit tick (time.hpp) one character's time is kept in 1/256 us, rounded up, and n
// characters take ceil(n × that / 256) us: a 32 × 32-bit product and shifts, no 64-bit
// division. Rounded up twice, a time is at most n/256 + 1 us longer than exact and never
// shorter, so no timeout is shorter than the manual's.
class wire_clock {
public:
    constexpr explicit wire_clock(const serial_format& f) noexcept
        : char_ticks_((f.bits_per_char() * 256'000'000u + f.baud - 1) / f.baud) {}
    constexpr duration chars_time(std::uint64_t n) const noexcept {
        const std::uint64_t t =
            static_cast<std::uint64_t>(static_cast<std::uint32_t>(n)) * char_ticks_;
        return duration{static_cast<std::int32_t>((t + 255) >> 8)};
    }

private:
    std::uint32_t char_ticks_; // one character in 1/256 us (12 bits at 1 baud still fit)
};
#else
class wire_clock {
public:
    constexpr explicit wire_clock(const serial_format& f) noexcept
        : bit_ns_(f.bits_per_char() * 1'000'000'000ull), baud_(f.baud) {}
    constexpr duration chars_time(std::uint64_t n) const noexcept {
        return duration{static_cast<std::int64_t>((n * bit_ns_ + baud_ - 1) / baud_)};
    }

private:
    std::uint64_t bit_ns_; // nanoseconds × baud of one character
    std::uint32_t baud_;
};
#endif

constexpr duration serial_format::chars_time(std::uint64_t n) const noexcept {
    return wire_clock(*this).chars_time(n);
}

} // namespace ferrule
