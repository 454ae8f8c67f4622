// Dimetix answers written as the sensor sends them (S1 §8.1-8.6), the inverse of
// parse_reply() (reply.hpp):
//
//   gN?                    generic acknowledge, also the startup string (§8.1.5 p.40)
//   gN<cmd>?               set acknowledge (§8.1.4); afi / ado echo the selector: gNafi+a?
//   gN<cmd>+v[+v…]         value(s); `-` replaces `+` for negative values (§8.1.3)
//   gN@Ezzz[+b]            error zzz; sNq adds its buffer status b (§8.2.6, §8.6)
//
// reply_encoder builds one line piece by piece, with the width of each field (the manual's
// placeholders, `gNg+aaaaaaaa+bbbbbb+ccc`, S1 §8.4.1): a device side such as the simulated
// sensor writes its answers with it. encode_reply() writes a whole `reply`.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/dimetix/command.hpp" // detail::put_decimal
#include "ferrule/dimetix/constants.hpp"
#include "ferrule/dimetix/reply.hpp"

namespace ferrule::dimetix {

// One answer line of at most max_line_length bytes, CR LF included. What does not fit is
// left out and overflowed() says so; CR LF always fit.
class reply_encoder {
public:
    static constexpr std::size_t max_digits = 10; // every int32 magnitude

    // Starts a new line `gN`, N with at least `id_digits` digits (`g03?`, dimetix.md §11.2).
    void begin(std::uint8_t id, std::size_t id_digits = 1) noexcept {
        size_ = 0;
        overflowed_ = false;
        put('g');
        put_number(id, id_digits);
    }
    void put_mnemonic(std::string_view m) noexcept {
        for (const char c : m) put(static_cast<std::uint8_t>(c));
    }
    // `+v` or `-v`, the sign as separator (S1 §8.1.3), with at least `digits` digits.
    void put_value(std::int32_t v, std::size_t digits = 1) noexcept {
        put(v < 0 ? '-' : '+');
        // Magnitude as unsigned: -2^31 has no positive int32.
        put_number(v < 0 ? 0u - static_cast<std::uint32_t>(v) : static_cast<std::uint32_t>(v),
                   digits);
    }
    // The `?` of gN? and gN<cmd>? (S1 §8.1.4).
    void put_ack() noexcept { put('?'); }
    // `@Ezzz`, three digits (S1 §8.6).
    void put_error(std::uint16_t code) noexcept {
        put('@');
        put('E');
        put_number(code, 3);
    }
    // Ends the line with CR LF and returns it (valid until the next begin()).
    std::span<const std::uint8_t> finish() noexcept {
        text_[size_++] = cr;
        text_[size_++] = lf;
        return bytes();
    }

    std::span<const std::uint8_t> bytes() const noexcept { return {text_.data(), size_}; }
    bool overflowed() const noexcept { return overflowed_; }

private:
    static constexpr std::size_t room = max_line_length - 2; // CR LF

    void put(std::uint8_t c) noexcept {
        if (size_ < room)
            text_[size_++] = c;
        else
            overflowed_ = true;
    }
    void put_number(std::uint32_t v, std::size_t digits) noexcept {
        std::array<std::uint8_t, max_digits> d;
        const std::uint8_t* end =
            detail::put_decimal(d.data(), v, digits < max_digits ? digits : max_digits);
        for (const std::uint8_t* p = d.data(); p != end; ++p) put(*p);
    }

    std::array<std::uint8_t, max_line_length> text_{};
    std::size_t size_ = 0;
    bool overflowed_ = false;
};

namespace detail {
// What parse_reply() could have read `r` from: an ID of 0..99 in 1 or 2 digits, a mnemonic
// where the kind has one, at most max_values values, an error code 1..999, a buffer status
// 0..2 only on sNq's value and on an error.
constexpr bool encodable(const reply& r) noexcept {
    const bool has_mnemonic = r.mnemonic.size > 0;
    if (r.id > max_id || r.id_digits < 1 || r.id_digits > 2 || r.count > reply::max_values ||
        (has_mnemonic && !r.mnemonic.valid_text()))
        return false;
    const bool status_value = r.kind == reply_kind::value && r.mnemonic.is('q');
    const bool status_ok = r.buffer_status >= -1 && r.buffer_status <= 2 &&
                           (r.buffer_status == -1 || status_value || r.kind == reply_kind::error);
    switch (r.kind) {
    case reply_kind::startup_or_ack: return !has_mnemonic && r.count == 0 && status_ok;
    case reply_kind::set_ack: return has_mnemonic && status_ok;
    case reply_kind::value:
        return has_mnemonic && r.count > 0 &&
               (status_value ? r.count >= 2 && r.buffer_status >= 0 &&
                                   r.values[r.count - 1] == r.buffer_status
                             : r.buffer_status == -1);
    case reply_kind::error:
        return !has_mnemonic && r.count == 0 && r.error_code >= 1 && r.error_code <= 999 &&
               status_ok;
    }
    return false;
}
} // namespace detail

// Writes `r` with its CR LF, each value with at least `digits` digits (1: unpadded, as
// `g0g+22`; 8: the manual's `g0g+00000022`). errc::invalid_argument for a reply that no line
// parses to (detail::encodable), errc::buffer_too_small when `out` cannot hold the line or
// the line exceeds max_line_length.
inline result<std::size_t> encode_reply(const reply& r, std::span<std::uint8_t> out,
                                        std::size_t digits = 1) noexcept {
    if (!detail::encodable(r)) return errc::invalid_argument;
    reply_encoder e;
    e.begin(r.id, r.id_digits);
    if (r.kind == reply_kind::error) {
        e.put_error(r.error_code);
        if (r.buffer_status >= 0) e.put_value(r.buffer_status, 1);
    } else {
        e.put_mnemonic(r.mnemonic.view());
        const auto values = r.value_span();
        for (std::size_t i = 0; i < values.size(); ++i)
            e.put_value(values[i], r.buffer_status >= 0 && i + 1 == values.size() ? 1 : digits);
        if (r.kind != reply_kind::value) e.put_ack();
    }
    const auto line = e.finish();
    if (e.overflowed() || out.size() < line.size()) return errc::buffer_too_small;
    for (std::size_t i = 0; i < line.size(); ++i) out[i] = line[i];
    return line.size();
}

} // namespace ferrule::dimetix
