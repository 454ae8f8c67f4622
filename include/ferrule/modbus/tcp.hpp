// Modbus TCP ADU (TCP §3.1.2, §3.1.3): the MBAP header, then the PDU.
//
//   transaction id (2)  echoed by the server: pairs a response with its request
//   protocol id (2)     0 = Modbus
//   length (2)          bytes that follow: unit id + PDU, 2…254
//   unit id (1)         the server behind a gateway (serial address), else 0xFF or 0
//
// All fields big-endian. There is no checksum: TCP carries none (TCP §3.1.3).
//
// Two ways to frame a stream: tcp_decoder keeps each ADU and resynchronises after bytes that
// start none, one byte at a time (the client and server sessions read with it); mbap_framer
// only finds where ADUs end, and stops at such bytes: for a server that times requests as
// their bytes come and gives up on a stream it cannot frame.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/bytes.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/frame_scanner.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/modbus/constants.hpp"

namespace ferrule::modbus {

// The MBAP checks (TCP §3.1.3): the protocol id of a Modbus ADU is 0, and its length field
// counts the unit id and a PDU of 1…253 bytes.
constexpr bool mbap_protocol_ok(const std::uint8_t* header) noexcept {
    return load_be16(&header[2]) == 0;
}
constexpr bool mbap_length_ok(std::size_t length) noexcept {
    return length >= 2 && length <= max_pdu + 1;
}

// Writes the MBAP header in front of a PDU of `pdu_size` bytes already in place at
// adu[mbap_size]; returns the ADU's size.
inline std::size_t seal_tcp(std::uint16_t transaction, std::uint8_t unit, std::uint8_t* adu,
                            std::size_t pdu_size) noexcept {
    store_be16(&adu[0], transaction);
    store_be16(&adu[2], 0); // protocol id: Modbus
    store_be16(&adu[4], static_cast<std::uint16_t>(pdu_size + 1));
    adu[6] = unit;
    return mbap_size + pdu_size;
}

inline result<std::size_t> encode_tcp(std::uint16_t transaction, std::uint8_t unit,
                                      std::span<const std::uint8_t> pdu,
                                      std::span<std::uint8_t> out) noexcept {
    if (pdu.empty() || pdu.size() > max_pdu) return errc::invalid_argument;
    if (out.size() < mbap_size + pdu.size()) return errc::buffer_too_small;
    for (std::size_t i = 0; i < pdu.size(); ++i) out[mbap_size + i] = pdu[i];
    return seal_tcp(transaction, unit, out.data(), pdu.size());
}

// Splits a TCP byte stream into ADUs; the step API of rtu_decoder. A header with a protocol
// id other than 0 or a length outside 2…254 is errc::malformed (reported once per run);
// one byte is dropped and framing tried again from the next.
class tcp_decoder : public frame_scanner<tcp_decoder, max_tcp_adu> {
public:
    // The frame just yielded (valid until the next feed() or reset()).
    std::uint16_t transaction() const noexcept {
        return frame_size_ ? load_be16(buf_.data()) : std::uint16_t{0};
    }
    std::uint8_t unit() const noexcept { return frame_size_ ? buf_[6] : std::uint8_t{0}; }
    std::span<const std::uint8_t> pdu() const noexcept {
        if (frame_size_ == 0) return {};
        return {buf_.data() + mbap_size, frame_size_ - mbap_size};
    }
    std::span<const std::uint8_t> adu() const noexcept { return {buf_.data(), frame_size_}; }

private:
    friend frame_scanner;

    step scan() noexcept {
        for (;;) {
            const bool bad_protocol = size_ >= 4 && !mbap_protocol_ok(buf_.data());
            std::size_t length = 0;
            if (size_ >= 6) length = load_be16(&buf_[4]);
            const bool bad_length = size_ >= 6 && !mbap_length_ok(length);
            if (!bad_protocol && !bad_length) {
                if (size_ < 6 || size_ < 6 + length) return {};
                return yield(6 + length);
            }
            if (drop_garbage()) return {status::error, 0, errc::malformed};
        }
    }
};

// Finds where the ADUs of a TCP byte stream end from their MBAP headers alone, keeping no
// more than a header: what a server needs to time each request from its first byte to its
// last, before its session has read them. A header that no Modbus ADU can start with
// (mbap_protocol_ok(), mbap_length_ok()) is not skipped: the framer takes no byte from its
// first on, and bad() tells the server to give up on the stream.
class mbap_framer {
public:
    struct scan {
        std::size_t ended = 0; // ADUs whose last byte was among the bytes taken
        std::size_t taken = 0; // bytes before a bad header (all when there is none)
    };

    scan feed(std::span<const std::uint8_t> in) noexcept {
        scan r;
        std::size_t start = 0; // where the header being read began among these bytes
        while (r.taken < in.size() && !bad_) {
            if (body_left_ > 0) {
                const std::size_t n = std::min(body_left_, in.size() - r.taken);
                body_left_ -= n;
                r.taken += n;
                if (body_left_ == 0) ++r.ended;
                continue;
            }
            if (header_size_ == 0) start = r.taken;
            header_[header_size_++] = in[r.taken++];
            read_header();
        }
        if (bad_) r.taken = start;
        return r;
    }

    // Bytes of an ADU have come and its last has not.
    bool in_adu() const noexcept { return header_size_ > 0 || body_left_ > 0; }
    // A header no ADU starts with has come: nothing is taken any more.
    bool bad() const noexcept { return bad_; }

private:
    // The protocol id is judged at once (4 bytes), the length when it is in (6).
    void read_header() noexcept {
        if (header_size_ == 4 && !mbap_protocol_ok(header_.data())) bad_ = true;
        if (header_size_ < header_.size()) return;
        const std::size_t length = load_be16(&header_[4]);
        if (!mbap_length_ok(length)) {
            bad_ = true;
            return;
        }
        body_left_ = length;
        header_size_ = 0;
    }

    std::array<std::uint8_t, 6> header_{}; // transaction, protocol id, length
    std::size_t header_size_ = 0;
    std::size_t body_left_ = 0; // unit id and PDU still to come
    bool bad_ = false;
};

} // namespace ferrule::modbus
