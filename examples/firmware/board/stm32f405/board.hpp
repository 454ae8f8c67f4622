// The board part of the firmware examples: an STM32F405 at 168 MHz (QEMU's netduinoplus2
// emulates it). A port to another MCU provides this folder — this header, its start-up code
// and a linker script — and nothing else; ferrule itself knows no board (docs/firmware.md).
//
// USART1 and USART2 carry the protocols (RS-485 transceivers), USART3 is the console the
// examples report on (115200 8N1), SysTick is the clock. uart_stream is the ferrule
// byte_stream over a USART: polling, no interrupt. Its members stay out of line so the size of
// ferrule's code can be measured apart from the board's (tools/firmware-size.sh … '^board::').
#pragma once

#include <chrono>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/serial_format.hpp"

namespace board {

// The clocks start-up sets (startup.cpp): SYSCLK 168 MHz, APB1 42 MHz, APB2 84 MHz.
constexpr std::uint32_t core_hz = 168'000'000;
constexpr std::uint32_t apb1_hz = core_hz / 4;
constexpr std::uint32_t apb2_hz = core_hz / 2;

// Whether the PLL reported lock at start-up: false in QEMU, which models no clock tree and
// runs the core at 168 MHz anyway.
extern bool clock_locked;

// Milliseconds since reset, advanced by SysTick_Handler.
inline volatile std::uint32_t ticks_ms = 0;

// Start-up fills the free stack with this word; stack_high_water() returns how many bytes at
// the top of RAM no longer hold it, i.e. the deepest the stack has been so far.
constexpr std::uint32_t stack_paint = 0xC0FFEE55u;
std::uint32_t stack_high_water();

struct usart_regs {
    volatile std::uint32_t sr, dr, brr, cr1, cr2, cr3, gtpr;
};
// Register blocks (RM0090 §2.3): USART1 on APB2, USART2 and USART3 on APB1.
constexpr std::uintptr_t usart1_base = 0x40011000u;
constexpr std::uintptr_t usart2_base = 0x40004400u;
constexpr std::uintptr_t usart3_base = 0x40004800u;
template <std::uintptr_t Base>
usart_regs& usart() {
    return *reinterpret_cast<usart_regs*>(Base);
}
constexpr std::uint32_t sr_rxne = 1u << 5;
constexpr std::uint32_t sr_txe = 1u << 7;
constexpr std::uint32_t sr_tc = 1u << 6;

// The USART in the protocol's character format (RM0090 §30.6.4). The frame holds data bits +
// parity bit: 9 bits need M = 1 (8E1), 8 bits M = 0 (7E1, 8N1). PCE enables parity, PS = 1
// makes it odd. BRR = f_PCLK / baud with OVER8 = 0 (§30.3.4, mantissa and fraction together).
template <std::uintptr_t Base = usart2_base>
void init(const ferrule::serial_format& f) {
    constexpr std::uint32_t pclk = Base == usart1_base ? apb2_hz : apb1_hz;
    const bool parity = f.parity != ferrule::parity::none;
    usart<Base>().brr = (pclk + f.baud / 2) / f.baud;
    usart<Base>().cr1 = (1u << 13) /* UE */ | (f.data_bits + parity == 9 ? 1u << 12 : 0u) |
                        (parity ? 1u << 10 : 0u) |
                        (f.parity == ferrule::parity::odd ? 1u << 9 : 0u) | (1u << 3) /* TE */ |
                        (1u << 2) /* RE */;
}

// SysTick counts down from core_hz / 1000 - 1 each millisecond (PM0214 §4.5). The firmware
// builds with FERRULE_TICK_32: time is a 32-bit microsecond count that wraps after 71.6
// minutes, which the sessions' wrap-safe comparisons allow (docs/firmware.md).
[[gnu::noinline]] inline ferrule::time_point now() noexcept {
    constexpr std::uint32_t per_us = core_hz / 1'000'000;
    std::uint32_t ms, val;
    do {
        ms = ticks_ms;
        val = *reinterpret_cast<volatile std::uint32_t*>(0xE000E018u); // SYST_CVR
    } while (ms != ticks_ms); // a tick between the two reads: read again
    const std::uint32_t us = (core_hz / 1000 - 1 - val) / per_us;
    return ferrule::time_point{std::chrono::duration<std::uint32_t, std::micro>(ms * 1000u + us)};
}

template <std::uintptr_t Base = usart2_base>
class uart_stream {
public:
    using time_point = ferrule::time_point;

    // With parity the parity bit arrives above the data bits in DR: the mask takes it off.
    constexpr explicit uart_stream(const ferrule::serial_format& f) noexcept
        : data_mask_(static_cast<std::uint8_t>((1u << f.data_bits) - 1u)) {}

    [[gnu::noinline]] time_point now() const noexcept { return board::now(); }
    [[gnu::noinline]] ferrule::io_result write(std::span<const std::uint8_t> out) noexcept {
        for (auto b : out) {
            while (!(regs().sr & sr_txe)) {
            }
            regs().dr = b;
        }
        while (!(regs().sr & sr_tc)) {
        } // RS-485: release the bus only after the last bit
        return {out.size(), {}};
    }
    // Never waits: the bytes the transmitter takes now (one, while a character is on the wire).
    [[gnu::noinline]] std::size_t write_some(std::span<const std::uint8_t> out) noexcept {
        std::size_t n = 0;
        while (n < out.size() && (regs().sr & sr_txe)) regs().dr = out[n++];
        return n;
    }
    // Non-blocking when deadline <= now (the poll driver's case).
    [[gnu::noinline]] ferrule::io_result read_some(std::span<std::uint8_t> in,
                                                   time_point deadline) noexcept {
        do {
            if (regs().sr & sr_rxne) {
                in[0] = static_cast<std::uint8_t>(regs().dr & data_mask_);
                return {1, {}};
            }
        } while (ferrule::before(now(), deadline));
        return {0, ferrule::errc::timeout};
    }
    [[gnu::noinline]] void discard_input() noexcept {
        while (regs().sr & sr_rxne) (void)regs().dr;
    }

private:
    static usart_regs& regs() noexcept { return usart<Base>(); }

    std::uint8_t data_mask_;
};

// The console on USART3, for what an example reports: text and decimal numbers, no printf.
void console_init();
void print(const char* text);
void print_int(std::int32_t value);
void print_uint(std::uint32_t value);
void print_hex(std::uint32_t value); // 0x and eight digits
// One report line: report("speed=", v, " status=", s) prints the pieces and a newline.
template <class... Parts>
void report(const Parts&... parts) {
    auto one = [](const auto& p) {
        using part = std::decay_t<decltype(p)>;
        if constexpr (std::signed_integral<part>)
            print_int(static_cast<std::int32_t>(p));
        else if constexpr (std::unsigned_integral<part>)
            print_uint(static_cast<std::uint32_t>(p));
        else
            print(p);
    };
    (one(parts), ...);
    print("\n");
}

} // namespace board
