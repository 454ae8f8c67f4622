// Modbus PDUs: function code + data, the same on every transport (AP §4.1). Multi-byte
// fields are big-endian (AP §4.2).
//
//   request            FC   fields                                              AP
//   read bits          1 2  address(2) quantity(2)                              §6.1 §6.2
//   read registers     3 4  address(2) quantity(2)                              §6.3 §6.4
//   write single       5 6  address(2) value(2)   (FC5: FF00 on, 0000 off)      §6.5 §6.6
//   diagnostics        8    sub-function(2) data(2)                             §6.8
//   write multiple     15   address(2) quantity(2) byte count(1) packed bits    §6.11
//                      16   address(2) quantity(2) byte count(1) registers      §6.12
//   read/write         23   read address, read qty, write address, write qty,
//                           byte count(1), registers                            §6.17
//   read device id     43   MEI type 14, read device id code, object id         §6.21
//
// Responses: FC 1-4 and 23 byte count + data; FC 5, 6, 8 echo the request; FC 15, 16 echo
// address and quantity; 43/14 a list of objects; an exception is FC | 0x80 + code (AP §7).
//
// encode_request() checks the spec's limits; parse_request() / request_exception() serve a
// server; parse_response() checks a response against the request it answers;
// expected_*_length() give the length of a PDU from its first bytes for RTU framing.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/bytes.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/error.hpp"

