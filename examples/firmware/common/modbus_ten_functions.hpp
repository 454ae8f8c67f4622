// The ten function codes that ferrule and nanoMODBUS both have (FC 1-6, 15, 16, 23, 43/14;
// FC 8 is ferrule's alone), for the examples that docs/PERFORMANCE.md uses to compare the two
// libraries' firmware size on the same functions: the servers of modbus_server and
// modbus_client_server, and the RTU client of modbus_client_functions and
// modbus_client_server (19200 8E1, t3.5 before each request, 100 ms response timeout, one
// resend).
#pragma once

#include <chrono>

#include "ferrule/modbus/client.hpp"

namespace example {

inline constexpr ferrule::modbus::function_set ten_functions = ferrule::modbus::functions<
    ferrule::modbus::function::read_coils, ferrule::modbus::function::read_discrete_inputs,
    ferrule::modbus::function::read_holding_registers,
    ferrule::modbus::function::read_input_registers, ferrule::modbus::function::write_single_coil,
    ferrule::modbus::function::write_single_register,
    ferrule::modbus::function::write_multiple_coils,
    ferrule::modbus::function::write_multiple_registers,
    ferrule::modbus::function::read_write_multiple_registers,
    ferrule::modbus::function::encapsulated_interface>;

// Without the fault latch (68 bytes), which nanoMODBUS has no counterpart of either.
using ten_function_client = ferrule::modbus::basic_client<ferrule::modbus::link_mode::rtu,
                                                          ten_functions, ferrule::no_fault_latch>;

constexpr ferrule::modbus::client_config ten_function_config() noexcept {
    ferrule::modbus::client_config c;
    c.format = ferrule::modbus::default_format;
    c.inter_frame_gap = ferrule::modbus::t35(c.format);
    c.response_timeout = std::chrono::milliseconds(100);
    c.retries = 1;
    return c;
}

} // namespace example
