// Modbus RTU client on a Cortex-M4 (STM32F4 register layout, USART2 on an RS-485
// transceiver) that uses ten function codes: a super-loop goes round a scan list on unit 1
// at 19200 8E1 — coils, discrete inputs, holding and input registers (FC 1-4), one coil and
// one register (FC 5, 6), sixteen coils and four registers (FC 15, 16), a read/write of
// registers (FC 23) and the basic device identification (FC 43/14) — without blocking and
// without heap. A failed transaction is counted and the list goes on.
//
// Its function set (common/modbus_ten_functions.hpp) is every function code that ferrule's
// client and nanoMODBUS's both have, so docs/PERFORMANCE.md compares the two clients'
// firmware size on this program.
//
// The byte_stream below is the only board-specific part; ferrule brings the protocol.
#include <array>
#include <cstdint>
#include <span>

#include "ferrule/core/driver.hpp"
#include "ferrule/modbus/client.hpp"
#include "ferrule/modbus/registers.hpp"

#include "../common/modbus_ten_functions.hpp"
#include "board.hpp"

namespace {
namespace mb = ferrule::modbus;
constexpr auto format = mb::default_format;
constexpr std::uint8_t unit = 1;

constinit board::uart_stream uart(format);

// The process image this device exchanges with unit 1.
volatile std::uint16_t coils_in = 0;     // FC 1: coils 0-15
volatile std::uint16_t inputs = 0;       // FC 2: discrete inputs 0-15
volatile std::uint16_t holding[8] = {};  // FC 3 / FC 23: holding registers 0-7
volatile std::uint16_t measured[8] = {}; // FC 4: input registers 0-7
volatile std::uint16_t coils_out = 0;    // FC 15: coils 16-31
volatile bool alarm = false;             // FC 5: coil 32
volatile std::uint16_t setpoint = 0;     // FC 6: register 16
volatile std::uint16_t outputs[4] = {};  // FC 16 / FC 23: registers 20-23
volatile std::uint8_t vendor_length = 0; // FC 43/14: length of object 0, the vendor name
volatile std::uint32_t failures = 0;

std::array<std::uint8_t, 2> packed_out{};
std::array<std::uint8_t, 8> register_out{};

// The request of scan list entry `i`; its data points at this file's buffers.
mb::request entry(std::size_t i) {
    mb::request r;
    switch (i) {
    case 0:
        r.function = mb::function::read_coils;
        r.quantity = 16;
        break;
    case 1:
        r.function = mb::function::read_discrete_inputs;
        r.quantity = 16;
        break;
    case 2:
        r.function = mb::function::read_holding_registers;
        r.quantity = 8;
        break;
    case 3:
        r.function = mb::function::read_input_registers;
        r.quantity = 8;
        break;
    case 4:
        r.function = mb::function::write_single_coil;
        r.address = 32;
        r.value = alarm ? mb::coil_on : mb::coil_off;
        break;
    case 5:
        r.function = mb::function::write_single_register;
        r.address = 16;
        r.value = setpoint;
        break;
    case 6:
        r.function = mb::function::write_multiple_coils;
        r.address = 16;
        r.quantity = 16;
        packed_out = {static_cast<std::uint8_t>(coils_out),
                      static_cast<std::uint8_t>(coils_out >> 8)};
        r.data = packed_out;
        break;
    case 7:
    case 8:
        r.function = i == 7 ? mb::function::write_multiple_registers
                            : mb::function::read_write_multiple_registers;
        for (std::size_t k = 0; k < 4; ++k) {
            register_out[2 * k] = static_cast<std::uint8_t>(outputs[k] >> 8);
            register_out[2 * k + 1] = static_cast<std::uint8_t>(outputs[k]);
        }
        r.data = register_out;
        if (i == 7) {
            r.address = 20;
            r.quantity = 4;
        } else {
            r.quantity = 8;
            r.write_address = 20;
            r.write_quantity = 4;
        }
        break;
    default:
        r.function = mb::function::encapsulated_interface;
        r.read_device_id_code = 1; // basic: vendor name, product code, revision
        break;
    }
    return r;
}

void take(std::size_t i, const mb::response& r) {
    switch (i) {
    case 0: coils_in = static_cast<std::uint16_t>(r.data[0] | r.data[1] << 8); break;
    case 1: inputs = static_cast<std::uint16_t>(r.data[0] | r.data[1] << 8); break;
    case 2:
    case 8:
        for (std::size_t k = 0; k < 8; ++k) holding[k] = mb::register_at(r.data, k);
        break;
    case 3:
        for (std::size_t k = 0; k < 8; ++k) measured[k] = mb::register_at(r.data, k);
        break;
    case 9: {
        std::span<const std::uint8_t> objects = r.data;
        mb::device_id_object o;
        if (mb::next_device_id_object(objects, o) && o.id == 0)
            vendor_length = static_cast<std::uint8_t>(o.value.size());
        break;
    }
    default: break; // the writes: the echo was checked by the client
    }
}
} // namespace

int main() {
    board::init(format);
    // In main(), not global: see examples/firmware/modbus_client.
    example::ten_function_client session(example::ten_function_config());
    ferrule::poll_driver driver(uart, session);
    std::size_t i = 0;
    for (;;) {
        if (driver.step() != ferrule::session_action::kind::done) {
            if (!session.busy()) (void)session.start(unit, entry(i));
            continue;
        }
        if (!session.succeeded())
            failures = failures + 1;
        else
            take(i, session.reply());
        session.clear();
        i = (i + 1) % 10;
    }
}
