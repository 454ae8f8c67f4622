// The D-Series command set (S1 ch.8, pp.40-54) as a table: per mnemonic its forms (by number
// of parameters) and the answer each form gets. Requests `sN<mnemonic>[+p…]`, answers
// `gN…`; the set/get convention is S1 §8.1.4 p.40: `sN<cmd>+value` sets and is answered
// `gN<cmd>?`, `sN<cmd>` gets and is answered `gN<cmd>+value`.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace ferrule::dimetix {

// A command mnemonic such as "g", "uof", "DI1", "SSIe" (case-sensitive, S1 ch.8).
struct mnemonic {
    static constexpr std::size_t capacity = 5;
    std::array<char, capacity> chars{};
    std::uint8_t size = 0;

    constexpr mnemonic() noexcept = default;
    // Longer text is cut to `capacity`, which no documented mnemonic needs; encode() and
    // validate() then refuse it because valid_text() fails.
    constexpr mnemonic(std::string_view s) noexcept {
        for (char c : s) {
            if (size == capacity) {
                size = 0xFF;
                return;
            }
            chars[size++] = c;
        }
    }
    template <std::size_t N>
    constexpr mnemonic(const char (&s)[N]) noexcept : mnemonic(std::string_view(s, N - 1)) {}

    constexpr std::string_view view() const noexcept {
        return {chars.data(), size <= capacity ? size : std::size_t{0}};
    }
    // 1..5 letters or digits (every mnemonic of S1 ch.8).
    constexpr bool valid_text() const noexcept {
        if (size == 0 || size > capacity) return false;
        for (std::size_t i = 0; i < size; ++i) {
            const char c = chars[i];
            if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9')))
                return false;
        }
        return true;
    }
    // A one-character mnemonic such as "g" or "c" (cheap test for the session).
    constexpr bool is(char c) const noexcept { return size == 1 && chars[0] == c; }
    // Unused characters are zero, so comparing the arrays compares the texts.
    friend constexpr bool operator==(const mnemonic& a, const mnemonic& b) noexcept {
        return a.size == b.size && a.chars == b.chars;
    }
};

// What the sensor answers to one form of a command.
enum class answer : std::uint8_t {
    none,    // this form does not exist
    ack,     // `gN?`            (S1 §8.2.1, §8.2.10, §8.3.1, §8.3.2, §8.3.15)
    set_ack, // `gN<cmd>?`       (S1 §8.1.4); afi / ado echo the selector: `gNafi+a?`
    value,   // `gN<cmd>+v[+v…]` (S1 §8.1.4)
};

struct command_spec {
    mnemonic name;
    std::uint8_t params_a; // form A (usually the get / action form)
    answer answer_a;
    std::uint8_t params_b; // form B (usually the set form)
    answer answer_b;
    bool measures;   // answers after a measurement or a flash write: measurement timeout
    bool no_id;      // sent without an ID (dt, dg: one device on the line only)
    std::int32_t lo; // documented range of the first parameter of form B
    std::int32_t hi;
};

namespace detail {
inline constexpr std::int32_t any_lo = -2147483647 - 1;
inline constexpr std::int32_t any_hi = 2147483647;
inline constexpr std::int32_t max_ms = 86'400'000;
constexpr answer no = answer::none;
} // namespace detail

