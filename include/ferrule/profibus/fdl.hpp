// PROFIBUS FDL telegrams (protocols/modbus_profibus.md §B.2, §B.3):
//
//   SD1  10 DA SA FC FCS 16                      no data unit
//   SD2  68 LE LEr 68 DA SA FC DU… FCS 16        LE = 3 + |DU|, 4…249, LEr = LE
//   SD3  A2 DA SA FC DU(8) FCS 16                exactly 8 bytes of data unit
//   SD4  DC DA SA                                token
//   SC   E5                                      short acknowledgement
//
// FCS is the byte sum mod 256 of DA, SA, FC and the data unit. Bit 7 of DA (SA) says that the
// data unit begins with a DSAP (SSAP) byte; `telegram` holds the SAP numbers apart from the
// data. An 8-byte data unit (SAP bytes included) may come as SD2 or SD3: both decode the
// same; encode() sends SD3, or SD2 when asked (a real ET200S answers with SD2).
//
// fdl_decoder frames a byte stream by start delimiter and length, checks LE = LEr, FCS and
// ED, and after an error drops the first byte and looks again from the next, so a telegram
// behind garbage is still found. A SAP byte with bit 7 (a further extension follows) or
// bit 6 (a segment address) set, and a token with an address extension, are telegrams DP
// does not use (§B.3): malformed, not decoded with those bits lost.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/frame_scanner.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/profibus/constants.hpp"

namespace ferrule::profibus {

enum class frame : std::uint8_t { sd1, sd2, sd3, sd4, short_ack };

inline constexpr std::uint8_t no_sap = 0xFF;

struct telegram {
    profibus::frame frame = profibus::frame::sd1;
    std::uint8_t da = 0; // 0…127, without the extension bit
    std::uint8_t sa = 0;
    std::uint8_t fc = 0;
    std::uint8_t dsap = no_sap; // a SAP number 0…63, or no_sap
    std::uint8_t ssap = no_sap;
    std::span<const std::uint8_t> data{}; // the data unit after the SAP bytes

    constexpr bool is_request() const noexcept { return (fc & fc_request) != 0; }
    constexpr bool fcb() const noexcept { return (fc & fc_fcb) != 0; }
    constexpr bool fcv() const noexcept { return (fc & fc_fcv) != 0; }
    constexpr std::uint8_t function() const noexcept { return fc & fc_function_mask; }
};

constexpr std::uint8_t request_code(request_fn f, bool fcb, bool fcv) noexcept {
    return static_cast<std::uint8_t>(fc_request | (fcb ? fc_fcb : 0) | (fcv ? fc_fcv : 0) |
                                     static_cast<std::uint8_t>(f));
}
constexpr std::uint8_t response_code(response_fn f) noexcept {
    return static_cast<std::uint8_t>(station_slave | static_cast<std::uint8_t>(f));
}

constexpr std::uint8_t fcs(std::span<const std::uint8_t> bytes) noexcept {
    std::uint8_t sum = 0;
    for (const std::uint8_t b : bytes) sum = static_cast<std::uint8_t>(sum + b);
    return sum;
}

struct encode_options {
    bool sd2_for_8_bytes = false; // send an 8-byte data unit as SD2 instead of SD3
};

// Writes `t` to `out`. The frame is chosen from the content: SD1 without data or SAPs, SD3
// for an 8-byte data unit, SD2 otherwise; t.frame matters only for SD4 and the short
// acknowledgement. invalid_argument for an address above 127, a SAP above 63 or a data unit
// longer than 246 bytes (SAPs included).
inline result<std::size_t> encode(const telegram& t, std::span<std::uint8_t> out,
                                  encode_options o = {}) noexcept {
    if (t.frame == frame::short_ack) {
        if (out.empty()) return errc::buffer_too_small;
        out[0] = sc;
        return std::size_t{1};
    }
    if (t.da > broadcast_address || t.sa > broadcast_address) return errc::invalid_argument;
    if (t.frame == frame::sd4) {
        if (out.size() < 3) return errc::buffer_too_small;
        out[0] = sd4;
        out[1] = t.da;
        out[2] = t.sa;
        return std::size_t{3};
    }
    const bool has_dsap = t.dsap != no_sap;
    const bool has_ssap = t.ssap != no_sap;
    if ((has_dsap && t.dsap > sap_mask) || (has_ssap && t.ssap > sap_mask))
        return errc::invalid_argument;
    const std::size_t du = t.data.size() + (has_dsap ? 1u : 0u) + (has_ssap ? 1u : 0u);
    if (du > max_data) return errc::invalid_argument;
    const bool sd1_fits = du == 0;
    const bool sd3_fits = du == sd3_data && !o.sd2_for_8_bytes;
    const std::size_t header = sd1_fits || sd3_fits ? 1 : 4;
    const std::size_t n = header + 3 + du + 2;
    if (out.size() < n) return errc::buffer_too_small;
    if (sd1_fits) {
        out[0] = sd1;
    } else if (sd3_fits) {
        out[0] = sd3;
    } else {
        out[0] = sd2;
        out[1] = out[2] = static_cast<std::uint8_t>(du + 3);
        out[3] = sd2;
    }
    std::size_t i = header;
    out[i++] = static_cast<std::uint8_t>(t.da | (has_dsap ? address_extension : 0));
    out[i++] = static_cast<std::uint8_t>(t.sa | (has_ssap ? address_extension : 0));
    out[i++] = t.fc;
    if (has_dsap) out[i++] = t.dsap;
    if (has_ssap) out[i++] = t.ssap;
    for (const std::uint8_t b : t.data) out[i++] = b;
    out[i] = fcs(out.subspan(header, i - header));
    out[i + 1] = ed;
    return n;
}

// Splits a byte stream into telegrams. Feed it with
//     do { s = d.feed(in); in = in.subspan(s.consumed); … } while (s.what != status::need_more);
// need_more: every byte given is used and no telegram is complete. Each FCS error is
// reported (errc::bad_checksum); a run of bytes that start no telegram, a wrong LEr, second
// SD2 or ED once (errc::malformed).
class fdl_decoder : public frame_scanner<fdl_decoder, max_telegram> {
public:
    // The line has been idle (a telegram has no gaps inside, §B.1): what is buffered will not
    // be completed. Call like feed() until need_more; drops bytes until a telegram or nothing
    // is left.
    step finish() noexcept { return drain(); }

