// Instructions per transaction of each protocol's master, counted in QEMU with
// `-icount shift=0` (bench/firmware/instructions.sh): one guest instruction is one virtual
// nanosecond, and SysTick counts virtual time, so the board's clock read before and after a
// piece of code gives the instructions it executed.
//
// Master and simulated device share this image: they talk over a mock_serial line in virtual
// time (include/ferrule/sim/), so no UART, no wire time and no waiting enter the count. The
// master's stream is `metered`, which also counts what runs inside each stream call — the
// mock_serial line and, within write(), the simulated device — so the table gives the whole
// transaction, the line and device, and the master's share (master session, driver and the
// blocking access function: the whole transaction less the line and device).
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <new>
#include <span>

#include "ferrule/dimetix/access.hpp"
#include "ferrule/dimetix/sim/bus.hpp"
#include "ferrule/lecom/access.hpp"
#include "ferrule/lecom/sim/bus.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/sim/bus.hpp"
#include "ferrule/movilink/access.hpp"
#include "ferrule/movilink/sim/bus.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/sim/bus.hpp"
#include "ferrule/sim/mock_serial.hpp"

#include "board.hpp"

namespace {
constexpr int transactions = 200;

// Virtual nanoseconds since reset = instructions under -icount shift=0. SysTick counts the
// 168 MHz core clock down from core_hz / 1000 - 1 each millisecond (PM0214 §4.5).
[[gnu::noinline]] std::uint64_t clock_ns() {
    std::uint32_t ms, val;
    do {
        ms = board::ticks_ms;
        val = *reinterpret_cast<volatile std::uint32_t*>(0xE000E018u); // SYST_CVR
    } while (ms != board::ticks_ms);
    constexpr std::uint32_t per_ms = board::core_hz / 1000;
    return std::uint64_t{ms} * 1'000'000u + std::uint64_t{per_ms - 1 - val} * 1'000'000u / per_ms;
}

// The master's byte_stream: mock_serial, with the time spent inside it counted.
class metered {
public:
    using time_point = ferrule::time_point;
    explicit metered(ferrule::mock_serial& line) : line_(line) {}

    time_point now() const {
        const std::uint64_t t0 = clock_ns();
        const time_point t = line_.now();
        leave(t0);
        return t;
    }
    ferrule::io_result write(std::span<const std::uint8_t> out) {
        const std::uint64_t t0 = clock_ns();
        const ferrule::io_result r = line_.write(out);
        leave(t0);
        return r;
    }
    ferrule::io_result read_some(std::span<std::uint8_t> in, time_point deadline) {
        const std::uint64_t t0 = clock_ns();
        const ferrule::io_result r = line_.read_some(in, deadline);
        leave(t0);
        return r;
    }
    void discard_input() {
        const std::uint64_t t0 = clock_ns();
        line_.discard_input();
        leave(t0);
    }