// S1 §8.2 operation, §8.3 configuration, §8.4 extended configuration, §8.5 information.
inline constexpr std::array<command_spec, 38> command_table{{
    // name  A-params A-answer       B-params B-answer        measures no_id  range of B
    {"c", 0, answer::ack, 0, detail::no, false, false, 0, 0},                     // §8.2.1
    {"g", 0, answer::value, 0, detail::no, true, false, 0, 0},                    // §8.2.2
    {"h", 0, answer::value, 1, answer::value, true, false, 0, detail::max_ms},    // §8.2.3-4
    {"f", 0, answer::value, 1, answer::set_ack, false, false, 0, detail::max_ms}, // §8.2.5
    {"q", 0, answer::value, 0, detail::no, false, false, 0, 0},                   // §8.2.6
    {"m", 0, detail::no, 1, answer::value, true, false, 0, 1},                    // §8.2.7
    {"t", 0, answer::value, 0, detail::no, true, false, 0, 0},                    // §8.2.8
    {"re", 0, answer::value, 0, detail::no, false, false, 0, 0},                  // §8.2.9
    {"ce", 0, answer::set_ack, 0, detail::no, false, false, 0, 0},                // §8.2.9
    {"o", 0, answer::ack, 0, detail::no, false, false, 0, 0},                     // §8.2.10
    {"br", 0, detail::no, 1, answer::ack, false, false, 1, 11},                   // §8.3.1
    {"id", 0, detail::no, 1, answer::ack, false, false, 0, 99},                   // §8.3.2
    {"vm", 0, answer::value, 1, answer::set_ack, false, false, 0, 1},             // §8.3.3
    {"ve", 0, answer::value, 1, answer::set_ack, false, false, 0, 999},           // §8.3.4
    {"v", 0, answer::value, 2, answer::set_ack, false, false, detail::any_lo, detail::any_hi},
    {"ot", 0, answer::value, 1, answer::set_ack, false, false, 0, 2}, // §8.3.6
    {"1", 0, answer::value, 2, answer::set_ack, false, false, detail::any_lo, detail::any_hi},
    {"2", 0, answer::value, 2, answer::set_ack, false, false, detail::any_lo, detail::any_hi},
    {"DI1", 0, answer::value, 1, answer::set_ack, false, false, 0, 8},            // §8.3.8
    {"RI", 0, answer::value, 0, detail::no, false, false, 0, 0},                  // §8.3.9
    {"SSI", 0, answer::value, 1, answer::set_ack, false, false, 0, 63},           // §8.3.10
    {"SSIe", 0, answer::value, 1, answer::set_ack, false, false, -2, 33554431},   // §8.3.11
    {"mc", 0, answer::value, 1, answer::set_ack, false, false, 0, 4},             // §8.3.12
    {"fi", 0, answer::value, 3, answer::set_ack, false, false, 0, 32},            // §8.3.13
    {"A", 0, answer::value, 1, answer::set_ack, false, false, 0, detail::max_ms}, // §8.3.14
    {"d", 0, answer::ack, 0, detail::no, true, false, 0, 0},            // §8.3.15 (flash)
    {"s", 0, answer::set_ack, 0, detail::no, true, false, 0, 0},        // §8.3.16 (flash)
    {"uo", 0, answer::value, 1, answer::set_ack, false, false, 0, 301}, // §8.4.1
    {"uof", 0, answer::value, 1, answer::set_ack, false, false, detail::any_lo, detail::any_hi},
    {"uga", 0, answer::value, 2, answer::set_ack, false, false, detail::any_lo, detail::any_hi},
    {"um", 0, answer::value, 1, answer::set_ack, false, false, 0, 5},  // §8.4.4
    {"afi", 1, answer::value, 2, answer::set_ack, false, false, 1, 3}, // §8.4.5
    {"ado", 1, answer::value, 4, answer::set_ack, false, false, 1, 2}, // §8.4.6
    {"sv", 0, answer::value, 0, detail::no, false, false, 0, 0},       // §8.5.1
    {"sn", 0, answer::value, 0, detail::no, false, false, 0, 0},       // §8.5.2
    {"dt", 0, answer::value, 0, detail::no, false, false, 0, 0},       // §8.5.3 (sNdt / dt)
    {"dt", 0, answer::value, 0, detail::no, false, true, 0, 0},        // §8.5.3 ID-less
    {"dg", 0, answer::value, 0, detail::no, false, true, 0, 0},        // §8.5.4 ID-less
}};

// The index in command_table of a mnemonic sent with or without an ID; command_table.size() if
// not in S1 ch.8. Constant-evaluated code uses this rather than find_spec(): GCC does not take
// "a table entry's address != nullptr" as a constant expression under -fsanitize.
constexpr std::size_t spec_index(const mnemonic& name, bool with_id) noexcept {
    std::size_t i = 0;
    while (i < command_table.size() &&
           !(command_table[i].name == name && command_table[i].no_id != with_id))
        ++i;
    return i;
}

// The table entry for a mnemonic sent with or without an ID; nullptr if not in S1 ch.8.
constexpr const command_spec* find_spec(const mnemonic& name, bool with_id) noexcept {
    const std::size_t i = spec_index(name, with_id);
    return i < command_table.size() ? &command_table[i] : nullptr;
}

// The answer to the form with `params` parameters; answer::none if that form does not exist.
constexpr answer answer_of(const command_spec& s, std::size_t params) noexcept {
    if (params == s.params_a && s.answer_a != answer::none) return s.answer_a;
    if (params == s.params_b) return s.answer_b;
    return answer::none;
}

} // namespace ferrule::dimetix