    // The telegram just yielded; its data spans the decoder's buffer (valid until the next
    // feed(), finish() or reset()).
    const profibus::telegram& telegram() const noexcept { return t_; }
    std::span<const std::uint8_t> bytes() const noexcept { return {buf_.data(), frame_size_}; }

private:
    friend frame_scanner;

    // Telegram length from the first bytes: 0 = need more; `bad` = these bytes start none.
    static constexpr std::size_t bad = static_cast<std::size_t>(-1);
    std::size_t expected() const noexcept {
        switch (buf_[0]) {
        case sc: return 1;
        case sd4: return 3;
        case sd1: return 6;
        case sd3: return 6 + sd3_data;
        case sd2: {
            if (size_ < 4) return 0;
            const std::size_t le = buf_[1];
            if (le < sd2_min_le || le > sd2_max_le || buf_[2] != le || buf_[3] != sd2) return bad;
            return le + 6;
        }
        default: return bad;
        }
    }

    step scan() noexcept {
        for (;;) {
            if (size_ == 0) return {};
            const std::size_t len = expected();
            if (len == 0) return {};
            if (len == bad) {
                if (drop_garbage()) return {status::error, 0, errc::malformed};
                continue;
            }
            if (size_ < len) return {};
            if (len >= 6) {
                const std::size_t header = buf_[0] == sd2 ? 4 : 1;
                const auto body =
                    std::span<const std::uint8_t>(buf_.data() + header, len - header - 2);
                if (buf_[len - 1] != ed) {
                    if (drop_garbage()) return {status::error, 0, errc::malformed};
                    continue;
                }
                if (fcs(body) != buf_[len - 2]) {
                    drop_failed();
                    return {status::error, 0, errc::bad_checksum};
                }
                if (!parse(body)) {
                    if (drop_garbage()) return {status::error, 0, errc::malformed};
                    continue;
                }
            } else if (!parse_short()) {
                if (drop_garbage()) return {status::error, 0, errc::malformed};
                continue;
            }
            return yield(len);
        }
    }

    // DA SA FC [DSAP] [SSAP] DU…; false when the SAP bytes the addresses announce are missing.
    bool parse(std::span<const std::uint8_t> body) noexcept {
        profibus::telegram t;
        t.frame = buf_[0] == sd1 ? frame::sd1 : buf_[0] == sd3 ? frame::sd3 : frame::sd2;
        t.da = static_cast<std::uint8_t>(body[0] & 0x7F);
        t.sa = static_cast<std::uint8_t>(body[1] & 0x7F);
        t.fc = body[2];
        std::size_t i = 3;
        if (body[0] & address_extension) {
            if (i >= body.size() || body[i] > sap_mask) return false;
            t.dsap = body[i++];
        }
        if (body[1] & address_extension) {
            if (i >= body.size() || body[i] > sap_mask) return false;
            t.ssap = body[i++];
        }
        t.data = body.subspan(i);
        t_ = t;
        return true;
    }

    // SC, or SD4 DA SA (token addresses carry no extension).
    bool parse_short() noexcept {
        profibus::telegram t;
        if (buf_[0] == sc) {
            t.frame = frame::short_ack;
        } else {
            if ((buf_[1] | buf_[2]) & address_extension) return false;
            t.frame = frame::sd4;
            t.da = buf_[1];
            t.sa = buf_[2];
        }
        t_ = t;
        return true;
    }

    profibus::telegram t_{};
};

} // namespace ferrule::profibus
