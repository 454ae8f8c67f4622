// PROFIBUS-DP ↔ Modbus RTU gateway on a Cortex-M4 (STM32F4 register layout, two UARTs on
// RS-485 transceivers): DP slave 8 (ident 0x0F2A) on USART1 at 19200 8E1 (§B.1), the drive
// (Modbus unit 1) on USART2 at 9600 8E1. Transparent mode (seeds/002): the master's 5 output
// bytes (cfg 0x24 0x14) carry a Modbus request PDU such as 06 C8 00 00 25, the drive's reply
// comes back in the 5 input bytes. When DP is lost the drive gets its control word 0xC800 = 0
// (stop).
//
// A super-loop drives both lines and never waits on either: per line it takes what has
// arrived, asks the gateway what to send, and hands the transmitter one character at a time.
// While a line sends nothing arrives on it (half duplex), so it is not read meanwhile. The
// board's console reports each command the drive answered or failed, with the stack's
// high-water mark.
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/session.hpp"
#include "ferrule/gateway/gateway.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/profibus/constants.hpp"

#include "board.hpp"

namespace {
constexpr auto dp_format = ferrule::profibus::format(19'200);
constexpr ferrule::serial_format drive_format{9'600, 8, ferrule::parity::even, 1};
constexpr std::array<std::uint8_t, 2> cfg{0x24, 0x14}; // 5 bytes out, 5 bytes in
constexpr std::array<ferrule::gateway::safe_write, 1> safe{{{1, 0xC800, 0x0000}}};

board::uart_stream<board::usart1_base> dp_uart(dp_format);
board::uart_stream<board::usart2_base> drive_uart(drive_format);
ferrule::gateway::core gateway([] {
    ferrule::gateway::config c;
    c.dp.baud = dp_format.baud;
    c.dp.address = 8;
    c.dp.ident = 0x0F2A;
    c.dp.cfg = cfg;
    c.modbus.format = drive_format;
    c.modbus.inter_frame_gap = ferrule::modbus::t35(drive_format);
    c.modbus.response_timeout = std::chrono::milliseconds(100);
    c.modbus.retries = 1;
    c.mode = ferrule::gateway::mode::transparent;
    c.drive = 1;
    c.safe_writes = safe;
    return c;
}());

// What has arrived on a line, without waiting.
template <class Uart>
std::span<const std::uint8_t> arrived(Uart& uart, std::span<std::uint8_t> buf) {
    std::size_t n = 0;
    while (n < buf.size()) {
        const ferrule::io_result r = uart.read_some(buf.subspan(n), uart.now());
        if (r.bytes == 0) break;
        n += r.bytes;
    }
    return buf.first(n);
}

// The bytes a session asked to send, until the transmitter has taken them all.
template <class Uart>
void queue_output(Uart& uart, const ferrule::session_action& a,
                  std::span<const std::uint8_t>& out) {
    if (a.what != ferrule::session_action::kind::send) return;
    if (a.discard_input) uart.discard_input();
    out = a.bytes;
}

// One console line per command the drive answered (or did not).
void report_commands() {
    static std::uint32_t seen = 0;
    const ferrule::gateway::stats& s = gateway.stats();
    if (s.delivered + s.failed == seen) return;
    seen = s.delivered + s.failed;
    board::report("delivered=", s.delivered, " failed=", s.failed, " exceptions=", s.exceptions,
                  " stack=", board::stack_high_water());
}
} // namespace

int main() {
    board::init<board::usart1_base>(dp_format);
    board::init<board::usart2_base>(drive_format);
    std::array<std::uint8_t, 32> rx{};
    std::span<const std::uint8_t> dp_out;
    std::span<const std::uint8_t> drive_out;
    for (;;) {
        if (dp_out.empty()) {
            if (const auto in = arrived(dp_uart, rx); !in.empty())
                gateway.on_dp_receive(in, dp_uart.now());
            queue_output(dp_uart, gateway.next_dp(dp_uart.now()), dp_out);
        }
        dp_out = dp_out.subspan(dp_uart.write_some(dp_out));

        if (drive_out.empty()) {
            if (const auto in = arrived(drive_uart, rx); !in.empty())
                gateway.on_modbus_receive(in, drive_uart.now());
            queue_output(drive_uart, gateway.next_modbus(drive_uart.now()), drive_out);
        }
        drive_out = drive_out.subspan(drive_uart.write_some(drive_out));
        report_commands();
    }
}
