// Modbus RTU client on a Cortex-M4 (STM32F4 register layout, USART2 on an RS-485
// transceiver): a super-loop polls four holding registers of each of three servers (units
// 1…3) at 19200 8E1 without blocking and without heap, and writes a setpoint register of
// unit 1 (FC 6) when another task changes it, before the next poll. A write that fails is
// reported, not repeated: the next change is written again.
//
// The byte_stream below is the only board-specific part; ferrule brings the protocol.
#include <cstdint>
#include <span>

#include "ferrule/core/driver.hpp"
#include "ferrule/modbus/client.hpp"
#include "ferrule/modbus/registers.hpp"

#include "board.hpp"

namespace {
constexpr std::uint8_t units = 3;
constexpr std::uint16_t first_register = 0x0000;
constexpr std::uint16_t registers = 4;
constexpr std::uint16_t setpoint_register = 0x0010;
constexpr auto format = ferrule::modbus::default_format;

constinit board::uart_stream uart(format);
// RTU only, FC 3 and 6 only: the TCP path and the other function codes are not compiled in.
using client_type = ferrule::modbus::basic_client<
    ferrule::modbus::link_mode::rtu,
    ferrule::modbus::functions<ferrule::modbus::function::read_holding_registers,
                               ferrule::modbus::function::write_single_register>>;

// PLC-style inputs and outputs of this example, e.g. for a display task.
volatile std::uint16_t values[units][registers] = {};
volatile std::uint8_t online = 0;      // bit n: unit n + 1 answers
volatile std::uint16_t setpoint = 0;   // written to unit 1 when it changes
volatile bool setpoint_failed = false; // the last write was not acknowledged
} // namespace

int main() {
    using namespace ferrule::modbus;
    board::init(format);
    // The session lives in main(), which never returns: start-up writes its few non-zero
    // fields. A global would be constant-initialised and copied from flash whole (.data),
    // buffers and all: about 1 KB more flash.
    client_type session([] {
        ferrule::modbus::client_config c;
        c.format = format;
        c.inter_frame_gap = ferrule::modbus::t35(format);
        c.response_timeout = std::chrono::milliseconds(100);
        c.retries = 2;
        return c;
    }());
    ferrule::poll_driver driver(uart, session);
    std::uint8_t unit = 1;
    std::uint16_t written = 0;
    std::uint16_t sending = 0;
    bool writing = false;
    for (;;) {
        if (driver.step() != ferrule::session_action::kind::done) {
            if (session.busy()) continue;
            request r;
            sending = setpoint;
            writing = sending != written;
            if (writing) {
                r.function = function::write_single_register;
                r.address = setpoint_register;
                r.value = sending;
                (void)session.start(1, r);
            } else {
                r.function = function::read_holding_registers;
                r.address = first_register;
                r.quantity = registers;
                (void)session.start(unit, r);
            }
            continue;
        }
        const bool ok = session.succeeded();
        if (writing) {
            written = sending;
            setpoint_failed = !ok;
        } else {
            const std::uint8_t bit = static_cast<std::uint8_t>(1u << (unit - 1));
            online = static_cast<std::uint8_t>(ok ? online | bit : online & ~bit);
            if (ok)
                for (std::size_t i = 0; i < registers; ++i)
                    values[unit - 1][i] = register_at(session.reply().data, i);
            unit = static_cast<std::uint8_t>(unit % units + 1);
        }
        session.clear();
    }
}
