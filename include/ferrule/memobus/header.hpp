// The 218 header (protocols/memobus.md §2) and the framing of a byte stream into messages:
//
//   0  command type   0x11 command, 0x19 response, 0x12 general-purpose message
//   1  serial number  per connection, 00…FF and round again; the response echoes it
//   2  destination channel, 3 source channel (00 from a device that is not an MP)
//   4…5 reserved 0
//   6…7 total length, little-endian: header + MEMOBUS length field + MEMOBUS data
//   8…11 reserved 0
//
// A command or response continues with the MEMOBUS length (2 bytes, little-endian: the bytes
// from MFC to the end) that must equal total − 14 (FieldLink and Yaskawa's Delphi sample
// check it, §10.1). Over TCP, message_decoder reads 12 bytes, then total − 12 more; over
// UDP one datagram is one message (parse_message()).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/bytes.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/frame_scanner.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/memobus/constants.hpp"

namespace ferrule::memobus {

struct header {
    command_type type = command_type::command;
    std::uint8_t serial = 0;
    std::uint8_t destination_channel = 0;
    std::uint8_t source_channel = 0;
    std::uint16_t total = 0; // the whole message, this header included
};

constexpr void store_header(const header& h, std::uint8_t* out) noexcept {
    out[0] = static_cast<std::uint8_t>(h.type);
    out[1] = h.serial;
    out[2] = h.destination_channel;
    out[3] = h.source_channel;
    out[4] = out[5] = 0;
    store_le16(out + 6, h.total);
    out[8] = out[9] = out[10] = out[11] = 0;
}

constexpr header load_header(const std::uint8_t* p) noexcept {
    header h;
    h.type = static_cast<command_type>(p[0]);
    h.serial = p[1];
    h.destination_channel = p[2];
    h.source_channel = p[3];
    h.total = load_le16(p + 6);
    return h;
}

namespace detail {
constexpr bool known_type(std::uint8_t t) noexcept {
    return t == static_cast<std::uint8_t>(command_type::command) ||
           t == static_cast<std::uint8_t>(command_type::response) ||
           t == static_cast<std::uint8_t>(command_type::general);
}
// The message's length from its first bytes: 0 = need more; no_message = none starts here.
inline constexpr std::size_t no_message = static_cast<std::size_t>(-1);
constexpr std::size_t expected_length(std::span<const std::uint8_t> p) noexcept {
    if (p.empty()) return 0;
    if (!known_type(p[0])) return no_message;
    if (p.size() < header_size) return 0;
    const std::size_t total = load_le16(p.data() + 6);
    const bool general = p[0] == static_cast<std::uint8_t>(command_type::general);
    const std::size_t least = general ? header_size : header_size + length_size + 1;
    if (total < least || total > max_message) return no_message;
    return total;
}
// A command or response whose MEMOBUS length agrees with the total `total` (its first 14
// bytes are enough).
constexpr bool length_agrees(std::span<const std::uint8_t> m, std::size_t total) noexcept {
    if (m[0] == static_cast<std::uint8_t>(command_type::general)) return true;
    return load_le16(m.data() + header_size) + header_size + length_size == total;
}
} // namespace detail

// One UDP datagram as a message: its total length must be the datagram's (§6).
inline result<header> parse_message(std::span<const std::uint8_t> datagram) noexcept {
    const std::size_t n = detail::expected_length(datagram);
    if (n == 0 || n == detail::no_message || n != datagram.size() ||
        !detail::length_agrees(datagram, datagram.size()))
        return errc::malformed;
    return load_header(datagram.data());
}

// Splits a TCP byte stream into messages; the step API of modbus::rtu_decoder. A header
// with an unknown type, a total length below its minimum or above max_message (a length of
// 65535, say), or a MEMOBUS length that does not agree is errc::malformed, reported once per
// run; one byte is dropped and framing tried again from the next.
class message_decoder : public frame_scanner<message_decoder, max_message> {
public:
    // The message just yielded (valid until the next feed() or reset()).
    std::span<const std::uint8_t> message() const noexcept { return {buf_.data(), frame_size_}; }
    memobus::header header() const noexcept { return load_header(buf_.data()); }
    // The MEMOBUS part: length field, MFC, SFC, CPU, body (commands and responses).
    std::span<const std::uint8_t> body() const noexcept { return message().subspan(header_size); }

    bool in_message() const noexcept { return in_frame(); }

private:
    friend frame_scanner;
    static constexpr bool reads_ahead = true;

    // Bytes up to the end of the header, then up to the end of the message, at once.
    std::size_t wanted() const noexcept {
        if (size_ < header_size) return header_size - size_;
        const std::size_t n = detail::expected_length({buf_.data(), size_});
        return n == 0 || n == detail::no_message || n <= size_ ? 1 : n - size_;
    }

    step scan() noexcept {
        for (;;) {
            if (size_ == 0) return {};
            const std::size_t n = detail::expected_length({buf_.data(), size_});
            if (n == 0) return {};
            // The MEMOBUS length is checked as soon as it is in (byte 14), so a header that
            // disagrees with itself is dropped without waiting for the total it announces.
            const bool length_in = size_ >= header_size + length_size;
            if (n == detail::no_message ||
                (length_in && !detail::length_agrees({buf_.data(), std::min(n, size_)}, n))) {
                if (drop_garbage()) return {status::error, 0, errc::malformed};
                continue;
            }
            if (size_ < n) return {};
            return yield(n);
        }
    }
};

} // namespace ferrule::memobus
