// Modbus RTU server and client in one Cortex-M4 program (STM32F4 register layout, two
// RS-485 lines at 19200 8E1): a protocol concentrator. On USART1 it is unit 17 to a PLC, a
// memory_model of 32 coils, 32 discrete inputs, 64 holding and 32 input registers; on USART2
// it is the client of a drive, unit 1 (the registers of include/ferrule/modbus/sim/vfd.hpp,
// `ferrule-sim modbus`). Between the PLC's requests the loop copies the drive's registers
// 0xC800-0xC804 (FC 4: control word, setpoint, status word, output frequency, fault code)
// into its own input registers 0-4 and the drive's discrete inputs 0-15 (FC 2, the status
// word's bits) into its own, and writes its holding registers 0-1 to the drive's control
// word and setpoint (FC 16) when the PLC has changed them. Neither side blocks the other.
// The board's console reports each write to the drive, the drive's failed transactions so
// far and the stack's high-water mark.
//
// Both sides are built for the ten function codes of common/modbus_ten_functions.hpp, the
// client as in modbus_client_functions, so docs/PERFORMANCE.md compares "client and server
// in one program" on this program.
#include <array>
#include <cstdint>
#include <span>

#include "ferrule/core/driver.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/modbus/client.hpp"
#include "ferrule/modbus/memory_model.hpp"
#include "ferrule/modbus/registers.hpp"
#include "ferrule/modbus/server.hpp"

#include "../common/modbus_ten_functions.hpp"
#include "board.hpp"

namespace {
namespace mb = ferrule::modbus;
constexpr auto format = mb::default_format;
using model = mb::memory_model<32, 32, 64, 32>;

constinit board::uart_stream<board::usart1_base> plc_uart(format);
constinit board::uart_stream<board::usart2_base> drive_uart(format);

volatile std::uint32_t drive_failures = 0;

constexpr std::uint16_t drive_control_word = 0xC800;
constexpr std::size_t drive_live = 5;   // 0xC800-0xC804
constexpr std::size_t drive_writes = 2; // control word and setpoint
} // namespace

int main() {
    board::init<board::usart1_base>(format);
    board::init<board::usart2_base>(format);
    // In main(), not global: see examples/firmware/modbus_client.
    mb::server<model, mb::link_mode::rtu, example::ten_functions> server(
        [] {
            mb::server_config c;
            c.units = {17};
            c.format = format;
            return c;
        }(),
        model({}, {"ferrule", "fw-concentrator", "1.0"}));
    example::ten_function_client client(example::ten_function_config());
    ferrule::poll_driver drive(drive_uart, client);
    std::array<std::uint8_t, 64> rx{};
    std::array<std::uint16_t, drive_writes> written{};
    std::array<std::uint8_t, 2 * drive_writes> out{};
    int step = 0; // 0: FC 4, 1: FC 2, 2: FC 16 when holding 0-3 changed
    for (;;) {
        // The PLC's line first: a request is answered t3.5 after it ended.
        const ferrule::io_result r = plc_uart.read_some(rx, plc_uart.now());
        if (r.bytes > 0) server.on_receive({rx.data(), r.bytes}, plc_uart.now());
        const ferrule::session_action a = server.next(plc_uart.now());
        if (a.what == ferrule::session_action::kind::send) (void)plc_uart.write(a.bytes);

        // Then the drive's line, one step. A transaction may end inside a step that reports
        // waiting: its result is read at the next step (done), so a new one starts only when
        // the client is idle.
        model& m = server.model();
        const ferrule::session_action::kind what = drive.step();
        if (what == ferrule::session_action::kind::idle) {
            mb::request q;
            if (step == 0) {
                q.function = mb::function::read_input_registers;
                q.address = drive_control_word;
                q.quantity = drive_live;
            } else if (step == 1) {
                q.function = mb::function::read_discrete_inputs;
                q.quantity = 16;
            } else {
                q.function = mb::function::write_multiple_registers;
                q.address = drive_control_word;
                q.quantity = drive_writes;
                for (std::size_t k = 0; k < drive_writes; ++k) {
                    out[2 * k] = static_cast<std::uint8_t>(m.holding_registers()[k] >> 8);
                    out[2 * k + 1] = static_cast<std::uint8_t>(m.holding_registers()[k]);
                }
                q.data = out;
            }
            (void)client.start(1, q);
            continue;
        }
        if (what != ferrule::session_action::kind::done) continue;
        if (!client.succeeded()) {
            drive_failures = drive_failures + 1;
        } else if (step == 0) {
            for (std::size_t k = 0; k < drive_live; ++k)
                m.input_registers()[k] = mb::register_at(client.reply().data, k);
        } else if (step == 1) {
            for (std::size_t k = 0; k < 16; ++k)
                m.set_discrete_input(k, (client.reply().data[k / 8] >> k % 8) & 1u);
        } else {
            for (std::size_t k = 0; k < drive_writes; ++k) written[k] = m.holding_registers()[k];
            board::report("to_drive=", written[0], ",", written[1], " failures=", drive_failures,
                          " stack=", board::stack_high_water());
        }
        client.clear();
        bool changed = false;
        for (std::size_t k = 0; k < drive_writes; ++k)
            changed = changed || written[k] != m.holding_registers()[k];
        step = step == 0 ? 1 : (changed ? 2 : 0);
    }
}
