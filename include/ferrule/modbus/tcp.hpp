// Modbus TCP ADU (TCP §3.1.2, §3.1.3): the MBAP header, then the PDU.
//
//   transaction id (2)  echoed by the server: pairs a response with its request
//   protocol id (2)     0 = Modbus
//   length (2)          bytes that follow: unit id + PDU, 2…254
//   unit id (1)         the server behind a gateway (serial address), else 0xFF or 0
//
// All fields big-endian. There is no checksum: TCP carries none (TCP §3.1.3).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <system_error>

#include "ferrule/core/bytes.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/frame_scanner.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/modbus/constants.hpp"

namespace ferrule::modbus {

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
            const bool bad_protocol = size_ >= 4 && load_be16(&buf_[2]) != 0;
            std::size_t length = 0;
            if (size_ >= 6) length = load_be16(&buf_[4]);
            const bool bad_length = size_ >= 6 && (length < 2 || length > max_pdu + 1);
            if (!bad_protocol && !bad_length) {
                if (size_ < 6 || size_ < 6 + length) return {};
                return yield(6 + length);
            }
            if (drop_garbage()) return {status::error, 0, errc::malformed};
        }
    }
};

} // namespace ferrule::modbus
