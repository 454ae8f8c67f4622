// Extended MEMOBUS messages, MFC 0x20 (protocols/memobus.md §3): after the 218 header,
//
//   length (LE16: bytes from MFC to the end) · MFC 0x20 · SFC · CPU · body
//
//   SFC  request body                              response body
//   01 02  addr, n                                 packed bits, (n + 7) / 8 bytes
//   03 04  addr, n                                 n registers
//   05   addr, FF 00 / 00 00                       echo
//   06   addr, value                               echo
//   08   test code, test data                      echo
//   0F   addr, n, packed bits                      addr, n
//   10   addr, n, n registers                      addr, n
//   09 0A  spare, addr, n                          spare, n, n registers
//   0B   spare, addr, n, n registers               spare, addr, n
//   0D   spare, n, n addresses                     spare, n, n registers
//   0E   spare, n, n × (addr, value)               spare, n
//   error: SFC | 0x80, one error code (01 SFC, 02 address, 03 count)
//
// SFCs 01…10 (the MEMOBUS-compatible ones) carry addresses and counts big-endian, as the
// manual's worked example shows, and no byte count; their register data is big-endian unless
// data_order::little_endian is chosen (uncertain, §3.3). SFCs 09…0E have the spare byte and
// every field little-endian. Limits: constants.hpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/bytes.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/memobus/constants.hpp"
#include "ferrule/memobus/error.hpp"
#include "ferrule/memobus/header.hpp"