namespace ferrule::modbus {

// A request PDU, to encode or as parse_request() decoded it. Fields by function code:
//   1-4     address, quantity
//   5, 6    address, value (FC5: 0xFF00 on, 0x0000 off)
//   8       value = sub-function, data = its 2 data bytes
//   15      address, quantity (bits), data = ceil(quantity / 8) bytes, LSB first
//   16      address, quantity, data = 2 * quantity bytes (big-endian registers)
//   23      address / quantity = read part, write_address / write_quantity, data as FC16
//   43      mei_type = 14, read_device_id_code 1-4, object_id
struct request {
    modbus::function function = modbus::function::read_holding_registers;
    std::uint16_t address = 0;
    std::uint16_t quantity = 0;
    std::uint16_t write_address = 0;
    std::uint16_t write_quantity = 0;
    std::uint16_t value = 0;
    std::span<const std::uint8_t> data{};
    std::uint8_t mei_type = mei_read_device_id;
    std::uint8_t read_device_id_code = 0;
    std::uint8_t object_id = 0;
};

// A normal response PDU, checked against its request (data spans the parsed PDU):
//   1-4, 23  data = packed bits / register bytes, quantity and address as asked
//   5, 6     address, value echoed
//   8        value = sub-function, data = its 2 data bytes
//   15, 16   address, quantity echoed
//   43/14    data = the objects (id, length, value)…, quantity = their number;
//            conformity level, more follows, next object id (AP §6.21)
struct response {
    modbus::function function = modbus::function::read_holding_registers;
    std::span<const std::uint8_t> data{};
    std::uint16_t address = 0;
    std::uint16_t value = 0;
    std::uint16_t quantity = 0;
    std::uint8_t conformity = 0;
    bool more_follows = false;
    std::uint8_t next_object_id = 0;
};

// FC5 coil values (AP §6.5).
inline constexpr std::uint16_t coil_on = 0xFF00;
inline constexpr std::uint16_t coil_off = 0x0000;

// expected_*_length(): these bytes cannot start a PDU that can be framed by its length.
inline constexpr std::size_t no_frame = static_cast<std::size_t>(-1);

// The function codes a client is built for. Firmware that uses few of them names them
// (functions<function::read_holding_registers, function::write_single_register>) and
// carries the code of no other: encode_request(), parse_response() and the response
// framing refuse the rest as they refuse an unknown function code.
struct function_set {
    std::uint64_t mask = 0; // bit n: function code n
    constexpr bool has(function f) const noexcept {
        return (mask >> static_cast<unsigned>(f) & 1u) != 0;
    }
    constexpr bool has(std::uint8_t code) const noexcept {
        return code < 64 && (mask >> code & 1u) != 0;
    }
};

template <function... F>
inline constexpr function_set functions{
    ((std::uint64_t{1} << static_cast<unsigned>(F)) | ... | 0u)};

namespace detail {
template <function... F>
struct function_list {
    static constexpr function_set set = functions<F...>;
    // f is one of F… in Fs: one comparison per function of Fs (Fs.has() of a code known only
    // at run time shifts a 64-bit mask, a library call on Cortex-M).
    template <function_set Fs>
    static constexpr bool has(function f) noexcept {
        return ((Fs.has(F) && f == F) || ...);
    }
};
// The function codes ferrule implements.
using every_function = function_list<
    function::read_coils, function::read_discrete_inputs, function::read_holding_registers,
    function::read_input_registers, function::write_single_coil, function::write_single_register,
    function::diagnostics, function::write_multiple_coils, function::write_multiple_registers,
    function::read_write_multiple_registers, function::encapsulated_interface>;
} // namespace detail

inline constexpr function_set all_functions = detail::every_function::set;

constexpr std::size_t packed_size(std::size_t bits) noexcept {
    return (bits + 7) / 8;
}

namespace detail {
constexpr bool fits(std::uint16_t address, std::uint16_t quantity) noexcept {
    return std::uint32_t{address} + quantity <= 0x10000u;
}
constexpr bool in(std::uint16_t v, std::uint16_t lo, std::uint16_t hi) noexcept {
    return v >= lo && v <= hi;
}
constexpr std::size_t limited(std::size_t n) noexcept {
    return n > max_pdu ? no_frame : n;
}
// `f` is one of F… and in `Fs`. A test whose functions are all left out of Fs is false at
// compile time, so the code under it is not compiled in.
template <function_set Fs, function... F>
constexpr bool one_of(function f) noexcept {
    return ((Fs.has(F) && f == F) || ...);
}
} // namespace detail

// Writes the request PDU to `out`; invalid_argument for what the spec does not allow
// (quantities beyond AP §6's limits, address + quantity beyond 65536, a data size that does
// not match the quantity, an FC5 value other than FF00 / 0000, FC8 data other than 2 bytes)
// and for a function not in `Fs`.
template <function_set Fs = all_functions>
result<std::size_t> encode_request(const request& r, std::span<std::uint8_t> out) noexcept {
    using detail::fits;
    using detail::in;
    using detail::one_of;
    const function f = r.function;
    std::size_t n = 5;                 // function code, then two 16-bit fields …
    std::uint16_t second = r.quantity; // … address and quantity, or address and value
    std::size_t data = 0;              // … then r.data, at the end
    std::uint16_t limit = 0;           // of r.quantity (AP §6), checked with the address
    bool ok = true;
    if (one_of<Fs, function::read_coils, function::read_discrete_inputs>(f)) {
        limit = max_read_bits;
    } else if (one_of<Fs, function::read_holding_registers, function::read_input_registers>(f)) {
        limit = max_read_registers;
    } else if (one_of<Fs, function::write_single_coil, function::write_single_register>(f)) {
        ok = f == function::write_single_register || r.value == coil_on || r.value == coil_off;
        second = r.value;
    } else if (one_of<Fs, function::diagnostics>(f)) {
        ok = r.data.size() == 2; // sub-function, then its data
        n = 3;
        data = 2;
    } else if (one_of<Fs, function::write_multiple_coils, function::write_multiple_registers>(f)) {
        const bool coils = f == function::write_multiple_coils;
        data = coils ? packed_size(r.quantity) : 2u * r.quantity;
        limit = coils ? max_write_bits : max_write_registers;
        ok = r.data.size() == data;
        n = 6; // and the byte count
    } else if (one_of<Fs, function::read_write_multiple_registers>(f)) {
        data = 2u * r.write_quantity;
        limit = max_read_registers;
        ok = in(r.write_quantity, 1, max_rw_write_registers) &&
             fits(r.write_address, r.write_quantity) && r.data.size() == data;
        n = 10; // write address, write quantity, byte count
    } else if (one_of<Fs, function::encapsulated_interface>(f)) {
        ok = r.mei_type == mei_read_device_id && in(r.read_device_id_code, 1, 4);
        n = 4;
    } else {
        ok = false;
    }
    if (limit != 0) ok = ok && in(r.quantity, 1, limit) && fits(r.address, r.quantity);
    if (!ok) return errc::invalid_argument;
    if (out.size() < n + data) return errc::buffer_too_small;
    out[0] = static_cast<std::uint8_t>(f);
    if (one_of<Fs, function::encapsulated_interface>(f)) {
        out[1] = r.mei_type;
        out[2] = r.read_device_id_code;
        out[3] = r.object_id;
        return n;
    }
    store_be16(&out[1], one_of<Fs, function::diagnostics>(f) ? r.value : r.address);
    if (n >= 5) store_be16(&out[3], second);
    if (n >= 6) out[n - 1] = static_cast<std::uint8_t>(data);
    if (n == 10) {
        store_be16(&out[5], r.write_address);
        store_be16(&out[7], r.write_quantity);
    }
    for (std::size_t i = 0; i < data; ++i) out[n + i] = r.data[i];
    return n + data;
}

// Length of a request PDU from its first bytes: 0 = need more, no_frame = cannot be framed.
// Besides the function codes of `function`, the other fixed-layout public ones (7, 11, 12,
// 17, 20-22, 24; AP §6) are framed too, so a server can answer them with exception 01.
constexpr std::size_t expected_request_length(std::span<const std::uint8_t> p) noexcept {
    if (p.empty()) return 0;
    switch (p[0]) {
    case 1:
    case 2:
    case 3:
    case 4:
    case 5:
    case 6:
    case 8: return 5;
    case 15:
    case 16: return p.size() < 6 ? 0 : detail::limited(6u + p[5]);
    case 23: return p.size() < 10 ? 0 : detail::limited(10u + p[9]);
    case 43:
        if (p.size() < 2) return 0;
        return p[1] == mei_read_device_id ? 4 : no_frame;
    case 7:
    case 11:
    case 12:
    case 17: return 1;
    case 20:
    case 21: return p.size() < 2 ? 0 : detail::limited(2u + p[1]);
    case 22: return 7;
    case 24: return 3;
    default: return no_frame;
    }
}

// Length of a response PDU from its first bytes: 0 = need more, no_frame = cannot be framed.
// With all functions, the other fixed-layout public ones (7, 11, 12, 17, 20-22, 24) are
// framed too (`Others`: a tool that reads a whole bus); a client frames only the responses
// to what it can send, and exception responses.
template <function_set Fs = all_functions, bool Others = Fs.mask == all_functions.mask>
constexpr std::size_t expected_response_length(std::span<const std::uint8_t> p) noexcept {
    if (p.empty()) return 0;
    if (p[0] > exception_flag) return 2; // FC | 0x80, exception code (AP §7)
    constexpr bool others = Others;
    const std::uint8_t fc = p[0];
    const auto counted = [&](std::size_t header) {
        return p.size() < header ? 0 : detail::limited(header + p[header - 1]);
    };
    switch (fc) {
    case 1:
    case 2:
    case 3:
    case 4:
    case 23: return Fs.has(fc) ? counted(2) : no_frame;
    case 5:
    case 6:
    case 8:
    case 15:
    case 16: return Fs.has(fc) ? 5 : no_frame;
    case 43: {
        if (!Fs.has(fc)) return no_frame;
        // 2B 0E code conformity more next count, then count × (id, length, value).
        if (p.size() < 2) return 0;
        if (p[1] != mei_read_device_id) return no_frame;
        if (p.size() < 7) return 0;
        std::size_t pos = 7;
        for (unsigned i = 0; i < p[6]; ++i) {
            if (p.size() < pos + 2) return 0;
            pos += 2u + p[pos + 1];
            if (pos > max_pdu) return no_frame;
        }
        return pos;
    }
    case 12:
    case 17:
    case 20:
    case 21: return others ? counted(2) : no_frame;
    case 11: return others ? 5 : no_frame;
    case 7: return others ? 2 : no_frame;
    case 22: return others ? 7 : no_frame;
    case 24:
        if (!others) return no_frame;
        return p.size() < 3 ? 0 : detail::limited(3u + load_be16(&p[1]));
    default: return no_frame;
    }
}

namespace detail {
inline constexpr std::uint8_t illegal_function = 1;
inline constexpr std::uint8_t illegal_data_address = 2;
inline constexpr std::uint8_t illegal_data_value = 3;
inline constexpr std::uint8_t not_a_request = 0xFF; // empty: nothing to answer

// Decodes a request PDU into `r`; returns 0, or the exception code it deserves, checked in
// the order of AP §6's state diagrams: function code (01; a function not in `Fs` too),
// quantity and byte count (03), address + quantity (02).
template <function_set Fs = all_functions>
constexpr std::uint8_t decode_request(std::span<const std::uint8_t> p, request& r) noexcept {
    if (p.empty()) return not_a_request;
    const auto f = static_cast<modbus::function>(p[0]);
    if (!every_function::has<Fs>(f)) return illegal_function;
    if (one_of<Fs, function::encapsulated_interface>(f) && p.size() >= 2 &&
        p[1] != mei_read_device_id)
        return illegal_function;
    const std::size_t want = expected_request_length(p);
    if (want == 0 || want == no_frame || p.size() != want) return illegal_data_value;
    r = request{};
    r.function = f;
    if (one_of<Fs, function::encapsulated_interface>(f)) {
        r.mei_type = p[1];
        r.read_device_id_code = p[2];
        r.object_id = p[3];
        return in(p[2], 1, 4) ? 0 : illegal_data_value;
    }
    r.address = load_be16(&p[1]);
    r.quantity = load_be16(&p[3]);
    if (one_of<Fs, function::read_coils, function::read_discrete_inputs,
               function::read_holding_registers, function::read_input_registers>(f)) {
        const bool bits = f == function::read_coils || f == function::read_discrete_inputs;
        if (!in(r.quantity, 1, bits ? max_read_bits : max_read_registers))
            return illegal_data_value;
        return fits(r.address, r.quantity) ? 0 : illegal_data_address;
    }
    if (one_of<Fs, function::write_single_coil, function::write_single_register>(f)) {
        r.value = r.quantity;
        r.quantity = 0;
        if (f == function::write_single_coil && r.value != coil_on && r.value != coil_off)
            return illegal_data_value;
        return 0;
    }
    if (one_of<Fs, function::diagnostics>(f)) {
        r.value = r.address;
        r.address = 0;
        r.quantity = 0;
        r.data = p.subspan(3, 2);
        return 0;
    }
    if (one_of<Fs, function::write_multiple_coils, function::write_multiple_registers>(f)) {
        const bool coils = f == function::write_multiple_coils;
        const std::size_t bytes = coils ? packed_size(r.quantity) : 2u * r.quantity;
        if (!in(r.quantity, 1, coils ? max_write_bits : max_write_registers) || p[5] != bytes)
            return illegal_data_value;
        r.data = p.subspan(6);
        return fits(r.address, r.quantity) ? 0 : illegal_data_address;
    }
    if (one_of<Fs, function::read_write_multiple_registers>(f)) {
        r.write_address = load_be16(&p[5]);
        r.write_quantity = load_be16(&p[7]);
        if (!in(r.quantity, 1, max_read_registers) ||
            !in(r.write_quantity, 1, max_rw_write_registers) || p[9] != 2u * r.write_quantity)
            return illegal_data_value;
        r.data = p.subspan(10);
        return fits(r.address, r.quantity) && fits(r.write_address, r.write_quantity)
                   ? 0
                   : illegal_data_address;
    }
    return illegal_function;
}
} // namespace detail

// A request PDU as a server receives it; errc::malformed when it deserves an exception (ask
// request_exception() which) or is empty. `data` spans `pdu`.
inline result<request> parse_request(std::span<const std::uint8_t> pdu) noexcept {
    request r;
    if (detail::decode_request(pdu, r) != 0) return errc::malformed;
    return r;
}

// The exception code a request deserves before any data is touched: 01 unknown or
// unsupported function (FC43 with another MEI type too), 03 bad quantity, byte count, PDU
// length, FC5 value or read device id code, 02 address + quantity beyond 65536; 0 when none
// (a valid request, or an empty PDU, which gets no answer at all).
constexpr std::uint8_t request_exception(std::span<const std::uint8_t> pdu) noexcept {
    request r;
    const std::uint8_t code = detail::decode_request(pdu, r);
    return code == detail::not_a_request ? 0 : code;
}

namespace detail {
// [FC | 0x80][code] (AP §7) into `out`, which holds 2 bytes; returns 2.
constexpr std::size_t write_exception(function fc, std::uint8_t code, std::uint8_t* out) noexcept {
    out[0] = static_cast<std::uint8_t>(static_cast<std::uint8_t>(fc) | exception_flag);
    out[1] = code;
    return 2;
}
} // namespace detail

// [FC | 0x80][code] (AP §7).
inline result<std::size_t> encode_exception(function fc, exception_code code,
                                            std::span<std::uint8_t> out) noexcept {
    if (out.size() < 2) return errc::buffer_too_small;
    return detail::write_exception(fc, static_cast<std::uint8_t>(code), out.data());
}

// One object of a Read Device Identification response (AP §6.21).
struct device_id_object {
    std::uint8_t id = 0;
    std::span<const std::uint8_t> value{};
};

// Takes the next object off `objects` (response::data of FC43/14); false at the end.
constexpr bool next_device_id_object(std::span<const std::uint8_t>& objects,
                                     device_id_object& out) noexcept {
    if (objects.size() < 2 || objects.size() < 2u + objects[1]) return false;
    out.id = objects[0];
    out.value = objects.subspan(2, objects[1]);
    objects = objects.subspan(2u + objects[1]);
    return true;
}

namespace detail {
// parse_response() without error categories, against the request as sent (its PDU `q`, as
// encode_request<Fs>() wrote it), for the client session: errc{} when `pdu` answers it, as a
// normal response (then `r` is filled) or as a well-formed exception response (pdu[0]
// carries exception_flag, pdu[1] the code).
template <function_set Fs>
constexpr errc check_response(std::span<const std::uint8_t> q, std::span<const std::uint8_t> pdu,
                              response& r) noexcept {
    if (pdu.empty()) return errc::malformed;
    const std::uint8_t fc = q[0];
    const auto f = static_cast<function>(fc);
    if (pdu[0] == (fc | exception_flag))
        return pdu.size() != 2 || pdu[1] == 0 ? errc::malformed : errc{};
    if (pdu[0] != fc) return errc::unexpected_type;
    // `r` is written once the response has passed its checks.
    if (one_of<Fs, function::encapsulated_interface>(f)) {
        // 2B 0E code conformity more-follows(00/FF) next-object count objects… (AP §6.21)
        // The objects fill the PDU exactly: its length as framing computes it.
        if (expected_response_length<Fs, false>(pdu) != pdu.size() || pdu[2] != q[2] ||
            (pdu[4] != 0x00 && pdu[4] != 0xFF))
            return errc::malformed;
        r = {.function = f,
             .data = pdu.subspan(7),
             .quantity = pdu[6],
             .conformity = pdu[3],
             .more_follows = pdu[4] == 0xFF,
             .next_object_id = pdu[5]};
        return errc{};
    }
    // The other requests begin with two 16-bit fields: address (FC 8: sub-function) and
    // quantity (FC 5, 6: value; FC 8: data).
    const std::uint16_t first = load_be16(&q[1]);
    const std::uint16_t second = load_be16(&q[3]);
    const auto echoes = [&](std::size_t n) {
        for (std::size_t i = 1; i < n; ++i)
            if (pdu[i] != q[i]) return false;
        return true;
    };
    if (one_of<Fs, function::read_coils, function::read_discrete_inputs,
               function::read_holding_registers, function::read_input_registers,
               function::read_write_multiple_registers>(f)) {
        const bool bits = f == function::read_coils || f == function::read_discrete_inputs;
        const std::size_t bytes = bits ? packed_size(second) : 2u * second;
        if (pdu.size() < 2 || pdu[1] != bytes || pdu.size() != 2 + bytes) return errc::malformed;
        r = {.function = f, .data = pdu.subspan(2), .address = first, .quantity = second};
        return errc{};
    }
    if (pdu.size() != 5) return errc::malformed;
    if (one_of<Fs, function::write_single_coil, function::write_single_register,
               function::write_multiple_coils, function::write_multiple_registers>(f)) {
        // The echo of address and value or quantity.
        if (!echoes(5)) return errc::malformed;
        const bool single =
            f == function::write_single_coil || f == function::write_single_register;
        r = {.function = f,
             .address = first,
             .value = single ? second : std::uint16_t{0},
             .quantity = single ? std::uint16_t{0} : second};
        return errc{};
    }
    if (one_of<Fs, function::diagnostics>(f)) {
        // Echo of the sub-function; Return Query Data echoes the data too (AP §6.8.1).
        const bool query = first == static_cast<std::uint16_t>(diag_sub::return_query_data);
        if (!echoes(query ? 5 : 3)) return errc::malformed;
        r = {.function = f, .data = pdu.subspan(3, 2), .value = first};
        return errc{};
    }
    return errc::invalid_argument;
}

} // namespace detail

// The response PDU `pdu` to `sent`. An exception response gives the server's code as a
// modbus::device_domain error; another function code errc::unexpected_type; a wrong
// length, byte count or echo errc::malformed; a request that encode_request<Fs>() refuses
// (a function not in `Fs` among them) errc::invalid_argument.
// This form fills `r` and returns the error (empty on success; `r` is then not to be used).
template <function_set Fs = all_functions>
ferrule::error parse_response(const request& sent, std::span<const std::uint8_t> pdu,
                              response& r) noexcept {
    std::array<std::uint8_t, max_pdu> q;
    const auto n = encode_request<Fs>(sent, q);
    if (!n) return errc::invalid_argument;
    const errc e = detail::check_response<Fs>(std::span<const std::uint8_t>(q.data(), *n), pdu, r);
    if (e != errc{}) return e;
    if (pdu[0] & exception_flag) return make_device_error(pdu[1]);
    return {};
}

template <function_set Fs = all_functions>
result<response> parse_response(const request& sent, std::span<const std::uint8_t> pdu) noexcept {
    response r;
    if (const ferrule::error ec = parse_response<Fs>(sent, pdu, r)) return ec;
    return r;
}

} // namespace ferrule::modbus
