// Dimetix answers (S1 §8.1-8.6):
//
//   gN?                    generic acknowledge, also the startup string (§8.1.5 p.40)
//   gN<cmd>?               set acknowledge (§8.1.4); afi / ado echo the selector: gNafi+a?
//   gN<cmd>+v[+v…]         value(s); `-` replaces `+` for negative values (§8.1.3)
//   gN@Ezzz[+b]            error zzz; sNq adds its buffer status b (§8.2.6, §8.6)
//
// Values are read by their separators, not by columns: the manual's widths (`+00001234`)
// are placeholders and unpadded values (`g0g+22`) parse the same (dimetix.md §2, §11.3).
//
// With 2-digit IDs the text is ambiguous (dimetix.md §11.1): `g11?` is ID 11's acknowledge
// or ID 1's answer to the DO1 hysteresis set `s11+…`. parse_reply() reads the ID greedily
// (up to two digits); check_answers() decides with the command that was sent, and
// answered() gives the reply as that command's answer. The sensor session reads each line
// against the command it sent in one step (detail::read_answer()).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/dimetix/command.hpp"
#include "ferrule/dimetix/constants.hpp"
#include "ferrule/dimetix/error.hpp"
#include "ferrule/dimetix/line.hpp" // line_decoder: the lines this header parses
#include "ferrule/dimetix/mnemonic.hpp"

namespace ferrule::dimetix {

enum class reply_kind : std::uint8_t {
    startup_or_ack, // gN?
    set_ack,        // gN<cmd>?  (or gN<cmd>+v?)
    value,          // gN<cmd>+v[+v…]
    error,          // gN@Ezzz[+b]
};

struct reply {
    static constexpr std::size_t max_values = 8;

    std::uint8_t id = 0;
    std::uint8_t id_digits = 1; // as written: `g03?` has 2 (dimetix.md §11.2)
    reply_kind kind = reply_kind::startup_or_ack;
    dimetix::mnemonic mnemonic{};
    std::array<std::int32_t, max_values> values{};
    std::uint8_t count = 0;
    bool truncated = false;         // more than max_values values came; the first ones are kept
    std::uint16_t error_code = 0;   // zzz of gN@Ezzz
    std::int8_t buffer_status = -1; // b of gNq+…+b / gN@Ezzz+b, -1 when absent

