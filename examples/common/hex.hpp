// Hex bytes as the command-line tools print and read them ("06 C8 00 00 25"). Shared by
// `ferrule` and `ferrule-sim`.
#pragma once

#include <fmt/core.h>

#include <cctype>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace ferrule::tools {

inline std::string hex(std::span<const std::uint8_t> bytes) {
    std::string s;
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        if (i) s += ' ';
        s += fmt::format("{:02X}", bytes[i]);
    }
    return s;
}

// "02 01 05", "020105", "02:01:05", "0x02,0x01": the bytes (appended to `out`); false for
// anything else or an odd number of digits.
inline bool parse_hex(std::span<const std::string> words, std::vector<std::uint8_t>& out) {
    std::string digits;
    for (const auto& w : words)
        for (std::size_t i = 0; i < w.size(); ++i) {
            const char ch = w[i];
            if (ch == '0' && i + 1 < w.size() && (w[i + 1] == 'x' || w[i + 1] == 'X')) {
                ++i;
                continue;
            }
            if (std::isxdigit(static_cast<unsigned char>(ch)))
                digits += ch;
            else if (ch != ' ' && ch != ':' && ch != ',' && ch != '-')
                return false;
        }
    if (digits.size() % 2 != 0) return false;
    for (std::size_t i = 0; i < digits.size(); i += 2)
        out.push_back(static_cast<std::uint8_t>(std::stoul(digits.substr(i, 2), nullptr, 16)));
    return true;
}

inline bool parse_hex(const std::string& text, std::vector<std::uint8_t>& out) {
    return parse_hex(std::span<const std::string>(&text, 1), out);
}

} // namespace ferrule::tools
