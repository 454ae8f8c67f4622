// Dimetix D-Series sensor on a Cortex-M4 (STM32F4 register layout, USART2 on an RS-485
// transceiver, 19200 7E1, the sensor's factory setting): a super-loop that connects the way
// the PLC program of the paper does (sNc until gN?), then measures the distance with sNg
// again and again, without blocking and without heap. An error answer gN@Ezzz is kept as
// its code; a lost link is recovered with sNc.
//
// The byte_stream below is the only board-specific part; ferrule brings the protocol.
#include <cstdint>
#include <span>

#include "ferrule/core/driver.hpp"
#include "ferrule/dimetix/sensor.hpp"

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
    // 19200 baud from 16 MHz; 7 data bits + even parity = 8-bit frame (M=0), parity enable
    // (PCE), even (PS=0), TE, RE, UE.
    usart2.brr = core_hz / 19200;
    usart2.cr1 = (1u << 13) | (1u << 10) | (1u << 3) | (1u << 2);
}

// A ferrule byte_stream over the UART, polling (no interrupts needed). Its members are kept
// out of line so that the size of ferrule's code can be measured apart from the board's.
class uart_stream {
public:
    using time_point = ferrule::time_point;

    [[gnu::noinline]] time_point now() const noexcept {
        // SysTick counts down from (core_hz / 1000 - 1) each millisecond.
        const std::uint32_t sub = (core_hz / 1000 - 1 - systick_val) / (core_hz / 1'000'000);
        return time_point{std::chrono::microseconds(ticks_us + sub)};
    }
    [[gnu::noinline]] ferrule::io_result write(std::span<const std::uint8_t> out) noexcept {
        for (auto b : out) {
            while (!(usart2.sr & sr_txe)) {
            }
            usart2.dr = b;
        }
        while (!(usart2.sr & sr_tc)) {
        } // RS-485: release the bus only after the last bit
        return {out.size(), {}};
    }
    // Non-blocking when deadline <= now (the poll driver's case). The parity bit arrives as
    // bit 7 of DR with 7E1: mask it off.
    [[gnu::noinline]] ferrule::io_result read_some(std::span<std::uint8_t> in,
                                                   time_point deadline) noexcept {
        do {
            if (usart2.sr & sr_rxne) {
                in[0] = static_cast<std::uint8_t>(usart2.dr & 0x7Fu);
                return {1, {}};
            }
        } while (now() < deadline);
        return {0, ferrule::errc::timeout};
    }
    [[gnu::noinline]] void discard_input() noexcept {
        while (usart2.sr & sr_rxne) (void)usart2.dr;
    }
};

} // namespace board

namespace {
constexpr std::uint8_t sensor_id = 1; // sNid of the sensor on the line

board::uart_stream uart;
ferrule::dimetix::sensor dimetix_sensor;

// PLC-style outputs of this example, e.g. for a display task (names as in the paper).
volatile bool connected = false;
volatile std::int32_t value = 0;      // distance in 0.1 mm
volatile std::int32_t error_code = 0; // zzz of the last gN@Ezzz
} // namespace

int main() {
    board::init();
    using namespace ferrule::dimetix;
    ferrule::poll_driver driver(uart, dimetix_sensor);
    (void)dimetix_sensor.start_connect(sensor_id);
    for (;;) {
        if (driver.step() != ferrule::session_action::kind::done) continue;
        const std::error_code ec = dimetix_sensor.error();
        const bool was_connect = !connected;
        dimetix_sensor.clear();
        if (!ec) {
            connected = true;
            if (!was_connect) value = dimetix_sensor.last_reply().values[0];
        } else if (ec.category() == device_category()) {
            error_code = ec.value(); // the sensor answered: the link is fine
        } else {
            connected = false; // timeouts: back to the start-up, sNc until gN?
        }
        static constexpr command measure = distance(sensor_id);
        if (connected)
            (void)dimetix_sensor.start(measure);
        else
            (void)dimetix_sensor.start_connect(sensor_id);
    }
}
