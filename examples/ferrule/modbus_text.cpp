#include "modbus_text.hpp"

#include <fmt/core.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "common.hpp"
#include "ferrule/modbus/error.hpp"

namespace ferrule::cli {

namespace mb = ferrule::modbus;

std::optional<value_type> parse_value_type(const std::string& s) {
    if (s == "u16") return value_type::u16;
    if (s == "i16") return value_type::i16;
    if (s == "u32") return value_type::u32;
    if (s == "i32") return value_type::i32;
    if (s == "float") return value_type::f32;
    if (s == "hex") return value_type::hex;
    return std::nullopt;
}

std::optional<mb::word_order> parse_word_order(const std::string& s) {
    if (s == "abcd") return mb::word_order::abcd;
    if (s == "badc") return mb::word_order::badc;
    if (s == "cdab") return mb::word_order::cdab;
    if (s == "dcba") return mb::word_order::dcba;
    return std::nullopt;
}

unsigned registers_per_value(value_type t) {
    return t == value_type::u32 || t == value_type::i32 || t == value_type::f32 ? 2 : 1;
}

double value_number(value_type t, std::span<const std::uint16_t> r, mb::word_order o) {
    switch (t) {
    case value_type::u16: return mb::to_u16(r[0], o);
    case value_type::i16: return mb::to_i16(r[0], o);
    case value_type::u32: return mb::to_u32(r[0], r[1], o);
    case value_type::i32: return mb::to_i32(r[0], r[1], o);
    case value_type::f32: return mb::to_f32(r[0], r[1], o);
    case value_type::hex: return r[0];
    }
    return 0;
}

std::string value_text(value_type t, std::span<const std::uint16_t> r, mb::word_order o) {
    if (t == value_type::hex) return fmt::format("0x{:04X}", r[0]);
    if (t == value_type::f32) return fmt::format("{}", mb::to_f32(r[0], r[1], o));
    return fmt::format("{}", static_cast<std::int64_t>(value_number(t, r, o)));
}

namespace {

struct bounds {
    std::int64_t lo;
    std::int64_t hi;
};

bounds bounds_of(value_type t) {
    switch (t) {
    case value_type::i16: return {-32768, 32767};
    case value_type::u32: return {0, 0xFFFFFFFF};
    case value_type::i32:
        return {std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::max()};
    case value_type::u16:
    case value_type::hex:
    case value_type::f32: break;
    }
    return {0, 0xFFFF};
}

// An integer (decimal or 0x hex) within the bounds of `t`.
std::optional<std::int64_t> parse_integer(value_type t, const std::string& s) {
    const auto v = cli::parse_integer(s);
    const auto b = bounds_of(t);
    if (!v || *v < b.lo || *v > b.hi) return std::nullopt;
    return v;
}

} // namespace

std::string value_range(value_type t) {
    if (t == value_type::f32) return "a finite 32-bit float";
    if (t == value_type::hex) return "0x0000-0xFFFF";
    const auto b = bounds_of(t);
    const std::array<interval, 1> r{{{b.lo, b.hi}}};
    return range_text(r);
}

std::optional<std::vector<std::uint16_t>> parse_value(value_type t, const std::string& s,
                                                      mb::word_order o) {
    using v16 = std::vector<std::uint16_t>;
    const auto two = [](std::array<std::uint16_t, 2> a) { return v16{a[0], a[1]}; };
    switch (t) {
    case value_type::u16:
        if (const auto v = parse_integer(t, s))
            return v16{mb::from_u16(static_cast<std::uint16_t>(*v), o)};
        break;
    case value_type::i16:
        if (const auto v = parse_integer(t, s))
            return v16{mb::from_i16(static_cast<std::int16_t>(*v), o)};
        break;
    case value_type::hex:
        if (const auto v = parse_integer(t, s.rfind("0x", 0) == 0 ? s : "0x" + s))
            return v16{static_cast<std::uint16_t>(*v)};
        break;
    case value_type::u32:
        if (const auto v = parse_integer(t, s))
            return two(mb::from_u32(static_cast<std::uint32_t>(*v), o));
        break;
    case value_type::i32:
        if (const auto v = parse_integer(t, s))
            return two(mb::from_i32(static_cast<std::int32_t>(*v), o));
        break;
    case value_type::f32: {
        char* end = nullptr;
        const float f = std::strtof(s.c_str(), &end);
        if (!s.empty() && *end == '\0' && std::isfinite(f)) return two(mb::from_f32(f, o));
        break;
    }
    }
    return std::nullopt;
}

std::string function_name(std::uint8_t fc) {
    if (const char* n = mb::name(static_cast<mb::function>(fc))) return n;
    return fmt::format("function 0x{:02X}", fc);
}

std::string error_text(std::error_code ec) {
    if (ec.category() == mb::device_category())
        return fmt::format("exception {:02X}: {}", ec.value(), ec.message());
    return ec.message();
}

std::string object_name(std::uint8_t id) {
    if (const char* n = mb::device_id_object_name(id)) return n;
    return fmt::format("object 0x{:02X}", id);
}

} // namespace ferrule::cli
