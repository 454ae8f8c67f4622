// What a Modbus server serves: the four data tables of the Modbus data model (Modbus
// Application Protocol V1.1b3 §4.3: discrete inputs, coils, input registers, holding
// registers) and the device identification objects (§6.21, FC 43 / MEI 14).
//
// A data model is any type with these members; server<M> calls them for each request it
// has checked (function code, quantity, byte count). Each returns 0 when done, or the
// exception code the request deserves (exception_code as std::uint8_t): typically
// illegal_data_address for an address outside the table (§7: exception 02),
// illegal_data_value for a value the device refuses, server_device_failure when the device
// cannot do it (04). The server sends that code in an exception response (§7).
//
//   read_bits(fc, address, quantity, out)        FC 1 (coils) or FC 2 (discrete inputs): the
//                                                bits packed LSB first, bit 0 of out[0] is
//                                                `address` (§6.1, §6.2); `out` holds
//                                                ceil(quantity / 8) zeroed bytes
//   read_registers(fc, address, quantity, out)   FC 3 (holding) or FC 4 (input): 2 bytes per
//                                                register, big-endian (§6.3, §6.4)
//   write_coils(address, quantity, packed)       FC 5 and FC 15: packed as read_bits gives
//                                                them (FC 5: one bit, §6.5, §6.11)
//   write_registers(address, quantity, data)     FC 6, FC 16 and the write of FC 23:
//                                                big-endian (§6.6, §6.12, §6.17)
//   device_id(object_id)                         the object's text, empty when there is none
//                                                (§6.21: 0 vendor name, 1 product code,
//                                                2 major minor revision are mandatory)
//
// A write that fails must leave the tables as they were: the server answers it with an
// exception, and the client takes it as not done.
#pragma once

#include <concepts>
#include <cstdint>
#include <span>
#include <string_view>

#include "ferrule/modbus/constants.hpp"

namespace ferrule::modbus {

template <class M>
concept data_model = requires(M& m, function fc, std::uint16_t address, std::uint16_t quantity,
                              std::span<std::uint8_t> out, std::span<const std::uint8_t> in,
                              std::uint8_t object_id) {
    { m.read_bits(fc, address, quantity, out) } -> std::same_as<std::uint8_t>;
    { m.read_registers(fc, address, quantity, out) } -> std::same_as<std::uint8_t>;
    { m.write_coils(address, quantity, in) } -> std::same_as<std::uint8_t>;
    { m.write_registers(address, quantity, in) } -> std::same_as<std::uint8_t>;
    { m.device_id(object_id) } -> std::same_as<std::string_view>;
};

// The exception code as a data model returns it.
constexpr std::uint8_t code_of(exception_code e) noexcept {
    return static_cast<std::uint8_t>(e);
}

} // namespace ferrule::modbus
