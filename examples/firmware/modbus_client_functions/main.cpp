// Modbus RTU client on a Cortex-M4 (STM32F4 register layout, USART2 on an RS-485
// transceiver) that uses ten function codes: a super-loop goes round a scan list on unit 1,
// a drive, at 19200 8E1 — its control and status bits and registers (FC 1-4), one control
// bit and the frequency setpoint (FC 5, 6), three control bits and four parameters (FC 15,
// 16), the parameters written and the live registers read in one request (FC 23) and the
// basic device identification (FC 43/14) — without blocking and without heap. A failed
// transaction is counted and the list goes on. The addresses are those of the simulated
// drive (include/ferrule/modbus/sim/vfd.hpp, `ferrule-sim modbus`): control word 0xC800
// (coils 0-15 are its bits), status word 0xC802 (discrete inputs 0-15), parameters 0xC900.
// FC 15 and FC 5 together write the control word 0x0025, the gateway paper's start.
//
// Its function set (common/modbus_ten_functions.hpp) is every function code that ferrule's
// client and nanoMODBUS's both have, so docs/PERFORMANCE.md compares the two clients'
// firmware size on this program. Every 20 rounds of the list the board's console reports
// what it read, the failures and the stack's high-water mark.
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
volatile std::uint16_t coils_in = 0;       // FC 1: coils 0-15, the control word's bits
volatile std::uint16_t inputs = 0;         // FC 2: discrete inputs 0-15, the status word's bits
volatile std::uint16_t parameters[4] = {}; // FC 3: registers 0xC900-0xC903
volatile std::uint16_t live[5] = {};       // FC 4 / FC 23: registers 0xC800-0xC804
volatile std::uint16_t coils_out = 0x05;   // FC 15: coils 0-2, run and enable
volatile bool setpoint_enable = true;      // FC 5: coil 5
volatile std::uint16_t setpoint = 2500;    // FC 6: register 0xC801, 25.00 Hz
// FC 16 / FC 23: registers 0xC900-0xC903: max frequency 50.00 Hz, acceleration and
// deceleration time 1.0 s, baud rate select 0 (19200).
volatile std::uint16_t settings[4] = {5000, 10, 10, 0};
volatile std::uint8_t vendor_length = 0; // FC 43/14: length of object 0, the vendor name
volatile std::uint32_t failures = 0;

constexpr std::uint16_t control_word = 0xC800;
constexpr std::uint16_t frequency_setpoint = 0xC801;
constexpr std::uint16_t max_frequency = 0xC900;

std::array<std::uint8_t, 1> packed_out{};
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
        r.address = max_frequency;
        r.quantity = 4;
        break;
    case 3:
        r.function = mb::function::read_input_registers;
        r.address = control_word;
        r.quantity = 5;
        break;
    case 4:
        r.function = mb::function::write_single_coil;
        r.address = 5;
        r.value = setpoint_enable ? mb::coil_on : mb::coil_off;
        break;
    case 5:
        r.function = mb::function::write_single_register;
        r.address = frequency_setpoint;
        r.value = setpoint;
        break;
    case 6:
        r.function = mb::function::write_multiple_coils;
        r.quantity = 3;
        packed_out = {static_cast<std::uint8_t>(coils_out)};
        r.data = packed_out;
        break;
    case 7:
    case 8:
        r.function = i == 7 ? mb::function::write_multiple_registers
                            : mb::function::read_write_multiple_registers;
        for (std::size_t k = 0; k < 4; ++k) {
            register_out[2 * k] = static_cast<std::uint8_t>(settings[k] >> 8);
            register_out[2 * k + 1] = static_cast<std::uint8_t>(settings[k]);
        }
        r.data = register_out;
        if (i == 7) {
            r.address = max_frequency;
            r.quantity = 4;
        } else {
            r.address = control_word;
            r.quantity = 5;
            r.write_address = max_frequency;
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
        for (std::size_t k = 0; k < 4; ++k) parameters[k] = mb::register_at(r.data, k);
        break;
    case 3:
    case 8:
        for (std::size_t k = 0; k < 5; ++k) live[k] = mb::register_at(r.data, k);
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

// Every 20 rounds of the scan list: what it read (live: control word, setpoint, status word,
// output frequency, fault code).
void report() {
    static std::uint32_t rounds = 0;
    if (++rounds % 20 != 0) return;
    board::report("rounds=", rounds, " failures=", failures, " coils=", coils_in,
                  " inputs=", inputs, " live=", live[0], ",", live[1], ",", live[2], ",", live[3],
                  ",", live[4], " parameters=", parameters[0], ",", parameters[1], ",",
                  parameters[2], ",", parameters[3], " vendor_length=", vendor_length,
                  " stack=", board::stack_high_water());
}
} // namespace

int main() {
    board::init(format);
    // In main(), not global: see examples/firmware/modbus_client.
    example::ten_function_client session(example::ten_function_config());
    ferrule::poll_driver driver(uart, session);
    std::size_t i = 0;
    for (;;) {
        // A transaction may end inside a step that reports waiting: its result is read at
        // the next step (done); a start before that would replace it.
        const ferrule::session_action::kind what = driver.step();
        if (what == ferrule::session_action::kind::idle) (void)session.start(unit, entry(i));
        if (what != ferrule::session_action::kind::done) continue;
        if (!session.succeeded())
            failures = failures + 1;
        else
            take(i, session.reply());
        session.clear();
        i = (i + 1) % 10;
        if (i == 0) report();
    }
}
