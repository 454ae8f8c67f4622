// MOVILINK telegrams <-> bytes (SC01 §4; MDXB p.27):
//
//   ...idle >= 3.44 ms... | SD | ADR | TYP | PDU (0-14 bytes) | BCC
//   SD  0x02 request (master -> inverter), 0x1D response
//   PDU [8-byte parameter channel] [PD1] [PD2] [PD3], words high byte first
//   BCC XOR of SD .. last PDU byte
//
// encode() writes into the caller's buffer; decoder frames incoming bytes by idle gap +
// SD + the length TYP implies, never by searching for 0x02/0x1D (which occur in data).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/bytes.hpp"
#include "ferrule/core/checksum.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/movilink/constants.hpp"
#include "ferrule/movilink/param.hpp"

namespace ferrule::movilink {

enum class direction : std::uint8_t { request, response };

constexpr std::uint8_t start_delimiter(direction d) noexcept {
    return d == direction::request ? sd1_request : sd2_response;
}

struct telegram {
    direction dir = direction::request;
    std::uint8_t address = 0;
    pdu_type type = pdu_type::pd3;
    param_channel param{};                        // used when has_param(type)
    std::array<std::uint16_t, max_pd_words> pd{}; // PD1..PD3, first pd_words(type) used

    friend constexpr bool operator==(const telegram& a, const telegram& b) noexcept {
        if (a.dir != b.dir || a.address != b.address || a.type != b.type) return false;
        if (has_param(a.type) && a.param != b.param) return false;
        for (std::size_t i = 0; i < pd_words(a.type); ++i)
            if (a.pd[i] != b.pd[i]) return false;
        return true;
    }
};

// Compile-time layout: for a PDU type fixed at compile time the offsets are constants and
// the encoder is straight-line code.
template <pdu_type T>
constexpr void encode_fixed(const telegram& t,
                            std::span<std::uint8_t, telegram_size(T)> out) noexcept {
    out[0] = start_delimiter(t.dir);
    out[1] = t.address;
    out[2] = static_cast<std::uint8_t>(T);
    std::size_t i = 3;
    if constexpr (has_param(T)) {
        t.param.store(&out[i]);
        i += param_channel_size;
    }
    for (std::size_t w = 0; w < pd_words(T); ++w, i += 2) store_be16(&out[i], t.pd[w]);
    out[i] = xor_bcc(std::span<const std::uint8_t>(out.data(), i));
}

// Runtime form: any documented TYP. Returns the telegram size.
inline result<std::size_t> encode(const telegram& t, std::span<std::uint8_t> out) noexcept {
    const auto typ = static_cast<std::uint8_t>(t.type);
    if (!is_valid_pdu_type(typ)) return errc::invalid_argument;
    const std::size_t n = telegram_size(t.type);
    if (out.size() < n) return errc::buffer_too_small;
    out[0] = start_delimiter(t.dir);
    out[1] = t.address;
    out[2] = typ;
    std::size_t i = 3;
    if (has_param(t.type)) {
        t.param.store(&out[i]);
        i += param_channel_size;
    }
    for (std::size_t w = 0; w < pd_words(t.type); ++w, i += 2) store_be16(&out[i], t.pd[w]);
    out[i] = xor_bcc(out.first(i));
    return n;
}

// Parses one complete telegram (exactly telegram_size(TYP) bytes).
inline result<telegram> parse(std::span<const std::uint8_t> in) noexcept {
    if (in.size() < 4) return errc::malformed;
    telegram t;
    if (in[0] == sd1_request)
        t.dir = direction::request;
    else if (in[0] == sd2_response)
        t.dir = direction::response;
    else
        return errc::malformed;
    if (!is_valid_pdu_type(in[2])) return errc::malformed;
    t.address = in[1];
    t.type = static_cast<pdu_type>(in[2]);
    const std::size_t n = telegram_size(t.type);
    if (in.size() != n) return errc::malformed;
    if (xor_bcc(in.first(n - 1)) != in[n - 1]) return errc::bad_checksum;
    std::size_t i = 3;
    if (has_param(t.type)) {
        t.param = param_channel::load(&in[i]);
        i += param_channel_size;
    }
    for (std::size_t w = 0; w < pd_words(t.type); ++w, i += 2) t.pd[w] = load_be16(&in[i]);
    return t;
}

// Incremental decoder. The caller reports idle gaps (bus silent >= start pause) with
// idle(); a telegram may only begin right after one. After an error the decoder skips
// everything until the next idle gap, counting what it skipped.
class decoder {
public:
    enum class accept : std::uint8_t { requests, responses, both };
    enum class status : std::uint8_t { need_more, frame, error };

    struct step {
        std::size_t consumed = 0;
        decoder::status what = status::need_more;
        ferrule::error ec{};
    };

    explicit constexpr decoder(accept which = accept::both) noexcept : accept_(which) {}

    // Bus was idle: the next byte may be a start delimiter.
    constexpr void idle() noexcept {
        state_ = state::await_sd;
        size_ = 0;
    }

    // Consumes bytes until a telegram completes, an error is found, or input runs out.
    step feed(std::span<const std::uint8_t> in) noexcept {
        step s;
        while (s.consumed < in.size()) {
            const std::uint8_t b = in[s.consumed++];
            switch (state_) {
            case state::skip: ++skipped_; continue;
            case state::complete: // bytes after a complete telegram without an idle gap
                size_ = 0;
                return fail(s, errc::malformed);
            case state::await_sd:
                if (!sd_accepted(b)) return fail(s, errc::malformed);
                buf_[0] = b;
                size_ = 1;
                state_ = state::header;
                continue;
            case state::header:
                if (size_ == 2) {
                    if (!is_valid_pdu_type(b)) return fail(s, errc::malformed);
                    expected_ = telegram_size(static_cast<pdu_type>(b));
                    state_ = state::body;
                }
                buf_[size_++] = b;
                continue;
            case state::body:
                if (size_ + 1 < expected_) {
                    buf_[size_++] = b;
                    continue;
                }
                if (xor_bcc(std::span<const std::uint8_t>(buf_.data(), size_)) != b)
                    return fail(s, errc::bad_checksum);
                buf_[size_++] = b;
                state_ = state::complete;
                s.what = status::frame;
                return s;
            }
        }
        return s;
    }

    // The telegram's bytes, valid after feed() reported status::frame.
    constexpr std::span<const std::uint8_t> frame() const noexcept { return {buf_.data(), size_}; }
    constexpr bool in_frame() const noexcept {
        return state_ == state::header || state_ == state::body;
    }
    constexpr std::size_t buffered() const noexcept { return size_; }
    // Bytes thrown away while resynchronising since construction.
    constexpr std::size_t skipped() const noexcept { return skipped_; }

private:
    enum class state : std::uint8_t { await_sd, header, body, complete, skip };

    constexpr bool sd_accepted(std::uint8_t b) const noexcept {
        switch (accept_) {
        case accept::requests: return b == sd1_request;
        case accept::responses: return b == sd2_response;
        case accept::both: return b == sd1_request || b == sd2_response;
        }
        return false;
    }
    // The offending byte is never stored: it and the partial telegram are skipped.
    step fail(step s, errc e) noexcept {
        skipped_ += size_ + 1;
        size_ = 0;
        state_ = state::skip;
        s.what = status::error;
        s.ec = make_error(e);
        return s;
    }

    std::array<std::uint8_t, max_telegram_size> buf_{};
    std::size_t size_ = 0;
    std::size_t expected_ = 0;
    std::size_t skipped_ = 0;
    accept accept_;
    state state_ = state::await_sd;
};

} // namespace ferrule::movilink
