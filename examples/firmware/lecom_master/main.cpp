// LECOM-B master on a Cortex-M4 (STM32F4 register layout, USART2 on an RS-485 transceiver):
// the bus of the LECOM paper, six 4900 DC drives at addresses 01…06 run at 9600 8E1
// (lecom::lenze_4900), polled by a super-loop for their actual speed (C0050) without
// blocking and without heap. A new speed setpoint (C0046 of drive 01), handed over by
// another task, is written before the next poll; the first one, 1500 rpm, at start-up.
//
// It reports on the board's console what a test can check against the drives: each write
// and its outcome, each change of the online drives and, every 60 transactions, the actual
// speeds and the stack's high-water mark.
//
// The byte_stream below is the only board-specific part; ferrule brings the protocol.
#include <cstdint>
#include <span>

#include "ferrule/core/driver.hpp"
#include "ferrule/lecom/poller.hpp"

#include "board.hpp"

namespace {
constexpr std::uint8_t drives = 6;
constexpr auto format = ferrule::lecom::lenze_4900.format;

constinit board::uart_stream uart(format);
ferrule::lecom::poller<drives, 1, drives> bus;

// PLC-style inputs and outputs of this example, e.g. for a display task.
volatile std::int32_t actual_speed[drives] = {}; // C0050 × 10⁴ (FIX32)
volatile std::uint8_t online = 0;                // bit n: drive n + 1 answers
volatile std::int32_t setpoint = 1500 * 10'000;  // C0046 × 10⁴, written when it changes

// C0050 of each drive, polled round the list.
[[gnu::noinline]] void add_polls() {
    for (std::uint8_t a = 1; a <= drives; ++a) (void)bus.add({a, ferrule::lecom::code(50)});
}

// A change of the online drives at once; the actual speeds every 60 transactions.
[[gnu::noinline]] void report_status(std::uint32_t transactions, std::uint8_t was_online,
                                     std::uint8_t now_online) {
    if (now_online != was_online) board::report("online=", now_online);
    if (transactions % 60 != 0) return;
    board::print("transactions=");
    board::print_uint(transactions);
    board::print(" C0050=");
    for (std::size_t i = 0; i < drives; ++i) {
        board::print_int(actual_speed[i]);
        board::print(i + 1 < drives ? "," : "");
    }
    board::report(" stack=", board::stack_high_water());
}
} // namespace

int main() {
    board::init(format);
    using namespace ferrule::lecom;
    add_polls();
    ferrule::poll_driver driver(uart, bus);
    std::int32_t written = 0;
    std::uint32_t seen = 0;
    for (;;) {
        driver.step();
        if (setpoint != written && !bus.write(1, code(46), decimal_fixed(setpoint)))
            written = setpoint;
        if (bus.completed() == seen) continue;
        seen = bus.completed();
        const poll_event& e = bus.last_event();
        if (e.what == poll_event::kind::read && !e.error) actual_speed[e.item] = e.value.fixed;
        if (e.what == poll_event::kind::write)
            board::report("write drive=", e.address, " C0046=", e.value.fixed,
                          " error=", e.error.value());
        std::uint8_t mask = 0;
        for (std::size_t i = 0; i < drives; ++i)
            if (bus.drives()[i].online) mask = static_cast<std::uint8_t>(mask | 1u << i);
        report_status(seen, online, mask);
        online = mask;
    }
}
