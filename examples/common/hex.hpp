// Hex bytes as the command-line tools print and read them ("06 C8 00 00 25"). Shared by
// `ferrule` and `ferrule-sim`.
#pragma once

#include <fmt/core.h>

#include <cctype>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
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

namespace detail {

// Runs of characters between separators (space : , -) in `words`; `fn(token, index)` for each,
// index 1 for the first, until fn returns false.
template <class Fn>
void for_each_hex_token(std::span<const std::string> words, Fn fn) {
    const auto separator = [](char c) { return c == ' ' || c == ':' || c == ',' || c == '-'; };
    std::size_t index = 0;
    for (const std::string& w : words) {
        std::size_t i = 0;
        while (i < w.size()) {
            if (separator(w[i])) {
                ++i;
                continue;
            }
            std::size_t end = i;
            while (end < w.size() && !separator(w[end])) ++end;
            if (!fn(std::string_view(w).substr(i, end - i), ++index)) return;
            i = end;
        }
    }
}

// A token's hex digits ("0x" dropped) appended to `digits`; the offset in the token of the
// first character that is no hex digit, or npos.
inline std::size_t token_digits(std::string_view token, std::string& digits) {
    for (std::size_t i = 0; i < token.size(); ++i) {
        const char ch = token[i];
        if (ch == '0' && i + 1 < token.size() && (token[i + 1] == 'x' || token[i + 1] == 'X')) {
            ++i;
            continue;
        }
        if (!std::isxdigit(static_cast<unsigned char>(ch))) return i;
        digits += ch;
    }
    return std::string_view::npos;
}

} // namespace detail

// "02 01 05", "020105", "02:01:05", "0x02,0x01": the bytes (appended to `out`); false for
// anything else or an odd number of digits (hex_error() says why).
inline bool parse_hex(std::span<const std::string> words, std::vector<std::uint8_t>& out) {
    std::string digits;
    bool ok = true;
    detail::for_each_hex_token(words, [&](std::string_view token, std::size_t) {
        ok = detail::token_digits(token, digits) == std::string_view::npos;
        return ok;
    });
    if (!ok || digits.size() % 2 != 0) return false;
    for (std::size_t i = 0; i < digits.size(); i += 2)
        out.push_back(static_cast<std::uint8_t>(std::stoul(digits.substr(i, 2), nullptr, 16)));
    return true;
}

// Why parse_hex() refuses `words`, naming the token and its place (1: the first): one with a
// character that is no hex digit, or, when the digits do not pair up, the first with an odd
// number of them. Empty when parse_hex() takes the words.
inline std::string hex_error(std::span<const std::string> words) {
    std::string why;
    std::string digits;
    std::string odd;
    detail::for_each_hex_token(words, [&](std::string_view token, std::size_t index) {
        const std::size_t before = digits.size();
        const std::size_t bad = detail::token_digits(token, digits);
        if (bad != std::string_view::npos) {
            why =
                fmt::format("hex token {} \"{}\": '{}' is no hex digit", index, token, token[bad]);
            return false;
        }
        if (odd.empty() && (digits.size() - before) % 2 != 0)
            odd = fmt::format("hex token {} \"{}\": an odd number of hex digits (a byte is two)",
                              index, token);
        return true;
    });
    if (!why.empty()) return why;
    return digits.size() % 2 != 0 ? odd : std::string();
}

inline bool parse_hex(const std::string& text, std::vector<std::uint8_t>& out) {
    return parse_hex(std::span<const std::string>(&text, 1), out);
}

} // namespace ferrule::tools
