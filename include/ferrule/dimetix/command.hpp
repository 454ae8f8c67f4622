// Dimetix requests: `s` + ID + mnemonic + parameters + CR LF (S1 §8.1 p.40).
//
//   s0g⏎   s3eg+100⏎   s0v+0+100000⏎   sN2-500-495⏎   dg⏎ (no ID)
//
// A parameter is introduced by `+`, or by `-` where it is negative: the sign is the
// separator (S1 §8.1.3 p.40), so `+-` or `++` never appear. Values are written without
// padding as in the manual's examples; command::digits zero-pads for firmware that wants
// fixed widths (`s0br+07`, dimetix.md §2).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/dimetix/constants.hpp"
#include "ferrule/dimetix/mnemonic.hpp"

namespace ferrule::dimetix {

struct command {
    static constexpr std::uint8_t no_id = 0xFF; // ID-less dt / dg (S1 §8.5.3-8.5.4)
    static constexpr std::size_t max_params = 4;

    std::uint8_t id = 0; // 0..max_id, or no_id
    dimetix::mnemonic mnemonic{};
    std::array<std::int32_t, max_params> params{};
    std::uint8_t param_count = 0;
    std::uint8_t digits = 0; // minimum digits per parameter (zero-padded); 0 = as needed

    constexpr std::span<const std::int32_t> parameters() const noexcept {
        return {params.data(), param_count <= max_params ? param_count : std::size_t{0}};
    }
    friend constexpr bool operator==(const command&, const command&) = default;
};

constexpr command make_command(std::uint8_t id, std::string_view m,
                               std::span<const std::int32_t> p = {}) noexcept {
    command c;
    c.id = id;
    c.mnemonic = dimetix::mnemonic(m);
    for (std::size_t i = 0; i < p.size() && i < command::max_params; ++i) c.params[i] = p[i];
    c.param_count = static_cast<std::uint8_t>(p.size() <= command::max_params ? p.size() : 0xFF);
    return c;
}
constexpr command make_command(std::uint8_t id, std::string_view m, std::int32_t p0) noexcept {
    const std::int32_t p[1] = {p0};
    return make_command(id, m, p);
}

// --- operation commands (S1 §8.2) -----------------------------------------------------------
constexpr command stop_clear(std::uint8_t id) noexcept {
    return make_command(id, "c");
}
constexpr command distance(std::uint8_t id) noexcept {
    return make_command(id, "g");
}
// Continuous output: single-sensor lines only (S1 §5.8 p.20, §8.2.3-8.2.4 p.41).
constexpr command tracking(std::uint8_t id) noexcept {
    return make_command(id, "h");
}
constexpr command tracking(std::uint8_t id, std::int32_t sampling_ms) noexcept {
    return make_command(id, "h", sampling_ms);
}
// sNf+: tracking into a one-value buffer, read with sNq; safe on multi-drop (S1 §8.2.5).
constexpr command tracking_buffered(std::uint8_t id, std::int32_t sampling_ms) noexcept {
    return make_command(id, "f", sampling_ms);
}
constexpr command read_buffer(std::uint8_t id) noexcept {
    return make_command(id, "q");
}
// sNm+0 single, sNm+1 repetitive (continuous) (S1 §8.2.7 p.42).
constexpr command signal(std::uint8_t id, bool repetitive) noexcept {
    return make_command(id, "m", repetitive ? 1 : 0);
}
constexpr command temperature(std::uint8_t id) noexcept {
    return make_command(id, "t");
}
constexpr command read_error_stack(std::uint8_t id) noexcept {
    return make_command(id, "re");
}
constexpr command clear_error_stack(std::uint8_t id) noexcept {
    return make_command(id, "ce");
}
constexpr command laser_on(std::uint8_t id) noexcept {
    return make_command(id, "o");
}

// --- information (S1 §8.5) ------------------------------------------------------------------
constexpr command software_version(std::uint8_t id) noexcept {
    return make_command(id, "sv");
}
constexpr command serial_number(std::uint8_t id) noexcept {
    return make_command(id, "sn");
}
constexpr command device_type(std::uint8_t id) noexcept {
    return make_command(id, "dt");
}
constexpr command device_type() noexcept {
    return make_command(command::no_id, "dt");
}
constexpr command generation() noexcept {
    return make_command(command::no_id, "dg");
}

// --- configuration (S1 §8.3) ----------------------------------------------------------------
constexpr command save_configuration(std::uint8_t id) noexcept {
    return make_command(id, "s");
}
constexpr command factory_default(std::uint8_t id) noexcept {
    return make_command(id, "d");
}
constexpr command set_id(std::uint8_t id, std::uint8_t new_id) noexcept {
    return make_command(id, "id", new_id);
}
// Communication setting code: 1, 2, 6, 7 (default), 10, 11; active after a power cycle.
constexpr command set_comm(std::uint8_t id, std::int32_t code) noexcept {
    return make_command(id, "br", code);
}

// Is `code` a communication setting of S1 §8.3.1 p.44?
constexpr bool is_comm_setting(std::int32_t code) noexcept {
    return code == 1 || code == 2 || code == 6 || code == 7 || code == 10 || code == 11;
}

// A command the D-Series documents (S1 ch.8): known mnemonic, ID 0..99 (or none for
// dt / dg), a documented number of parameters, the first one in its documented range.
constexpr bool validate(const command& c) noexcept {
    if (c.param_count > command::max_params || (c.id > max_id && c.id != command::no_id))
        return false;
    const command_spec* s = find_spec(c.mnemonic, c.id != command::no_id);
    if (!s || answer_of(*s, c.param_count) == answer::none) return false;
    if (c.param_count == s->params_b && c.param_count > 0 && s->answer_b != answer::none) {
        if (c.params[0] < s->lo || c.params[0] > s->hi) return false;
        if (s->lo == 1 && s->hi == 11 && !is_comm_setting(c.params[0])) return false; // sNbr
    }
    return true;
}

// Get form of a configuration / extended configuration / information command (S1 §8.3-8.5);
// `selector` only for afi / ado, whose get carries the filter or output number.
inline result<command> get(std::uint8_t id, std::string_view m,
                           std::span<const std::int32_t> selector = {}) noexcept {
    if (id > max_id) return errc::invalid_argument;
    const command c = make_command(id, m, selector);
    const command_spec* s = find_spec(c.mnemonic, true);
    if (!validate(c) || s->answer_a != answer::value || s->measures) return errc::invalid_argument;
    return c;
}
// Set form of a configuration / extended configuration command (S1 §8.3-8.4).
inline result<command> set(std::uint8_t id, std::string_view m,
                           std::span<const std::int32_t> values) noexcept {
    if (id > max_id) return errc::invalid_argument;
    const command c = make_command(id, m, values);
    if (!validate(c) || values.empty()) return errc::invalid_argument;
    const command_spec* s = find_spec(c.mnemonic, true);
    if (s->measures || values.size() != s->params_b) return errc::invalid_argument;
    return c;
}

// sNh, sNh+t, sNm+1: the sensor keeps sending (S1 §5.8 p.20, §8.2.3-8.2.4, §8.2.7).
constexpr bool is_continuous(const command& c) noexcept {
    return c.mnemonic.is('h') || (c.mnemonic.is('m') && c.param_count == 1 && c.params[0] == 1);
}

namespace detail {
// Writes `v` in decimal with at least `digits` digits (zero-padded); returns the end.
inline std::uint8_t* put_decimal(std::uint8_t* p, std::uint32_t v, std::size_t digits) noexcept {
    std::size_t n = 1;
    for (std::uint32_t rest = v; rest >= 10; rest /= 10) ++n;
    std::uint8_t* const end = p + (n < digits ? digits : n);
    for (std::uint8_t* q = end; q != p; v /= 10) *--q = static_cast<std::uint8_t>('0' + v % 10);
    return end;
}

// Writes a command that encode() has checked; `out` holds max_request_length bytes.
inline std::size_t encode_unchecked(const command& c, std::uint8_t* out) noexcept {
    std::uint8_t* p = out;
    if (c.id != command::no_id) {
        *p++ = 's';
        p = put_decimal(p, c.id, 1);
    }
    for (std::size_t i = 0; i < c.mnemonic.size; ++i)
        *p++ = static_cast<std::uint8_t>(c.mnemonic.chars[i]);
    for (std::size_t i = 0; i < c.param_count; ++i) {
        const std::int32_t v = c.params[i];
        *p++ = v < 0 ? '-' : '+';
        // Magnitude as unsigned: -2^31 has no positive int32.
        p = put_decimal(p,
                        v < 0 ? 0u - static_cast<std::uint32_t>(v) : static_cast<std::uint32_t>(v),
                        c.digits);
    }
    *p++ = cr;
    *p++ = lf;
    return static_cast<std::size_t>(p - out);
}
} // namespace detail

// Writes `sN<mnemonic>[±p…]\r\n` (or `<mnemonic>\r\n` without ID). Checks only the syntax
// (mnemonic text, ID range, parameter count), so manual examples such as `s3eg+100` can be
// written; validate() checks against the command set.
inline result<std::size_t> encode(const command& c, std::span<std::uint8_t> out) noexcept {
    if (!c.mnemonic.valid_text() || c.param_count > command::max_params || c.digits > 10 ||
        (c.id > max_id && c.id != command::no_id))
        return errc::invalid_argument;
    std::array<std::uint8_t, max_request_length> buf;
    const std::size_t n = detail::encode_unchecked(c, buf.data());
    if (out.size() < n) return errc::buffer_too_small;
    for (std::size_t i = 0; i < n; ++i) out[i] = buf[i];
    return n;
}

// Reads a request line (with or without CR LF), for sensor simulators and capture decoding.
// The ID is read greedily (up to two digits); `s11+…` and `s21`, which would leave no
// mnemonic, are ID 1 / ID 2 with DO hysteresis 1 (S1 §8.3.7; dimetix.md §11.1).
inline result<command> parse_request(std::span<const std::uint8_t> line) noexcept {
    std::size_t n = line.size();
    if (n >= 2 && line[n - 2] == cr && line[n - 1] == lf) n -= 2;
    command c;
    std::size_t i = 0;
    if (n > 0 && line[0] == 's') {
        c.id = 0;
        i = 1;
        while (i < n && i < 3 && line[i] >= '0' && line[i] <= '9')
            c.id = static_cast<std::uint8_t>(c.id * 10 + (line[i++] - '0'));
        if (i == 1) return errc::malformed;
    } else {
        c.id = command::no_id;
    }
    const std::size_t id_end = i;
    std::size_t mn = 0;
    while (i < n && ((line[i] >= 'a' && line[i] <= 'z') || (line[i] >= 'A' && line[i] <= 'Z') ||
                     (line[i] >= '0' && line[i] <= '9'))) {
        if (mn == mnemonic::capacity) return errc::malformed;
        c.mnemonic.chars[mn++] = static_cast<char>(line[i++]);
    }
    c.mnemonic.size = static_cast<std::uint8_t>(mn);
    if (mn == 0) {
        const std::uint8_t last = id_end == 3 ? line[2] : 0;
        if (last != '1' && last != '2') return errc::malformed;
        c.id = static_cast<std::uint8_t>(c.id / 10);
        c.mnemonic = dimetix::mnemonic(last == '1' ? "1" : "2");
    }
    while (i < n && (line[i] == '+' || line[i] == '-')) {
        const bool negative = line[i++] == '-';
        std::uint32_t mag = 0;
        const std::size_t first = i;
        while (i < n && line[i] >= '0' && line[i] <= '9') {
            const std::uint32_t d = line[i++] - '0';
            if (mag > (2147483648u - d) / 10) return errc::malformed;
            mag = mag * 10 + d;
        }
        if (i == first || (!negative && mag > 2147483647u) || c.param_count == command::max_params)
            return errc::malformed;
        c.params[c.param_count++] =
            negative ? static_cast<std::int32_t>(0u - mag) : static_cast<std::int32_t>(mag);
    }
    if (i != n) return errc::malformed;
    return c;
}

} // namespace ferrule::dimetix