namespace ferrule::memobus {

struct request {
    memobus::sfc function = sfc::read_holding_registers_ext;
    std::uint8_t cpu = default_cpu;
    std::uint16_t address = 0; // 08: the test code
    std::uint16_t count = 0;   // registers or bits; 0D / 0E: addresses or pairs
    std::uint16_t value = 0;   // 05: 0xFF00 on / 0x0000 off; 06: the register; 08: test data
    // To encode: 0B / 10 register values, 0D addresses, 0E address and value pairs;
    // 0F coils packed LSB first.
    std::span<const std::uint16_t> words{};
    std::span<const std::uint8_t> bits{};
    // Decoded: the data bytes as received (0B, 0D, 0E, 0F, 10); see word_at().
    std::span<const std::uint8_t> raw{};
};

struct response {
    memobus::sfc function = sfc::read_holding_registers_ext;
    std::uint8_t cpu = 0;
    std::uint16_t address = 0;
    std::uint16_t count = 0;
    std::uint16_t value = 0;
    // To encode: read registers (03 04 09 0A 0D) or packed bits (01 02).
    std::span<const std::uint16_t> words{};
    std::span<const std::uint8_t> bits{};
    // Decoded: the data bytes as received; see word_at().
    std::span<const std::uint8_t> raw{};
};

inline constexpr std::uint16_t coil_on = 0xFF00;

constexpr std::size_t packed_size(std::size_t bits) noexcept {
    return (bits + 7) / 8;
}

// Word i of data bytes of `f`: little-endian for the extended SFCs, else in `order`.
constexpr std::uint16_t word_at(sfc f, std::span<const std::uint8_t> raw, std::size_t i,
                                data_order order = data_order::big_endian) noexcept {
    const bool le = is_extended(f) || order == data_order::little_endian;
    return le ? load_le16(&raw[2 * i]) : load_be16(&raw[2 * i]);
}

namespace detail {
struct writer {
    std::span<std::uint8_t> out;
    std::size_t n = 0;
    bool ok = true;
    void u8(std::uint8_t b) noexcept {
        if (n < out.size())
            out[n] = b;
        else
            ok = false;
        ++n;
    }
    void be(std::uint16_t v) noexcept {
        u8(static_cast<std::uint8_t>(v >> 8));
        u8(static_cast<std::uint8_t>(v));
    }
    void le(std::uint16_t v) noexcept {
        u8(static_cast<std::uint8_t>(v));
        u8(static_cast<std::uint8_t>(v >> 8));
    }
    void word(sfc f, std::uint16_t v, data_order o) noexcept {
        (is_extended(f) || o == data_order::little_endian) ? le(v) : be(v);
    }
};

constexpr bool in(std::size_t v, std::size_t lo, std::size_t hi) noexcept {
    return v >= lo && v <= hi;
}
constexpr bool fits(std::uint16_t address, std::size_t count) noexcept {
    return std::size_t{address} + count <= 0x10000u;
}

// Room for the 218 header and the length (finish() fills them in), then MFC, SFC, CPU.
inline writer begin(std::span<std::uint8_t> out, sfc f, std::uint8_t cpu) noexcept {
    writer w{out};
    for (std::size_t i = 0; i < header_size + length_size; ++i) w.u8(0);
    w.u8(mfc_extended);
    w.u8(static_cast<std::uint8_t>(f));
    w.u8(cpu);
    return w;
}

inline result<std::size_t> finish(writer& w, const header& h_in) noexcept {
    if (!w.ok) return errc::buffer_too_small;
    if (w.n > max_message) return errc::invalid_argument;
    header h = h_in;
    h.total = static_cast<std::uint16_t>(w.n);
    store_header(h, w.out.data());
    store_le16(w.out.data() + header_size,
               static_cast<std::uint16_t>(w.n - header_size - length_size));
    return w.n;
}
} // namespace detail

// The limits and shapes a request must have (§3.4, §10.5): errc::invalid_argument to a
// client, the error code a controller answers with to a server (request_error()).
constexpr device_errc check_request(const request& r) noexcept {
    using detail::fits;
    using detail::in;
    switch (r.function) {
    case sfc::read_coils:
    case sfc::read_input_relays:
        if (!in(r.count, 1, max_read_bits)) return device_errc::count_error;
        return fits(r.address, r.count) ? device_errc{} : device_errc::address_error;
    case sfc::read_holding_registers:
    case sfc::read_input_registers:
        if (!in(r.count, 1, max_read_registers)) return device_errc::count_error;
        return fits(r.address, r.count) ? device_errc{} : device_errc::address_error;
    case sfc::write_coil:
        return r.value == coil_on || r.value == 0 ? device_errc{} : device_errc::count_error;
    case sfc::write_holding_register:
    case sfc::loopback: return {};
    case sfc::read_holding_registers_ext:
    case sfc::read_input_registers_ext:
        if (!in(r.count, 1, max_read_registers_ext)) return device_errc::count_error;
        return fits(r.address, r.count) ? device_errc{} : device_errc::address_error;
    case sfc::write_holding_registers_ext:
        if (!in(r.count, 1, max_write_registers_ext)) return device_errc::count_error;
        return fits(r.address, r.count) ? device_errc{} : device_errc::address_error;
    case sfc::read_holding_registers_random:
        return in(r.count, 1, max_read_registers_ext) ? device_errc{} : device_errc::count_error;
    case sfc::write_holding_registers_random:
        return in(r.count, 1, max_write_random) ? device_errc{} : device_errc::count_error;
    case sfc::write_coils:
        if (!in(r.count, 1, max_write_bits)) return device_errc::count_error;
        return fits(r.address, r.count) ? device_errc{} : device_errc::address_error;
    case sfc::write_holding_registers:
        if (!in(r.count, 1, max_write_registers)) return device_errc::count_error;
        return fits(r.address, r.count) ? device_errc{} : device_errc::address_error;
    }
    return device_errc::sfc_error;
}

// A whole command message (218 header with type 0x11). invalid_argument for a request
// outside the limits or whose words / bits do not match its count.
inline result<std::size_t> encode_command(const request& r, std::uint8_t serial,
                                          std::span<std::uint8_t> out,
                                          data_order order = data_order::big_endian,
                                          std::uint8_t destination_channel = 0,
                                          std::uint8_t source_channel = 0) noexcept {
    if (check_request(r) != device_errc{}) return errc::invalid_argument;
    const sfc f = r.function;
    auto w = detail::begin(out, f, r.cpu);
    if (is_extended(f)) w.u8(0); // spare
    switch (f) {
    case sfc::read_coils:
    case sfc::read_input_relays:
    case sfc::read_holding_registers:
    case sfc::read_input_registers:
        w.be(r.address);
        w.be(r.count);
        break;
    case sfc::write_coil:
        w.be(r.address);
        w.be(r.value);
        break;
    case sfc::write_holding_register:
        w.be(r.address);
        w.word(f, r.value, order);
        break;
    case sfc::loopback:
        w.be(r.address);
        w.be(r.value);
        break;
    case sfc::write_coils:
        if (r.bits.size() != packed_size(r.count)) return errc::invalid_argument;
        w.be(r.address);
        w.be(r.count);
        for (const std::uint8_t b : r.bits) w.u8(b);
        break;
    case sfc::write_holding_registers:
    case sfc::write_holding_registers_ext:
        if (r.words.size() != r.count) return errc::invalid_argument;
        is_extended(f) ? w.le(r.address) : w.be(r.address);
        is_extended(f) ? w.le(r.count) : w.be(r.count);
        for (const std::uint16_t v : r.words) w.word(f, v, order);
        break;
    case sfc::read_holding_registers_ext:
    case sfc::read_input_registers_ext:
        w.le(r.address);
        w.le(r.count);
        break;
    case sfc::read_holding_registers_random:
    case sfc::write_holding_registers_random: {
        const std::size_t per = f == sfc::read_holding_registers_random ? 1 : 2;
        if (r.words.size() != per * r.count) return errc::invalid_argument;
        w.le(r.count);
        for (const std::uint16_t v : r.words) w.le(v);
        break;
    }
    }
    return detail::finish(w,
                          {command_type::command, serial, destination_channel, source_channel, 0});
}

// The request in the MEMOBUS part of a command (message_decoder::body()); on failure the
// error code a controller answers with: sfc_error for an unknown SFC or MFC, count_error for a
// length that does not fit the SFC or a count out of its limits, address_error for a range
// beyond 65535. `order`: how SFC 06 carries its value (see data_order).
inline result<request> parse_request(std::span<const std::uint8_t> body,
                                     data_order order = data_order::big_endian) noexcept {
    if (body.size() < length_size + 3 || body[2] != mfc_extended)
        return make_error(device_errc::sfc_error);
    request r;
    r.function = static_cast<sfc>(body[3]);
    r.cpu = body[4];
    const auto p = body.subspan(5); // after the CPU byte
    const auto count_error = make_error(device_errc::count_error);
    switch (r.function) {
    case sfc::read_coils:
    case sfc::read_input_relays:
    case sfc::read_holding_registers:
    case sfc::read_input_registers:
    case sfc::write_coil:
    case sfc::write_holding_register:
    case sfc::loopback:
        if (p.size() != 4) return count_error;
        r.address = load_be16(&p[0]);
        r.count = load_be16(&p[2]);
        if (r.function == sfc::write_coil || r.function == sfc::loopback ||
            r.function == sfc::write_holding_register) {
            r.value = r.function == sfc::write_holding_register
                          ? word_at(r.function, p.subspan(2), 0, order)
                          : r.count;
            r.count = 1;
            r.raw = p.subspan(2);
        }
        break;
    case sfc::write_coils:
    case sfc::write_holding_registers: {
        if (p.size() < 4) return count_error;
        r.address = load_be16(&p[0]);
        r.count = load_be16(&p[2]);
        const std::size_t bytes =
            r.function == sfc::write_coils ? packed_size(r.count) : 2u * r.count;
        if (p.size() != 4 + bytes) return count_error;
        r.raw = p.subspan(4);
        break;
    }
    case sfc::read_holding_registers_ext:
    case sfc::read_input_registers_ext:
    case sfc::write_holding_registers_ext: {
        if (p.size() < 5) return count_error;
        r.address = load_le16(&p[1]);
        r.count = load_le16(&p[3]);
        const std::size_t bytes = r.function == sfc::write_holding_registers_ext ? 2u * r.count : 0;
        if (p.size() != 5 + bytes) return count_error;
        r.raw = p.subspan(5);
        break;
    }
    case sfc::read_holding_registers_random:
    case sfc::write_holding_registers_random: {
        if (p.size() < 3) return count_error;
        r.count = load_le16(&p[1]);
        const std::size_t per = r.function == sfc::read_holding_registers_random ? 2 : 4;
        if (p.size() != 3 + per * r.count) return count_error;
        r.raw = p.subspan(3);
        break;
    }
    default: return make_error(device_errc::sfc_error);
    }
    if (const device_errc e = check_request(r); e != device_errc{}) return make_error(e);
    return r;
}

// A whole response message (type 0x19) to `req`, with the serial and channels of the
// command's header `h` (channels swapped, §2) and the CPU nibbles swapped (§3.2). For reads
// `rsp.words` (or `rsp.bits` for 01 / 02) holds the data; for the others the echo is made
// from `req`.
inline result<std::size_t> encode_response(const header& h, const request& req, const response& rsp,
                                           std::span<std::uint8_t> out,
                                           data_order order = data_order::big_endian) noexcept {
    const sfc f = req.function;
    auto w = detail::begin(out, f, swap_nibbles(req.cpu));
    if (is_extended(f)) w.u8(0); // spare
    switch (f) {
    case sfc::read_coils:
    case sfc::read_input_relays:
        if (rsp.bits.size() != packed_size(req.count)) return errc::invalid_argument;
        for (const std::uint8_t b : rsp.bits) w.u8(b);
        break;
    case sfc::read_holding_registers:
    case sfc::read_input_registers:
        if (rsp.words.size() != req.count) return errc::invalid_argument;
        for (const std::uint16_t v : rsp.words) w.word(f, v, order);
        break;
    case sfc::write_coil:
    case sfc::loopback:
        w.be(req.address);
        w.be(req.value);
        break;
    case sfc::write_holding_register:
        w.be(req.address);
        w.word(f, req.value, order);
        break;
    case sfc::write_coils:
    case sfc::write_holding_registers:
        w.be(req.address);
        w.be(req.count);
        break;
    case sfc::read_holding_registers_ext:
    case sfc::read_input_registers_ext:
    case sfc::read_holding_registers_random:
        if (rsp.words.size() != req.count) return errc::invalid_argument;
        w.le(req.count);
        for (const std::uint16_t v : rsp.words) w.le(v);
        break;
    case sfc::write_holding_registers_ext:
        w.le(req.address);
        w.le(req.count);
        break;
    case sfc::write_holding_registers_random: w.le(req.count); break;
    default: return errc::invalid_argument;
    }
    return detail::finish(
        w, {command_type::response, h.serial, h.source_channel, h.destination_channel, 0});
}

// An error response: SFC | 0x80 and the code (§3.5); 18 bytes.
inline result<std::size_t> encode_error(const header& h, std::uint8_t sfc_code, std::uint8_t cpu,
                                        device_errc e, std::span<std::uint8_t> out) noexcept {
    detail::writer w{out};
    for (std::size_t i = 0; i < header_size + length_size; ++i) w.u8(0);
    w.u8(mfc_extended);
    w.u8(static_cast<std::uint8_t>(sfc_code | error_flag));
    w.u8(swap_nibbles(cpu));
    w.u8(static_cast<std::uint8_t>(e));
    return detail::finish(
        w, {command_type::response, h.serial, h.source_channel, h.destination_channel, 0});
}

// The response in the MEMOBUS part of a response message to `sent`, checked in the order of
// Yaskawa's sample (§2): MFC, SFC (an error response gives the controller's code as a
// memobus::device_domain error), then the count and length. errc::unexpected_type for
// another MFC or SFC, errc::malformed for a length, count or echo that does not fit.
inline result<response> parse_response(const request& sent, std::span<const std::uint8_t> body,
                                       data_order order = data_order::big_endian) noexcept {
    if (body.size() < length_size + 3) return errc::malformed;
    if (body[2] != mfc_extended) return errc::unexpected_type;
    const auto f = static_cast<std::uint8_t>(sent.function);
    if (body[3] == (f | error_flag)) {
        if (body.size() != length_size + 4 || body[5] == 0) return errc::malformed;
        return make_device_error(body[5]);
    }
    if (body[3] != f) return errc::unexpected_type;
    response r;
    r.function = sent.function;
    r.cpu = body[4];
    r.address = sent.address;
    r.count = sent.count;
    const auto p = body.subspan(5);
    switch (sent.function) {
    case sfc::read_coils:
    case sfc::read_input_relays:
        if (p.size() != packed_size(sent.count)) return errc::malformed;
        r.raw = p;
        return r;
    case sfc::read_holding_registers:
    case sfc::read_input_registers:
        if (p.size() != 2u * sent.count) return errc::malformed;
        r.raw = p;
        return r;
    case sfc::write_coil:
    case sfc::write_holding_register:
    case sfc::loopback:
        if (p.size() != 4 || load_be16(&p[0]) != sent.address) return errc::malformed;
        r.value = sent.function == sfc::write_holding_register
                      ? word_at(sent.function, p.subspan(2), 0, order)
                      : load_be16(&p[2]);
        if (r.value != sent.value) return errc::malformed;
        r.raw = p.subspan(2);
        return r;
    case sfc::write_coils:
    case sfc::write_holding_registers:
        if (p.size() != 4 || load_be16(&p[0]) != sent.address || load_be16(&p[2]) != sent.count)
            return errc::malformed;
        return r;
    case sfc::read_holding_registers_ext:
    case sfc::read_input_registers_ext:
    case sfc::read_holding_registers_random:
        if (p.size() != 3u + 2u * sent.count || load_le16(&p[1]) != sent.count)
            return errc::malformed;
        r.raw = p.subspan(3);
        return r;
    case sfc::write_holding_registers_ext:
        if (p.size() != 5 || load_le16(&p[1]) != sent.address || load_le16(&p[3]) != sent.count)
            return errc::malformed;
        return r;
    case sfc::write_holding_registers_random:
        if (p.size() != 3 || load_le16(&p[1]) != sent.count) return errc::malformed;
        return r;
    }
    return errc::invalid_argument;
}

} // namespace ferrule::memobus
