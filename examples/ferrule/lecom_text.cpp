#include "lecom_text.hpp"

#include <fmt/core.h>

#include <charconv>

namespace ferrule::cli {

std::optional<lecom::code_address> parse_code_arg(std::string_view text, bool extended) {
    if (!text.empty() && text[0] == '!') {
        const auto c = lecom::parse_code(std::span<const std::uint8_t>(
            reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
        if (!c || text.size() != lecom::extended_code_length) return std::nullopt;
        return *c;
    }
    if (!text.empty() && (text[0] == 'C' || text[0] == 'c')) text.remove_prefix(1);
    const auto slash = text.find('/');
    const std::string_view number = text.substr(0, slash);
    unsigned code = 0;
    const auto [end, ec] = std::from_chars(number.data(), number.data() + number.size(), code);
    if (ec != std::errc{} || end != number.data() + number.size() || code > 0xFFFF)
        return std::nullopt;
    unsigned sub = 0;
    if (slash != std::string_view::npos) {
        const std::string_view s = text.substr(slash + 1);
        const auto [send, sec] = std::from_chars(s.data(), s.data() + s.size(), sub);
        if (sec != std::errc{} || send != s.data() + s.size() || sub > 0xFF) return std::nullopt;
        extended = true;
    }
    if (extended)
        return lecom::extended_code(static_cast<std::uint16_t>(code),
                                    static_cast<std::uint8_t>(sub));
    if (code > lecom::max_standard_code) return std::nullopt;
    return lecom::code(static_cast<std::uint16_t>(code));
}

std::string code_text(const lecom::code_address& c) {
    return c.extended ? fmt::format("C{:04}/{}", c.code, c.subcode) : fmt::format("C{:04}", c.code);
}

std::string value_text(const lecom::value& v) {
    std::array<std::uint8_t, lecom::max_value_length> buf{};
    const auto n = lecom::encode_value(v, buf.data());
    std::string s(reinterpret_cast<const char*>(buf.data()), n);
    if (v.format == lecom::value_format::string) return "S\"" + s.substr(1) + "\"";
    return s;
}

std::string format_name(lecom::value_format f) {
    switch (f) {
    case lecom::value_format::decimal: return "decimal";
    case lecom::value_format::hex: return "hex";
    case lecom::value_format::string: return "string";
    case lecom::value_format::octets: return "octets";
    }
    return "?";
}

} // namespace ferrule::cli
