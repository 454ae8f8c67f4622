// Start-up of the STM32F405 board: the vector table, the reset handler (.data copy, .bss
// zero, stack paint, static constructors, clock tree), SysTick as the time base, and the
// USART set-up. Neither newlib's crt0 nor its libnosys system calls are linked.
#include <cstdint>

#include "board.hpp"

extern "C" {
// From stm32f405.ld.
extern std::uint32_t _sidata[], _sdata[], _edata[], _sbss[], _ebss[], _estack[];
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();

int main();
[[noreturn]] void Reset_Handler();
[[noreturn]] void Default_Handler();
void SysTick_Handler();
}

namespace board {
namespace {

struct rcc_regs {
    volatile std::uint32_t cr, pllcfgr, cfgr, cir, ahb1rstr, ahb2rstr, ahb3rstr, reserved0,
        apb1rstr, apb2rstr, reserved1[2], ahb1enr, ahb2enr, ahb3enr, reserved2, apb1enr, apb2enr;
};
struct gpio_regs {
    volatile std::uint32_t moder, otyper, ospeedr, pupdr, idr, odr, bsrr, lckr, afr[2];
};
struct systick_regs {
    volatile std::uint32_t ctrl, load, val, calib;
};

// RM0090 §2.3 (memory map) and PM0214 §4.5 (SysTick).
rcc_regs& rcc() {
    return *reinterpret_cast<rcc_regs*>(0x40023800u);
}
volatile std::uint32_t& flash_acr() {
    return *reinterpret_cast<volatile std::uint32_t*>(0x40023C00u);
}
gpio_regs& gpio(unsigned port) {
    return *reinterpret_cast<gpio_regs*>(0x40020000u + 0x400u * port);
}
systick_regs& systick() {
    return *reinterpret_cast<systick_regs*>(0xE000E010u);
}

// How long start-up waits for a clock-ready bit. The PLL locks within about 100 us
// (DS8626 Table 34, t_LOCK); QEMU models no RCC (its registers read 0), so the wait must end.
constexpr std::uint32_t ready_polls = 100'000;

bool wait_set(volatile std::uint32_t& reg, std::uint32_t mask, std::uint32_t value) {
    for (std::uint32_t i = 0; i < ready_polls; ++i)
        if ((reg & mask) == value) return true;
    return false;
}

// 168 MHz from the internal 16 MHz HSI, so no crystal is assumed (RM0090 §6.3.2):
// f_VCO = 16 MHz / M(16) * N(336) = 336 MHz, SYSCLK = f_VCO / P(2), USB/SDIO = / Q(7) = 48 MHz.
// AHB /1, APB1 /4 = 42 MHz (max 42), APB2 /2 = 84 MHz (max 84). Flash: 5 wait states at
// 168 MHz and 2.7-3.6 V, prefetch and both caches on (RM0090 §3.5.1 Table 10, §3.9.1).
bool start_clock_tree() {
    flash_acr() = 5u | (1u << 8) | (1u << 9) | (1u << 10);       // LATENCY, PRFTEN, ICEN, DCEN
    rcc().pllcfgr = 16u | (336u << 6) | (0u << 16) | (7u << 24); // PLLSRC = HSI (bit 22 = 0)
    rcc().cr |= 1u << 24;                                        // PLLON
    const bool locked = wait_set(rcc().cr, 1u << 25, 1u << 25);  // PLLRDY
    rcc().cfgr = (5u << 10) | (4u << 13) | 2u;                   // PPRE1 /4, PPRE2 /2, SW = PLL
    return wait_set(rcc().cfgr, 3u << 2, 2u << 2) && locked;     // SWS = PLL
}

// USART1 on PA9/PA10, USART2 on PA2/PA3, USART3 (console) on PB10/PB11, all alternate
// function 7 (DS8626 Table 9). RS-485 transceivers with automatic direction control are
// assumed; a board with a driver-enable pin drives it around write() (docs/firmware.md).
// The masks are constants: one read-modify-write per register, no loop over the pins.
struct pin_masks {
    std::uint32_t moder_clear = 0, moder_set = 0;
    std::uint32_t afr_clear[2] = {}, afr_set[2] = {};
};
template <unsigned... Pins>
constexpr pin_masks alternate_function_7() {
    pin_masks m;
    for (unsigned pin : {Pins...}) {
        m.moder_clear |= 3u << (2 * pin);
        m.moder_set |= 2u << (2 * pin); // MODER = 10: alternate function
        m.afr_clear[pin / 8] |= 0xFu << (4 * (pin % 8));
        m.afr_set[pin / 8] |= 7u << (4 * (pin % 8));
    }
    return m;
}

template <unsigned Port, pin_masks M>
void set_alternate_functions() {
    auto& g = gpio(Port);
    g.moder = (g.moder & ~M.moder_clear) | M.moder_set;
    for (unsigned i = 0; i < 2; ++i)
        if (M.afr_clear[i]) g.afr[i] = (g.afr[i] & ~M.afr_clear[i]) | M.afr_set[i];
}

void start_peripherals() {
    rcc().ahb1enr |= (1u << 0) | (1u << 1);   // GPIOA, GPIOB
    rcc().apb2enr |= 1u << 4;                 // USART1
    rcc().apb1enr |= (1u << 17) | (1u << 18); // USART2, USART3
    set_alternate_functions<0, alternate_function_7<2, 3, 9, 10>()>();
    set_alternate_functions<1, alternate_function_7<10, 11>()>();
}

// SysTick from the processor clock, one interrupt per millisecond (PM0214 §4.5.1).
void start_systick() {
    systick().load = core_hz / 1000 - 1;
    systick().val = 0;
    systick().ctrl = 7u; // CLKSOURCE = processor, TICKINT, ENABLE
}

} // namespace

bool clock_locked = false;

std::uint32_t stack_high_water() {
    const auto* p = _ebss;
    while (p < _estack && *p == stack_paint) ++p;
    return static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(_estack) -
                                      reinterpret_cast<std::uintptr_t>(p));
}

} // namespace board

