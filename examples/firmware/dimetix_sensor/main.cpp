// Dimetix D-Series sensor on a Cortex-M4 (STM32F4 register layout, USART2 on an RS-485
// transceiver, 19200 7E1, the sensor's factory setting): a super-loop that connects the way
// the PLC program of the paper does (sNc until gN?), then measures the distance with sNg
// again and again, without blocking and without heap. An error answer gN@Ezzz is kept as
// its code; a lost link is recovered with sNc.
//
// It reports on the board's console what a test can check against the sensor: each change of
// the link, each distance that differs from the last or follows an error, each error code and,
// every 100 transactions, the stack's high-water mark.
//
// The byte_stream below is the only board-specific part; ferrule brings the protocol.
#include <cstdint>
#include <span>

#include "ferrule/core/driver.hpp"
#include "ferrule/dimetix/sensor.hpp"

#include "board.hpp"

namespace {
constexpr std::uint8_t sensor_id = 1; // sNid of the sensor on the line

constinit board::uart_stream uart(ferrule::dimetix::default_format);

// PLC-style outputs of this example, e.g. for a display task (names as in the paper).
volatile bool connected = false;
volatile std::int32_t value = 0;      // distance in 0.1 mm
volatile std::int32_t error_code = 0; // zzz of the last gN@Ezzz
} // namespace

int main() {
    board::init(ferrule::dimetix::default_format);
    using namespace ferrule::dimetix;
    // The session lives in main(), which never returns: start-up writes its few non-zero
    // fields. A global would be constant-initialised and copied from flash whole (.data).
    sensor dimetix_sensor;
    ferrule::poll_driver driver(uart, dimetix_sensor);
    (void)dimetix_sensor.start_connect(sensor_id);
    std::uint32_t transactions = 0;
    bool failed = false; // the last measurement was an error answer
    for (;;) {
        if (driver.step() != ferrule::session_action::kind::done) continue;
        const ferrule::error ec = dimetix_sensor.error();
        const bool was_connect = !connected;
        dimetix_sensor.clear();
        if (!ec) {
            connected = true;
            if (was_connect) {
                board::report("connected");
            } else if (const std::int32_t d = dimetix_sensor.reply().values[0];
                       failed || value != d) {
                value = d;
                failed = false;
                board::report("distance=", d);
            }
        } else if (ec.domain() == &device_domain) {
            error_code = ec.value(); // the sensor answered: the link is fine
            failed = true;
            board::report("error=", error_code);
        } else if (connected) {
            connected = false; // timeouts: back to the start-up, sNc until gN?
            board::report("disconnected");
        }
        if (++transactions % 100 == 0)
            board::report("transactions=", transactions, " stack=", board::stack_high_water());
        static constexpr planned_command measure = plan(distance(sensor_id));
        if (connected)
            (void)dimetix_sensor.start(measure);
        else
            (void)dimetix_sensor.start_connect(sensor_id);
    }
}
