// The board part of the firmware examples: an STM32F4 at 16 MHz, USART2 (and USART1 where
// an example needs two lines) on an RS-485 transceiver, SysTick as the clock (RM0090 §30.6,
// PM0214 §4.5). uart_stream is the ferrule byte_stream over a USART, polling, no interrupts
// needed. Its members are kept out of line so that the size of ferrule's code can be
// measured apart from the board's (tools/firmware-size.sh … '^board::').
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/core/serial_format.hpp"

namespace board {

struct usart_regs {
    volatile std::uint32_t sr, dr, brr, cr1, cr2, cr3, gtpr;
};
// Register blocks (RM0090 §2.3). At 16 MHz without bus prescalers APB1 (USART2) and APB2
// (USART1) both run at core_hz.
constexpr std::uintptr_t usart1_base = 0x40011000u;
constexpr std::uintptr_t usart2_base = 0x40004400u;
template <std::uintptr_t Base>
usart_regs& usart() {
    return *reinterpret_cast<usart_regs*>(Base);
}
constexpr std::uint32_t sr_rxne = 1u << 5;
constexpr std::uint32_t sr_txe = 1u << 7;
constexpr std::uint32_t sr_tc = 1u << 6;
inline volatile std::uint32_t& systick_val =
    *reinterpret_cast<volatile std::uint32_t*>(0xE000E018u);

inline volatile std::uint32_t ticks_us = 0; // advanced by the SysTick handler
constexpr std::uint32_t core_hz = 16'000'000;

// Defined here, not inline, so the vector table finds it: each example includes this header
// from its one translation unit.
extern "C" void SysTick_Handler() {
    ticks_us = ticks_us + 1000;
}

// A USART (USART2 unless told) in the protocol's character format. The frame holds data bits
// + parity bit: 9 bits need M = 1 (8E1), 8 bits M = 0 (7E1, 8N1). PCE enables parity, PS = 1
// makes it odd.
template <std::uintptr_t Base = usart2_base>
void init(const ferrule::serial_format& f) {
    const bool parity = f.parity != ferrule::parity::none;
    usart<Base>().brr = core_hz / f.baud;
    usart<Base>().cr1 = (1u << 13) /* UE */ | (f.data_bits + parity == 9 ? 1u << 12 : 0u) |
                        (parity ? 1u << 10 : 0u) |
                        (f.parity == ferrule::parity::odd ? 1u << 9 : 0u) | (1u << 3) /* TE */ |
                        (1u << 2) /* RE */;
}

template <std::uintptr_t Base = usart2_base>
class uart_stream {
public:
    using time_point = ferrule::time_point;

    // With parity the parity bit arrives above the data bits in DR: the mask takes it off.
    constexpr explicit uart_stream(const ferrule::serial_format& f) noexcept
        : data_mask_(static_cast<std::uint8_t>((1u << f.data_bits) - 1u)) {}

    [[gnu::noinline]] time_point now() const noexcept {
        // SysTick counts down from (core_hz / 1000 - 1) each millisecond.
        const std::uint32_t sub = (core_hz / 1000 - 1 - systick_val) / (core_hz / 1'000'000);
        return time_point{std::chrono::duration<std::uint32_t, std::micro>(ticks_us + sub)};
    }
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

} // namespace board