    mutable std::uint64_t inside = 0;
    mutable std::uint32_t calls = 0;

private:
    void leave(std::uint64_t t0) const {
        inside += clock_ns() - t0;
        ++calls;
    }
    ferrule::mock_serial& line_;
};

// What metering adds to `inside` per call: a metered now() less a bare one, over many calls.
// (`inside` holds the end of the first clock read and the start of the second.)
std::uint32_t inside_overhead = 0;

void calibrate(ferrule::mock_serial& line) {
    constexpr int calls = 1000;
    metered s(line);
    const std::uint64_t t0 = clock_ns();
    for (int i = 0; i < calls; ++i) (void)line.now();
    const std::uint64_t bare = clock_ns() - t0;
    for (int i = 0; i < calls; ++i) (void)s.now();
    inside_overhead = static_cast<std::uint32_t>((s.inside - bare) / calls);
}

// Runs `transaction(stream)` (true on success) `transactions` times on the bare line, then
// as many times on the metered line, and reports per transaction: all instructions (bare
// line), those inside the stream calls (line + device: the metered run's count less the
// metering's calibrated overhead per call), and the master's share, the difference.
template <class Transaction>
void measure(const char* name, ferrule::mock_serial& line, Transaction transaction) {
    int good = 0;
    const std::uint64_t t0 = clock_ns();
    for (int i = 0; i < transactions; ++i) good += transaction(line) ? 1 : 0;
    const std::uint64_t total = clock_ns() - t0;
    metered s(line);
    for (int i = 0; i < transactions; ++i) good += transaction(s) ? 1 : 0;
    const std::uint64_t inside = s.inside - std::uint64_t{s.calls} * inside_overhead;
    board::report(
        "insn ", name, " ok=", good, "/", 2 * transactions,
        " total=", static_cast<std::uint32_t>(total / transactions),
        " line_and_device=", static_cast<std::uint32_t>(inside / transactions), " master=",
        static_cast<std::int32_t>((std::int64_t(total) - std::int64_t(inside)) / transactions),
        " stream_calls=", s.calls / transactions);
}

// The check of the method: 100 000 nops in blocks of 1000 (plus the loop's 3 instructions
// per block).
[[gnu::noinline]] void nops() {
    for (int i = 0; i < 100; ++i) asm volatile(".rept 1000\n nop\n .endr" ::: "memory");
}

namespace mv = ferrule::movilink;
namespace dx = ferrule::dimetix;
namespace lc = ferrule::lecom;
namespace mb = ferrule::modbus;
namespace pb = ferrule::profibus;

// One rig at a time: a mock_serial keeps a log of 4096 wire bytes (about 100 KB), so the
// protocols' rigs take turns in one static block.
struct movilink_rig {
    mv::sim::bus<1> bus;
    ferrule::mock_serial line{mv::default_format, &bus};
    mv::master m;
};
struct dimetix_rig {
    dx::sim::bus<1> bus;
    ferrule::mock_serial line{dx::default_format, &bus};
    dx::sensor sensor;
};
struct lecom_rig {
    lc::sim::bus<1> bus;
    ferrule::mock_serial line{lc::default_format, &bus};
    lc::master m;
};
using modbus_client =
    mb::basic_client<mb::link_mode::rtu, mb::functions<mb::function::read_holding_registers>>;
struct modbus_rig {
    mb::sim::bus<1> bus;
    ferrule::mock_serial line{mb::default_format, &bus};
    modbus_client c{[] {
        mb::client_config cfg;
        cfg.inter_frame_gap = mb::t35(cfg.format);
        return cfg;
    }()};
};
struct profibus_rig {
    pb::sim::bus<1> bus;
    ferrule::mock_serial line{pb::format(19200), &bus};
    pb::master m;
};

constexpr std::size_t rig_size =
    std::max({sizeof(movilink_rig), sizeof(dimetix_rig), sizeof(lecom_rig), sizeof(modbus_rig),
              sizeof(profibus_rig)});
alignas(8) std::byte rig_storage[rig_size];

// Builds a Rig in the shared block, runs `body` on it, takes it down.
template <class Rig, class Body>
void with_rig(Body body) {
    Rig* r = new (rig_storage) Rig;
    body(*r);
    r->~Rig();
}

void movilink() {
    with_rig<movilink_rig>([](movilink_rig& r) {
        r.bus.add();
        calibrate(r.line);
        board::report("insn metering_overhead_per_call=", inside_overhead);
        constexpr std::array<std::uint16_t, 3> po{0x0006, 7500, 1000};
        measure("movilink_3pd_cycle", r.line,
                [&](auto& s) { return bool(mv::exchange(s, r.m, 1, po)); });
        measure("movilink_parameter_read", r.line,
                [&](auto& s) { return bool(mv::read_parameter(s, r.m, 1, 8318)); }); // P014
    });
}

void dimetix() {
    with_rig<dimetix_rig>([](dimetix_rig& r) {
        r.bus.add();
        measure("dimetix_distance", r.line,
                [&](auto& s) { return bool(dx::measure(s, r.sensor, 0)); });
    });
}

void lecom() {
    with_rig<lecom_rig>([](lecom_rig& r) {
        r.bus.add();
        measure("lecom_read", r.line,
                [&](auto& s) { return bool(lc::read(s, r.m, 1, lc::code(50))); });
    });
}

void modbus() {
    with_rig<modbus_rig>([](modbus_rig& r) {
        r.bus.add(mb::server_config{});
        std::array<std::uint16_t, 4> regs{};
        measure("modbus_rtu_fc3_4_registers", r.line, [&](auto& s) {
            return !mb::read_holding_registers(s, r.c, 1, mb::sim::vfd_register::max_frequency,
                                               regs);
        });
    });
}

void profibus() {
    with_rig<profibus_rig>([](profibus_rig& r) {
        static constexpr std::array<std::uint8_t, 2> cfg{0x11, 0x21}; // 2 bytes in, 2 out
        pb::slave_config sc;
        sc.address = 8;
        sc.ident = 0x0815;
        sc.cfg = cfg;
        r.bus.add(sc);
        pb::prm_data p;
        p.station_status = pb::prm::lock_req;
        p.min_tsdr = 11;
        p.ident = 0x0815;
        if (pb::bring_up(r.line, r.m, 8, p, cfg)) board::report("profibus: bring-up failed");
        constexpr std::array<std::uint8_t, 2> out{0x12, 0x34};
        std::array<std::uint8_t, 2> in{};
        measure("profibus_data_exchange", r.line,
                [&](auto& s) { return !pb::data_exchange(s, r.m, 8, out, in); });
    });
}
} // namespace

int main() {
    const std::uint64_t t0 = clock_ns();
    nops();
    board::report("insn nops_100000 measured=", static_cast<std::uint32_t>(clock_ns() - t0));
    movilink();
    dimetix();
    lecom();
    modbus();
    profibus();
    board::report("insn done stack=", board::stack_high_water());
    // Ends QEMU: semihosting SYS_EXIT (0x18) with ADP_Stopped_ApplicationExit (0x20026)
    // (Arm semihosting v2, §5.5.4); instructions.sh runs QEMU with semihosting on.
    register std::uint32_t op asm("r0") = 0x18;
    register std::uint32_t reason asm("r1") = 0x20026;
    asm volatile("bkpt 0xab" : : "r"(op), "r"(reason) : "memory");
    for (;;) {
    }
}