    constexpr std::span<const std::int32_t> value_span() const noexcept {
        return {values.data(), count};
    }
};

namespace detail {
constexpr bool is_digit(std::uint8_t c) noexcept {
    return c >= '0' && c <= '9';
}
constexpr bool is_alnum(std::uint8_t c) noexcept {
    return is_digit(c) || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}

// Digits from line[i] on into `value` (at most 2^31); false if there are none or too many.
constexpr bool read_number(std::span<const std::uint8_t> line, std::size_t n, std::size_t& i,
                           std::uint32_t& value) noexcept {
    const std::size_t first = i;
    value = 0;
    while (i < n && is_digit(line[i])) {
        const std::uint32_t d = line[i++] - '0';
        if (value > (2147483648u - d) / 10) return false; // beyond int32
        value = value * 10 + d;
    }
    return i != first;
}

// What parse_tail() reads: values, values whose last one is a buffer status (sNq), or
// `@Ezzz[+b]`.
enum class tail : std::uint8_t { values, values_status, error };

// What follows the ID and mnemonic, from line[i] to n: values `±digits…` ended by the end
// of the line (kind value) or by `?` (kind set_ack); with tail::error, `@Ezzz[+b]` (i at the
// '@'). False if malformed.
constexpr bool parse_tail(std::span<const std::uint8_t> line, std::size_t n, std::size_t i,
                          reply& r, tail t) noexcept {
    const bool error = t == tail::error;
    const bool status_last = t == tail::values_status;
    // The `E` of @E introduces the code like a separator introduces a value.
    i += error;
    // Values, each `+digits` or `-digits`; the sign is the separator (S1 §8.1.3).
    while (i < n &&
           (line[i] == '+' || line[i] == '-' || (error && r.count == 0 && line[i] == 'E'))) {
        const bool negative = line[i++] == '-';
        std::uint32_t v = 0;
        if (!read_number(line, n, i, v) || (!negative && v > 2147483647u)) return false;
        if (r.count == reply::max_values) {
            r.truncated = true;
            continue;
        }
        r.values[r.count++] = static_cast<std::int32_t>(negative ? 0u - v : v);
    }
    if (error) {
        r.kind = reply_kind::error;
        if (i != n || r.count == 0 || r.count > 2 || r.values[0] < 1 || r.values[0] > 999)
            return false;
        r.error_code = static_cast<std::uint16_t>(r.values[0]);
    } else if (i + 1 == n && line[i] == '?') {
        r.kind = reply_kind::set_ack;
    } else if (i == n && r.count > 0) {
        r.kind = reply_kind::value;
    } else {
        return false;
    }
    // The buffer status b of gNq+aaaaaaaa+b and gN@Ezzz+b (S1 §8.2.6): 0, 1 or 2.
    if ((status_last && r.kind == reply_kind::value) || (error && r.count == 2)) {
        const std::int32_t b = r.values[r.count - 1];
        if (r.count < 2 || b < 0 || b > 2) return false;
        r.buffer_status = static_cast<std::int8_t>(b);
    }
    if (error) r.count = 0;
    return true;
}

// The work of parse_reply(). A value answer without mnemonic (`g11+…`) is left as read.
constexpr bool parse_into(std::span<const std::uint8_t> line, reply& r) noexcept {
    std::size_t n = line.size();
    if (n >= 2 && line[n - 2] == cr && line[n - 1] == lf) n -= 2;
    if (n < 3 || line[0] != 'g' || !is_digit(line[1])) return false;
    // ID: up to two digits (0..99); a third digit starts the mnemonic (`g101+…`: ID 10, DO1).
    std::size_t i = 1;
    unsigned id = 0;
    while (i < 3 && is_digit(line[i])) id = id * 10 + (line[i++] - '0');
    r.id = static_cast<std::uint8_t>(id);
    r.id_digits = static_cast<std::uint8_t>(i - 1);
    std::size_t mn = 0;
    while (i < n && is_alnum(line[i])) {
        if (mn == mnemonic::capacity) return false;
        r.mnemonic.chars[mn++] = static_cast<char>(line[i++]);
    }
    r.mnemonic.size = static_cast<std::uint8_t>(mn);
    const bool error = mn == 0 && i + 1 < n && line[i] == '@' && line[i + 1] == 'E';
    const tail t = error ? tail::error : r.mnemonic.is('q') ? tail::values_status : tail::values;
    if (!parse_tail(line, n, i, r, t)) return false;
    if (r.kind == reply_kind::set_ack && mn == 0 && r.count == 0)
        r.kind = reply_kind::startup_or_ack;
    return true;
}
} // namespace detail

// Parses one line (with or without its CR LF).
inline result<reply> parse_reply(std::span<const std::uint8_t> line) noexcept {
    reply r;
    if (!detail::parse_into(line, r)) return errc::malformed;
    if (r.count > 0 && r.mnemonic.size == 0 && r.kind != reply_kind::error) {
        // `g11+…`: a value needs a mnemonic, so the ID's second digit is DO1 / DO2 (S1 §8.3.7).
        const auto last = static_cast<char>('0' + r.id % 10);
        if (r.id_digits != 2 || (last != '1' && last != '2')) return errc::malformed;
        r.id = static_cast<std::uint8_t>(r.id / 10);
        r.id_digits = 1;
        r.mnemonic.chars[0] = last;
        r.mnemonic.size = 1;
    }
    return r;
}

namespace detail {
// The answer a command gets: from the table, else by the set/get convention (S1 §8.1.4).
constexpr answer expected_answer(const command& c) noexcept {
    if (const command_spec* s = find_spec(c.mnemonic, c.id != command::no_id))
        return answer_of(*s, c.param_count);
    return c.param_count > 0 ? answer::set_ack : answer::value;
}

enum class match : std::uint8_t { answer, device_error, other_id, other_answer };

// check_answers() for a command whose expected answer `a` is known.
constexpr match classify(const command& c, answer a, const reply& r) noexcept {
    const bool any_id = c.id == command::no_id; // dt / dg: whichever device is on the line
    const bool own_id = any_id || r.id == c.id;
    if (r.kind == reply_kind::error) return own_id ? match::device_error : match::other_id;
    // `g11?` reads as ID 11's acknowledge; as the answer to `s11+…` (ID 1, DO1) it is
    // DO1's: the ID's second digit is the mnemonic (dimetix.md §11.1). Likewise `g11+…`.
    const unsigned digit = static_cast<unsigned>(c.mnemonic.chars[0] - '0');
    const bool clash = r.mnemonic.size == 0 && r.id_digits == 2 && c.mnemonic.size == 1 &&
                       digit < 10 && r.id == c.id * 10 + digit;
    const bool same = own_id && r.mnemonic == (a == answer::ack ? mnemonic{} : c.mnemonic);
    if (!same && !clash) return own_id ? match::other_answer : match::other_id;
    bool ok = false;
    switch (a) {
    case answer::ack: ok = r.kind == reply_kind::startup_or_ack; break;
    case answer::set_ack:
        ok = (r.kind == reply_kind::set_ack || (clash && r.kind == reply_kind::startup_or_ack)) &&
             (r.count == 0 || (c.param_count > 0 && r.values[0] == c.params[0]));
        break;
    case answer::value:
        // `gNot+a?` is how the manual prints the get answer of sNot (S1 §8.3.6, dimetix.md §11.4).
        ok = r.kind == reply_kind::value || (r.kind == reply_kind::set_ack && r.count > 0);
        break;
    case answer::none: break;
    }
    return ok ? match::answer : match::other_answer;
}
} // namespace detail

// Whether `r` answers `c`, the command just sent: empty if it does; the sensor's error as
// dimetix::device_domain code for `gN@Ezzz` from c's ID; errc::unexpected_address for
// another ID; errc::unexpected_type for an answer of c's ID to something else (the startup
// string `gN?` while waiting for a distance, a tracking line `gNh+…` after sNc, …).
inline ferrule::error check_answers(const command& c, const reply& r) noexcept {
    const answer a = detail::expected_answer(c);
    if (a == answer::none) return errc::invalid_argument;
    switch (detail::classify(c, a, r)) {
    case detail::match::answer: return {};
    case detail::match::device_error: return make_device_error(r.error_code);
    case detail::match::other_id: return errc::unexpected_address;
    case detail::match::other_answer: break;
    }
    return errc::unexpected_type;
}

namespace detail {
constexpr void make_answer(const command& c, answer a, reply& r) noexcept {
    if (c.id != command::no_id) r.id = c.id;
    r.id_digits = r.id >= 10 ? 2 : 1;
    if (a != answer::ack) r.mnemonic = c.mnemonic;
    r.kind = a == answer::ack       ? reply_kind::startup_or_ack
             : a == answer::set_ack ? reply_kind::set_ack
                                    : reply_kind::value;
}

inline constexpr reply blank_reply{}; // what read_answer() starts from

// What a line is to the session waiting for the answer to a command; `timeout` is the
// session's own outcome when no answer came in time (read_answer() never returns it).
enum class line_is : std::uint8_t {
    answer,
    device_error,
    foreign,
    startup,
    skipped,
    malformed,
    timeout
};

// The session's reading of `line` (as line_decoder yields it, without CR LF) while it waits
// for the answer `a` (not answer::none) to `c`: check_answers() on parse_reply()'s work for
// answers and device errors, in one pass that parses only what may answer. `r` gets the line:
// on line_is::answer the reply as answered() gives it, on line_is::device_error gN@Ezzz.
//   answer        `g`, c's ID (1 or 2 digits as parse_reply() reads them, a leading zero
//                 tolerated: dimetix.md §11.2) and, but for gN?, c's mnemonic (S1 §8.1.4),
//                 then a tail of the expected kind: `?` for gN?, `?` or the first parameter
//                 echoed as `+a?` for a set acknowledge (S1 §8.4.5), values for a get (also
//                 `+a?`, S1 §8.3.6). dt / dg take any ID (S1 §8.5.3-8.5.4).
//   device_error  gN@Ezzz[+b] of c's ID (any ID for dt / dg)
//   foreign       another ID's line
//   startup       gN? of c's ID that does not answer c (S1 §8.1.5)
//   skipped       any other line of c's ID
//   malformed     not `g` and a digit, or an error line or c's answer with a malformed tail
// `g11?` reads as ID 11's; as the answer to `s11+…` (ID 1, DO1) the ID's second digit is the
// mnemonic (dimetix.md §11.1), and so it is matched.
constexpr line_is read_answer(const command& c, answer a, std::span<const std::uint8_t> line,
                              reply& r) noexcept {
    r = blank_reply;
    const std::size_t n = line.size();
    if (n < 3 || line[0] != 'g' || !is_digit(line[1])) return line_is::malformed;
    std::size_t i = 1;
    unsigned id = 0;
    while (i < 3 && is_digit(line[i])) id = id * 10 + (line[i++] - '0');
    r.id = static_cast<std::uint8_t>(id);
    r.id_digits = static_cast<std::uint8_t>(i - 1);
    const bool own_id = (c.id == command::no_id) | (id == c.id); // `|`: smaller code than `||`
    if (i + 1 < n && line[i] == '@' && line[i + 1] == 'E') {
        if (!parse_tail(line, n, i, r, tail::error)) return line_is::malformed;
        return own_id ? line_is::device_error : line_is::foreign;
    }
    // The mnemonic from line[h]; for the clash from the ID's second digit.
    std::size_t h = i;
    bool head = own_id;
    if (!own_id && i == 3 && line[1] - '0' == c.id) {
        h = 2;
        head = true;
    }
    const std::size_t len = a == answer::ack ? 0 : c.mnemonic.size;
    for (std::size_t k = 0; head && k < len; ++k, ++h)
        head = h < n && line[h] == static_cast<std::uint8_t>(c.mnemonic.chars[k]);
    if (head && (h == n || !is_alnum(line[h]))) {
        const tail t = c.mnemonic.is('q') ? tail::values_status : tail::values;
        if (!parse_tail(line, n, h, r, t)) return line_is::malformed;
        if (a == answer::value ? r.count > 0
                               : r.kind == reply_kind::set_ack &&
                                     (r.count == 0 || (a == answer::set_ack && c.param_count > 0 &&
                                                       r.values[0] == c.params[0]))) {
            make_answer(c, a, r);
            return line_is::answer;
        }
    }
    if (!own_id) return line_is::foreign;
    return i + 1 == n && line[i] == '?' ? line_is::startup : line_is::skipped;
}
} // namespace detail

// `r` as the answer to `c` (precondition: check_answers(c, r) is empty): ID and mnemonic
// from the command, the kind it expects.
inline reply answered(const command& c, reply r) noexcept {
    detail::make_answer(c, detail::expected_answer(c), r);
    return r;
}

// A distance answer `gNg+…` / `gNh+…` / `gNq+…+b` in user output format 0, 200, 300 or 301
// (S1 §8.4.1 p.50): distance, then signal and temperature (300), then speed (301).
struct measurement {
    std::int32_t distance = 0;    // 0.1 mm
    std::int32_t signal = 0;      // relative signal strength (format 300 / 301)
    std::int32_t temperature = 0; // 0.1 °C (format 300 / 301)
    std::int32_t speed = 0;       // mm/s (format 301); +999999 = invalid (S1 §8.4.1)
    std::uint8_t fields = 0;      // how many of distance, signal, temperature, speed came

    static constexpr std::int32_t invalid_speed = 999999;
};

inline result<measurement> measurement_of(const reply& r) noexcept {
    const auto& m = r.mnemonic;
    if (r.kind != reply_kind::value || !(m.is('g') || m.is('h') || m.is('q')))
        return errc::unexpected_type;
    // sNq's last value is its buffer status, not a measured field.
    const std::size_t n = m.is('q') ? r.count - 1u : r.count;
    if (n != 1 && n != 3 && n != 4) return errc::malformed;
    measurement out;
    out.fields = static_cast<std::uint8_t>(n);
    out.distance = r.values[0];
    if (n >= 3) {
        out.signal = r.values[1];
        out.temperature = r.values[2];
    }
    if (n == 4) out.speed = r.values[3];
    return out;
}

} // namespace ferrule::dimetix
