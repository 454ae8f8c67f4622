// Blocking Extended MEMOBUS access over any byte_stream: one call, one transaction, driven by
// ferrule::run(). For a non-blocking main loop use master + poll_driver.
//
// Quantities come from the spans: read_words(s, m, mw(100), regs) reads regs.size()
// registers from MW00100. Registers travel in the extended SFCs 09 / 0A / 0B / 0D / 0E, whose
// fields are little-endian without doubt (protocols/memobus.md §3.3), up to 2044 words a
// read (§3.4); bits in SFC 01 / 02 / 05 / 0F at bit address word × 16 + bit.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/memobus/constants.hpp"
#include "ferrule/memobus/master.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/names.hpp"

namespace ferrule::memobus {

constexpr register_ref mw(std::uint16_t word) noexcept {
    return {register_kind::mw, word, 0};
}
constexpr register_ref iw(std::uint16_t word) noexcept {
    return {register_kind::iw, word, 0};
}
constexpr register_ref mb(std::uint16_t word, std::uint8_t bit) noexcept {
    return {register_kind::mb, word, bit};
}
constexpr register_ref ib(std::uint16_t word, std::uint8_t bit) noexcept {
    return {register_kind::ib, word, bit};
}

namespace detail {
template <session_stream S>
ferrule::error transact(S& stream, master& m, const request& r) {
    if (auto ec = m.start(r)) return ec;
    return run(stream, m);
}

// The bit address of `first` when `count` bits from it stay within 0…65535.
inline bool bit_range(const register_ref& first, std::size_t count, std::uint16_t& address) {
    const std::uint32_t a = bit_address(first);
    if (!is_bit(first.kind) || first.bit > 15 || a + count > 0x10000u) return false;
    address = static_cast<std::uint16_t>(a);
    return true;
}
} // namespace detail

// SFC 09 (MW) or 0A (IW): out.size() registers, 1…2044, from `first`.
template <session_stream S>
ferrule::error read_words(S& stream, master& m, const register_ref& first,
                          std::span<std::uint16_t> out) {
    if (is_bit(first.kind) || out.empty() || out.size() > max_read_registers_ext)
        return errc::invalid_argument;
    request r;
    r.function = first.kind == register_kind::mw ? sfc::read_holding_registers_ext
                                                 : sfc::read_input_registers_ext;
    r.address = first.word;
    r.count = static_cast<std::uint16_t>(out.size());
    if (auto ec = detail::transact(stream, m, r)) return ec;
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = m.word(i);
    return {};
}

// SFC 0B: values.size() registers, 1…2043, from MW `first`.
template <session_stream S>
ferrule::error write_words(S& stream, master& m, const register_ref& first,
                           std::span<const std::uint16_t> values) {
    if (first.kind != register_kind::mw || values.empty() ||
        values.size() > max_write_registers_ext)
        return errc::invalid_argument;
    request r;
    r.function = sfc::write_holding_registers_ext;
    r.address = first.word;
    r.count = static_cast<std::uint16_t>(values.size());
    r.words = values;
    return detail::transact(stream, m, r);
}

// SFC 01 (MB, coils) or 02 (IB, input relays): out.size() bits, 1…2000, from `first`.
template <session_stream S>
ferrule::error read_bits(S& stream, master& m, const register_ref& first, std::span<bool> out) {
    request r;
    if (out.empty() || out.size() > max_read_bits ||
        !detail::bit_range(first, out.size(), r.address))
        return errc::invalid_argument;
    r.function = first.kind == register_kind::mb ? sfc::read_coils : sfc::read_input_relays;
    r.count = static_cast<std::uint16_t>(out.size());
    if (auto ec = detail::transact(stream, m, r)) return ec;
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = m.bit(i);
    return {};
}

// SFC 0F: values.size() coils, 1…800, from MB `first`.
template <session_stream S>
ferrule::error write_bits(S& stream, master& m, const register_ref& first,
                          std::span<const bool> values) {
    request r;
    if (first.kind != register_kind::mb || values.empty() || values.size() > max_write_bits ||
        !detail::bit_range(first, values.size(), r.address))
        return errc::invalid_argument;
    std::array<std::uint8_t, packed_size(max_write_bits)> packed{};
    for (std::size_t i = 0; i < values.size(); ++i)
        if (values[i]) packed[i / 8] = static_cast<std::uint8_t>(packed[i / 8] | 1u << (i % 8));
    r.function = sfc::write_coils;
    r.count = static_cast<std::uint16_t>(values.size());
    r.bits = std::span<const std::uint8_t>(packed).first(packed_size(values.size()));
    return detail::transact(stream, m, r);
}

// SFC 05: one coil, MB `bit`.
template <session_stream S>
ferrule::error write_bit(S& stream, master& m, const register_ref& bit, bool on) {
    request r;
    if (bit.kind != register_kind::mb || !detail::bit_range(bit, 1, r.address))
        return errc::invalid_argument;
    r.function = sfc::write_coil;
    r.count = 1;
    r.value = on ? coil_on : 0;
    return detail::transact(stream, m, r);
}

// SFC 0D: MW registers at the word numbers `words` (1…2044) into out (as many).
template <session_stream S>
ferrule::error read_random(S& stream, master& m, std::span<const std::uint16_t> words,
                           std::span<std::uint16_t> out) {
    if (words.empty() || words.size() > max_read_registers_ext || out.size() != words.size())
        return errc::invalid_argument;
    request r;
    r.function = sfc::read_holding_registers_random;
    r.count = static_cast<std::uint16_t>(words.size());
    r.words = words;
    if (auto ec = detail::transact(stream, m, r)) return ec;
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = m.word(i);
    return {};
}

// SFC 0E: values[i] to MW words[i], 1…1022 registers. The request's pairs are built on the
// stack (4 KiB for 1022).
template <session_stream S>
ferrule::error write_random(S& stream, master& m, std::span<const std::uint16_t> words,
                            std::span<const std::uint16_t> values) {
    if (words.empty() || words.size() > max_write_random || values.size() != words.size())
        return errc::invalid_argument;
    std::array<std::uint16_t, 2 * std::size_t{max_write_random}> pairs{};
    for (std::size_t i = 0; i < words.size(); ++i) {
        pairs[2 * i] = words[i];
        pairs[2 * i + 1] = values[i];
    }
    request r;
    r.function = sfc::write_holding_registers_random;
    r.count = static_cast<std::uint16_t>(words.size());
    r.words = std::span<const std::uint16_t>(pairs).first(2 * words.size());
    return detail::transact(stream, m, r);
}

// SFC 08: test code 0 and `data` (the manual's example: AAAA), echoed by the controller.
template <session_stream S>
ferrule::error loopback(S& stream, master& m, std::uint16_t data = 0xAAAA) {
    request r;
    r.function = sfc::loopback;
    r.value = data;
    return detail::transact(stream, m, r);
}

// By name: registers from "MW00100" / "IW0010", bits from "MB00100A" / "IB00100". A name
// beyond its area (MW65535) is errc::out_of_range, anything else that is no name
// errc::invalid_argument.
template <session_stream S>
ferrule::error read(S& stream, master& m, std::string_view name, std::span<std::uint16_t> out) {
    const auto first = parse_register(name);
    if (!first) return first.error();
    return read_words(stream, m, *first, out);
}
template <session_stream S>
ferrule::error read(S& stream, master& m, std::string_view name, std::span<bool> out) {
    const auto first = parse_register(name);
    if (!first) return first.error();
    return read_bits(stream, m, *first, out);
}
template <session_stream S>
ferrule::error write(S& stream, master& m, std::string_view name,
                     std::span<const std::uint16_t> values) {
    const auto first = parse_register(name);
    if (!first) return first.error();
    return write_words(stream, m, *first, values);
}
template <session_stream S>
ferrule::error write(S& stream, master& m, std::string_view name, std::span<const bool> values) {
    const auto first = parse_register(name);
    if (!first) return first.error();
    return write_bits(stream, m, *first, values);
}

} // namespace ferrule::memobus
