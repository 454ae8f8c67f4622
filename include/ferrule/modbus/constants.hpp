// Modbus wire constants. Sources (protocols/modbus_profibus.md §A):
//   AP   Modbus Application Protocol Specification V1.1b3
//   SL   Modbus over Serial Line Specification and Implementation Guide V1.02
//   TCP  Modbus Messaging on TCP/IP Implementation Guide V1.0b
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>

#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule::modbus {

// Public function codes in scope (AP §5.1, §6).
enum class function : std::uint8_t {
    read_coils = 1,
    read_discrete_inputs = 2,
    read_holding_registers = 3,
    read_input_registers = 4,
    write_single_coil = 5,
    write_single_register = 6,
    diagnostics = 8,
    write_multiple_coils = 15,
    write_multiple_registers = 16,
    read_write_multiple_registers = 23,
    encapsulated_interface = 43,
};

// Which link a session speaks: chosen by its config at run time (any), or fixed at compile
// time (basic_client, server), so firmware for one link does not carry the other's code.
enum class link_mode : std::uint8_t { any, rtu, tcp };

// An exception response carries the function code with its top bit set (AP §7).
inline constexpr std::uint8_t exception_flag = 0x80;
// MEI type of Read Device Identification (AP §6.21).
inline constexpr std::uint8_t mei_read_device_id = 14;

// The function's name (AP §6), for traces and tools; nullptr for a code outside the set.
// FC 43 is named by MEI type 14, the only one ferrule speaks.
constexpr const char* name(function f) noexcept {
    switch (f) {
    case function::read_coils: return "read coils";
    case function::read_discrete_inputs: return "read discrete inputs";
    case function::read_holding_registers: return "read holding registers";
    case function::read_input_registers: return "read input registers";
    case function::write_single_coil: return "write single coil";
    case function::write_single_register: return "write single register";
    case function::diagnostics: return "diagnostics";
    case function::write_multiple_coils: return "write multiple coils";
    case function::write_multiple_registers: return "write multiple registers";
    case function::read_write_multiple_registers: return "read/write multiple registers";
    case function::encapsulated_interface: return "read device identification";
    }
    return nullptr;
}

// The names of the device identification objects 0x00-0x06 (AP §6.21); nullptr above.
constexpr const char* device_id_object_name(std::uint8_t id) noexcept {
    constexpr const char* names[] = {"VendorName",         "ProductCode", "MajorMinorRevision",
                                     "VendorUrl",          "ProductName", "ModelName",
                                     "UserApplicationName"};
    return id < 7 ? names[id] : nullptr;
}

// AP §7, plus 07 as libmodbus lists it.
enum class exception_code : std::uint8_t {
    illegal_function = 1,
    illegal_data_address = 2,
    illegal_data_value = 3,
    server_device_failure = 4,
    acknowledge = 5,
    server_device_busy = 6,
    negative_acknowledge = 7,
    memory_parity_error = 8,
    gateway_path_unavailable = 0x0A,
    gateway_target_failed = 0x0B,
};

// Quantity limits: AP §6.1-§6.4 (read 2000 bits, 125 registers), §6.11 (write 0x7B0 coils),
// §6.12 (write 0x7B registers), §6.17 (FC23: read 0x7D, write 0x79).
inline constexpr std::uint16_t max_read_bits = 2000;
inline constexpr std::uint16_t max_read_registers = 125;
inline constexpr std::uint16_t max_write_bits = 1968;
inline constexpr std::uint16_t max_write_registers = 123;
inline constexpr std::uint16_t max_rw_write_registers = 121;

// PDU 253 bytes (AP §4.1); RTU ADU = address + PDU + CRC (SL §2.4); TCP ADU = MBAP 7 + PDU.
inline constexpr std::size_t max_pdu = 253;
inline constexpr std::size_t max_rtu_adu = 256;
inline constexpr std::size_t mbap_size = 7;
inline constexpr std::size_t max_tcp_adu = 260;

// SL §2.3: 0 broadcast, 1…247 servers, 248…255 reserved.
inline constexpr std::uint8_t broadcast_address = 0;
inline constexpr std::uint8_t max_unit_address = 247;

// SL §2.5.1: even parity is the default (8E1); 19200 baud as libmodbus and goburrow start.
inline constexpr serial_format default_format{19200, 8, parity::even, 1};

// FC 43 / 14 read device id codes (AP §6.21).
enum class device_id_code : std::uint8_t { basic = 1, regular = 2, extended = 3, specific = 4 };

// FC 08 sub-functions (AP §6.8.1).
enum class diag_sub : std::uint16_t {
    return_query_data = 0,
    restart_comm = 1,
    return_diagnostic_register = 2,
    force_listen_only = 4, // the server stops answering: no reply to this one either
    clear_counters = 10,
    bus_message_count = 11,
    bus_comm_error_count = 12,
    bus_exception_count = 13,
    server_message_count = 14,
    server_no_response_count = 15,
    server_nak_count = 16,
    server_busy_count = 17,
    bus_char_overrun_count = 18,
};

namespace detail {
// n/10 character times of `f`, rounded up to the clock's resolution.
constexpr duration tenth_chars(const serial_format& f, std::uint64_t tenths) noexcept {
    return ceil_seconds(tenths * f.bits_per_char(), 10ull * f.baud);
}
} // namespace detail

// SL §2.5.1.1: silence inside a frame must stay under 1.5 character times, frames are
// separated by 3.5; above 19200 baud the timers are fixed at 750 us and 1.750 ms.
constexpr duration t15(const serial_format& f) noexcept {
    if (f.baud > 19200) return std::chrono::microseconds(750);
    return detail::tenth_chars(f, 15);
}
constexpr duration t35(const serial_format& f) noexcept {
    if (f.baud > 19200) return std::chrono::microseconds(1750);
    return detail::tenth_chars(f, 35);
}

} // namespace ferrule::modbus
