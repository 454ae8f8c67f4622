// Modbus RTU client on a Cortex-M4 (STM32F4 register layout, USART2 on an RS-485
// transceiver): a super-loop polls four holding registers of each of three servers (units
// 1…3) at 19200 8E1 without blocking and without heap, and writes a setpoint register of
// unit 1 (FC 6) when another task changes it, before the next poll; the first setpoint at
// start-up. A write that fails is reported, not repeated: the next change is written again.
// The servers are VFDs with the gateway paper's register block (control word 0xC800, then
// frequency setpoint, status word and output frequency), as ferrule-sim modbus simulates.
//
// It reports on the board's console what a test can check against the servers: each write
// and its outcome and, every 30 reads, the online units, their registers and the stack's
// high-water mark.
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
constexpr std::uint16_t first_register = 0xC800;
constexpr std::uint16_t registers = 4;
constexpr std::uint16_t setpoint_register = 0xC801; // 0.01 Hz
constexpr auto format = ferrule::modbus::default_format;

constinit board::uart_stream uart(format);
// RTU only, FC 3 and 6 only: the TCP path and the other function codes are not compiled in.
using client_type = ferrule::modbus::basic_client<
    ferrule::modbus::link_mode::rtu,
    ferrule::modbus::functions<ferrule::modbus::function::read_holding_registers,
                               ferrule::modbus::function::write_single_register>>;

// PLC-style inputs and outputs of this example, e.g. for a display task.
volatile std::uint16_t values[units][registers] = {};
volatile std::uint8_t online = 0;       // bit n: unit n + 1 answers
volatile std::uint16_t setpoint = 2500; // written to unit 1 when it changes: 25.00 Hz
volatile bool setpoint_failed = false;  // the last write was not acknowledged

[[gnu::noinline]] void report_write(std::uint16_t value) {
    board::report("write unit=1 register=", setpoint_register, " value=", value,
                  setpoint_failed ? " failed" : " ok");
}

[[gnu::noinline]] void report_reads(std::uint32_t reads) {
    board::print("reads=");
    board::print_uint(reads);
    board::print(" online=");
    board::print_uint(online);
    for (std::size_t u = 0; u < units; ++u) {
        board::print(" unit");
        board::print_uint(u + 1);
        for (std::size_t i = 0; i < registers; ++i) {
            board::print(i == 0 ? "=" : ",");
            board::print_uint(values[u][i]);
        }
    }
    board::report(" stack=", board::stack_high_water());
}
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
    std::uint32_t reads = 0;
    for (;;) {
        const auto step = driver.step();
        if (step != ferrule::session_action::kind::done) {
            // Only an idle session takes a request: a step that hands the reply over leaves
            // the session done, but not busy, with its result still to read.
            if (step != ferrule::session_action::kind::idle) continue;
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
            report_write(sending);
        } else {
            const std::uint8_t bit = static_cast<std::uint8_t>(1u << (unit - 1));
            online = static_cast<std::uint8_t>(ok ? online | bit : online & ~bit);
            if (ok)
                for (std::size_t i = 0; i < registers; ++i)
                    values[unit - 1][i] = register_at(session.reply().data, i);
            unit = static_cast<std::uint8_t>(unit % units + 1);
            if (++reads % 30 == 0) report_reads(reads);
        }
        session.clear();
    }
}