extern "C" void SysTick_Handler() {
    board::ticks_ms = board::ticks_ms + 1;
}

extern "C" [[noreturn]] void Default_Handler() {
    for (;;) {
    }
}

// Everything below the reset handler's own frame is painted; 64 bytes keep clear of it.
// The copy and clear loops stay loops: as calls to newlib's memcpy they would link its 308
// bytes into images whose .data is a few bytes.
extern "C" [[noreturn, gnu::optimize("no-tree-loop-distribute-patterns")]] void Reset_Handler() {
    for (auto *s = _sidata, *d = _sdata; d < _edata;) *d++ = *s++;
    for (auto* d = _sbss; d < _ebss;) *d++ = 0;
    std::uint32_t* sp;
    asm volatile("mov %0, sp" : "=r"(sp));
    for (auto* d = _ebss; d < sp - 16;) *d++ = board::stack_paint;
    board::clock_locked = board::start_clock_tree();
    board::start_peripherals();
    board::start_systick();
    board::console_init();
    board::report("boot: STM32F405, 168 MHz, PLL ", board::clock_locked ? "locked" : "not seen");
    for (auto* f = __init_array_start; f < __init_array_end; ++f) (*f)();
    main();
    Default_Handler();
}

// The Cortex-M4 system exceptions (PM0214 §2.3.4 Table 17). The examples poll their USARTs
// and enable no peripheral interrupt, so the STM32F405's 82 interrupt vectors (RM0090 §12.2
// Table 61) are left out; a port that enables one extends this table to its position.
using handler = void (*)();
extern "C" [[gnu::section(".isr_vector"), gnu::used]] const handler vector_table[16] = {
    reinterpret_cast<handler>(_estack),
    Reset_Handler,
    Default_Handler, // NMI
    Default_Handler, // HardFault
    Default_Handler, // MemManage
    Default_Handler, // BusFault
    Default_Handler, // UsageFault
    nullptr,
    nullptr,
    nullptr,
    nullptr,
    Default_Handler, // SVCall
    Default_Handler, // DebugMonitor
    nullptr,
    Default_Handler, // PendSV
    SysTick_Handler,
};
