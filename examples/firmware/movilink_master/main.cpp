// MOVILINK master on a Cortex-M4 (STM32F4 register layout, USART2 on an RS-485
// transceiver, 9600 8E1): a super-loop that runs the drive with cyclic 3PD exchanges and
// reads the heat sink temperature (P014) now and then, without blocking and without heap.
//
// The byte_stream below is the only board-specific part; ferrule brings the protocol.
#include <cstdint>
#include <span>

#include "ferrule/core/driver.hpp"
#include "ferrule/movilink/cyclic.hpp"

namespace board {

// STM32F4 USART2 and SysTick registers (RM0090 §30.6, PM0214 §4.5).
struct usart_regs {
    volatile std::uint32_t sr, dr, brr, cr1, cr2, cr3, gtpr;
};
inline usart_regs& usart2 = *reinterpret_cast<usart_regs*>(0x40004400u);
constexpr std::uint32_t sr_rxne = 1u << 5;
constexpr std::uint32_t sr_txe = 1u << 7;
constexpr std::uint32_t sr_tc = 1u << 6;
volatile std::uint32_t& systick_val = *reinterpret_cast<volatile std::uint32_t*>(0xE000E018u);

volatile std::uint64_t ticks_us = 0; // advanced by the SysTick handler below
constexpr std::uint32_t core_hz = 16'000'000;

extern "C" void SysTick_Handler() {
    ticks_us = ticks_us + 1000;
}

void init() {
    // 9600 baud from 16 MHz; 9 data bits incl. parity (M), parity enable (PCE), even (PS=0).
    usart2.brr = core_hz / 9600;
    usart2.cr1 = (1u << 13) | (1u << 12) | (1u << 10) | (1u << 3) | (1u << 2);
}

// A ferrule byte_stream over the UART, polling (no interrupts needed).
class uart_stream {
public:
    using time_point = ferrule::time_point;

    time_point now() const noexcept {
        // SysTick counts down from (core_hz / 1000 - 1) each millisecond.
        const std::uint32_t sub = (core_hz / 1000 - 1 - systick_val) / (core_hz / 1'000'000);
        return time_point{std::chrono::microseconds(ticks_us + sub)};
    }
    ferrule::io_result write(std::span<const std::uint8_t> out) noexcept {
        for (auto b : out) {
            while (!(usart2.sr & sr_txe)) {
            }
            usart2.dr = b;
        }
        while (!(usart2.sr & sr_tc)) {
        } // RS-485: release the bus only after the last bit
        return {out.size(), {}};
    }
    // Non-blocking when deadline <= now (the poll driver's case).
    ferrule::io_result read_some(std::span<std::uint8_t> in, time_point deadline) noexcept {
        do {
            if (usart2.sr & sr_rxne) {
                in[0] = static_cast<std::uint8_t>(usart2.dr);
                return {1, {}};
            }
        } while (now() < deadline);
        return {0, ferrule::errc::timeout};
    }
    void discard_input() noexcept {
        while (usart2.sr & sr_rxne) (void)usart2.dr;
    }
};

} // namespace board

namespace {
board::uart_stream uart;
ferrule::movilink::master movilink_master;
ferrule::movilink::cyclic drive(movilink_master, 1);

// PLC-style outputs of this example, e.g. for a display task.
volatile std::uint16_t status_word = 0;
volatile std::uint16_t actual_speed = 0;
volatile std::uint32_t heat_sink_temperature = 0;
} // namespace

int main() {
    board::init();
    using namespace ferrule::movilink;
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
        }
        if (drive.parameter_done() && !drive.parameter_error())
            heat_sink_temperature = drive.parameter_value();
        if (movilink_master.fault_latched()) {
            drive.set_po(0, 0x0000); // rapid stop once the link is back
            movilink_master.reset_fault();
        }
    }
}
