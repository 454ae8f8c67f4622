// Blocking Modbus access over any byte_stream: one call, one transaction, driven by
// ferrule::run(). For a non-blocking main loop use client + poll_driver.
//
// Quantities come from the spans: read_holding_registers(s, c, 1, 0x6B, regs) reads
// regs.size() registers. Writes to unit 0 (RTU broadcast) return {} once the turnaround has
// passed: no server answers them (SL §2.2).
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/modbus/client.hpp"
#include "ferrule/modbus/pdu.hpp"
#include "ferrule/modbus/registers.hpp"

namespace ferrule::modbus {

namespace detail {
template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error transact(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                        const request& r) {
    if (auto ec = c.start(unit, r)) return ec;
    const ferrule::error ec = run(stream, c);
    if (ec == errc::no_response_expected) return {};
    return ec;
}

template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error read_bits(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit, function fc,
                         std::uint16_t address, std::span<bool> out) {
    if (out.size() > max_read_bits) return errc::invalid_argument;
    request r;
    r.function = fc;
    r.address = address;
    r.quantity = static_cast<std::uint16_t>(out.size());
    if (auto ec = transact(stream, c, unit, r)) return ec;
    const auto data = c.reply().data;
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = (data[i / 8] >> (i % 8)) & 1u;
    return {};
}

template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error read_regs(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit, function fc,
                         std::uint16_t address, std::span<std::uint16_t> out) {
    if (out.size() > max_read_registers) return errc::invalid_argument;
    request r;
    r.function = fc;
    r.address = address;
    r.quantity = static_cast<std::uint16_t>(out.size());
    if (auto ec = transact(stream, c, unit, r)) return ec;
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = register_at(c.reply().data, i);
    return {};
}
} // namespace detail

// FC 1 (AP §6.1): out.size() coils from `address`.
template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error read_coils(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                          std::uint16_t address, std::span<bool> out) {
    return detail::read_bits(stream, c, unit, function::read_coils, address, out);
}

// FC 2 (AP §6.2).
template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error read_discrete_inputs(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                                    std::uint16_t address, std::span<bool> out) {
    return detail::read_bits(stream, c, unit, function::read_discrete_inputs, address, out);
}

// FC 3 (AP §6.3): out.size() registers from `address`.
template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error read_holding_registers(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                                      std::uint16_t address, std::span<std::uint16_t> out) {
    return detail::read_regs(stream, c, unit, function::read_holding_registers, address, out);
}

// FC 4 (AP §6.4).
template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error read_input_registers(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                                    std::uint16_t address, std::span<std::uint16_t> out) {
    return detail::read_regs(stream, c, unit, function::read_input_registers, address, out);
}

// FC 5 (AP §6.5).
template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error write_coil(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                          std::uint16_t address, bool on) {
    request r;
    r.function = function::write_single_coil;
    r.address = address;
    r.value = on ? coil_on : coil_off;
    return detail::transact(stream, c, unit, r);
}

// FC 6 (AP §6.6).
template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error write_register(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                              std::uint16_t address, std::uint16_t value) {
    request r;
    r.function = function::write_single_register;
    r.address = address;
    r.value = value;
    return detail::transact(stream, c, unit, r);
}

// FC 15 (AP §6.11): values.size() coils from `address`.
template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error write_coils(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                           std::uint16_t address, std::span<const bool> values) {
    if (values.size() > max_write_bits) return errc::invalid_argument;
    std::array<std::uint8_t, packed_size(max_write_bits)> packed{};
    for (std::size_t i = 0; i < values.size(); ++i)
        if (values[i]) packed[i / 8] = static_cast<std::uint8_t>(packed[i / 8] | 1u << (i % 8));
    request r;
    r.function = function::write_multiple_coils;
    r.address = address;
    r.quantity = static_cast<std::uint16_t>(values.size());
    r.data = std::span<const std::uint8_t>(packed).first(packed_size(values.size()));
    return detail::transact(stream, c, unit, r);
}

// FC 16 (AP §6.12): values.size() registers from `address`.
template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error write_registers(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                               std::uint16_t address, std::span<const std::uint16_t> values) {
    if (values.size() > max_write_registers) return errc::invalid_argument;
    std::array<std::uint8_t, 2 * max_write_registers> bytes{};
    for (std::size_t i = 0; i < values.size(); ++i) put_register(bytes, i, values[i]);
    request r;
    r.function = function::write_multiple_registers;
    r.address = address;
    r.quantity = static_cast<std::uint16_t>(values.size());
    r.data = std::span<const std::uint8_t>(bytes).first(2 * values.size());
    return detail::transact(stream, c, unit, r);
}

// FC 23 (AP §6.17): writes `values` at `write_address`, then reads read_out.size()
// registers from `read_address` (the server writes first).
template <session_stream S, link_mode L, function_set F, class Latch>
ferrule::error read_write_registers(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                                    std::uint16_t read_address, std::span<std::uint16_t> read_out,
                                    std::uint16_t write_address,
                                    std::span<const std::uint16_t> values) {
    if (read_out.size() > max_read_registers || values.size() > max_rw_write_registers)
        return errc::invalid_argument;
    std::array<std::uint8_t, 2 * max_rw_write_registers> bytes{};
    for (std::size_t i = 0; i < values.size(); ++i) put_register(bytes, i, values[i]);
    request r;
    r.function = function::read_write_multiple_registers;
    r.address = read_address;
    r.quantity = static_cast<std::uint16_t>(read_out.size());
    r.write_address = write_address;
    r.write_quantity = static_cast<std::uint16_t>(values.size());
    r.data = std::span<const std::uint8_t>(bytes).first(2 * values.size());
    if (auto ec = detail::transact(stream, c, unit, r)) return ec;
    for (std::size_t i = 0; i < read_out.size(); ++i) read_out[i] = register_at(c.reply().data, i);
    return {};
}

// FC 8 (AP §6.8): the data word of the response (the echo, or a counter's value).
// force_listen_only gets no response and returns 0.
template <session_stream S, link_mode L, function_set F, class Latch>
result<std::uint16_t> diagnostics(S& stream, basic_client<L, F, Latch>& c, std::uint8_t unit,
                                  diag_sub sub, std::uint16_t data = 0) {
    std::array<std::uint8_t, 2> field{};
    store_be16(field.data(), data);
    request r;
    r.function = function::diagnostics;
    r.value = static_cast<std::uint16_t>(sub);
    r.data = field;
    if (auto ec = detail::transact(stream, c, unit, r)) return ec;
    if (sub == diag_sub::force_listen_only) return std::uint16_t{0};
    return load_be16(c.reply().data.data());
}

// FC 43 / 14 (AP §6.21): one response of objects from `object_id`; walk response::data
// with next_device_id_object(), and ask again from next_object_id while more_follows. The
// spans stay valid until the client's next start().
template <session_stream S, link_mode L, function_set F, class Latch>
result<response> read_device_identification(S& stream, basic_client<L, F, Latch>& c,
                                            std::uint8_t unit,
                                            device_id_code code = device_id_code::basic,
                                            std::uint8_t object_id = 0) {
    request r;
    r.function = function::encapsulated_interface;
    r.mei_type = mei_read_device_id;
    r.read_device_id_code = static_cast<std::uint8_t>(code);
    r.object_id = object_id;
    if (auto ec = detail::transact(stream, c, unit, r)) return ec;
    return c.reply();
}

} // namespace ferrule::modbus
