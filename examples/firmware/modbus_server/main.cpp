// Modbus RTU server on a Cortex-M4 (STM32F4 register layout, USART2 on an RS-485
// transceiver): unit 17 at 19200 8E1 serves a memory_model of 32 coils, 32 discrete inputs,
// 64 holding and 32 input registers to a PLC, with FC 1-6, 15, 16, 23 and 43/14 (device
// identification), from a super-loop that never blocks and uses no heap. The link is fixed
// to RTU at compile time, so no TCP framing is compiled in, and so are the function codes
// (common/modbus_ten_functions.hpp): FC 8 (diagnostics) would be one more in the set.
// The application mirrors the coils to outputs and its inputs to the discrete inputs and
// input registers between requests. The board's console reports the coils when a master has
// changed them, with the stack's high-water mark.
//
// The byte_stream below is the only board-specific part; ferrule brings the protocol.
#include <array>
#include <cstdint>
#include <span>

#include "ferrule/core/session.hpp"
#include "ferrule/modbus/memory_model.hpp"
#include "ferrule/modbus/server.hpp"

#include "../common/modbus_ten_functions.hpp"
#include "board.hpp"

namespace {
constexpr auto format = ferrule::modbus::default_format;
using model = ferrule::modbus::memory_model<32, 32, 64, 32>;

constinit board::uart_stream uart(format);

// The application's side of the tables.
volatile std::uint32_t outputs = 0; // coil n -> bit n
volatile std::uint32_t inputs = 0;  // bit n -> discrete input n
volatile std::uint16_t analog[32] = {};
} // namespace

int main() {
    board::init(format);
    // In main(), not global: see examples/firmware/modbus_client.
    ferrule::modbus::server<model, ferrule::modbus::link_mode::rtu, example::ten_functions> session(
        [] {
            ferrule::modbus::server_config c;
            c.units = {17};
            c.format = format;
            return c;
        }(),
        model({}, {"ferrule", "fw-server", "1.0"}));
    std::array<std::uint8_t, 64> rx{};
    for (;;) {
        const ferrule::io_result r = uart.read_some(rx, uart.now());
        if (r.bytes > 0) session.on_receive({rx.data(), r.bytes}, uart.now());
        const ferrule::session_action a = session.next(uart.now());
        if (a.what == ferrule::session_action::kind::send) (void)uart.write(a.bytes);
        if (a.what != ferrule::session_action::kind::idle) continue;
        // Between requests: the tables meet the application.
        model& m = session.model();
        std::uint32_t out = 0;
        for (std::size_t i = 0; i < 32; ++i) {
            if (m.coil(i)) out |= 1u << i;
            m.set_discrete_input(i, (inputs >> i) & 1u);
            m.input_registers()[i] = analog[i];
        }
        if (out != outputs) board::report("coils=", out, " stack=", board::stack_high_water());
        outputs = out;
    }
}
