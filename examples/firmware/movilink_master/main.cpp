// MOVILINK master on a Cortex-M4 (STM32F4 register layout, USART2 on an RS-485
// transceiver, 9600 8E1): a super-loop that runs the drive with cyclic 3PD exchanges and
// reads the heat sink temperature (P014) now and then, without blocking and without heap.
//
// It reports on the board's console what a test can check against the drive: each P014
// reading and, every 100 cycles, the process input data and the stack's high-water mark.
// The byte_stream over the USART is the only board-specific part; ferrule brings the protocol.
#include <cstdint>
#include <span>

#include "ferrule/core/driver.hpp"
#include "ferrule/movilink/cyclic.hpp"

#include "board.hpp"

namespace {
constinit board::uart_stream uart(ferrule::movilink::default_format);

// PLC-style outputs of this example, e.g. for a display task.
volatile std::uint16_t status_word = 0;
volatile std::uint16_t actual_speed = 0;
volatile std::uint32_t heat_sink_temperature = 0;
} // namespace

int main() {
    board::init(ferrule::movilink::default_format);
    using namespace ferrule::movilink;
    // The sessions live in main(), which never returns: start-up writes their few non-zero
    // fields. Globals would be constant-initialised and copied from flash whole (.data).
    master movilink_master;
    cyclic drive(movilink_master, 1);
    drive.set_po(0, 0x0006);   // control word 1: enable
    drive.set_po(1, 1500 * 5); // 1500 rpm at 0.2 rpm per digit
    drive.set_po(2, 2000);     // ramp 2 s
    ferrule::poll_driver driver(uart, drive);
    std::uint32_t last_read = 0;
    for (;;) {
        driver.step();
        status_word = drive.pi(0);
        actual_speed = drive.pi(1);
        if (drive.cycles() - last_read >= 100 &&
            drive.request_parameter(param_channel::make(service::read, 0x2087))) { // P014
            last_read = drive.cycles();
            board::report("cycles=", drive.cycles(), " status=", status_word,
                          " speed=", actual_speed, " stack=", board::stack_high_water());
        }
        if (drive.parameter_done() && !drive.parameter_error() &&
            heat_sink_temperature != drive.parameter_value()) {
            heat_sink_temperature = drive.parameter_value();
            board::report("P014=", heat_sink_temperature);
        }
        if (movilink_master.fault_latched()) {
            drive.set_po(0, 0x0000); // rapid stop once the link is back
            movilink_master.reset_fault();
        }
    }
}
