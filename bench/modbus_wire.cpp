// Whole runs on the wire, in virtual time: a Modbus RTU client polls eight simulated VFDs
// (modbus::sim::bus, units 1…8) on one 8E1 line, at 9600 and at 115200 baud. Each
// transaction reads the four parameter registers 0xC900…0xC903 (FC 3) of one drive; a cycle
// is one read of each of the eight.
//
// Every drive starts its reply t3.5 + 1 ms (its simulated processing time) after the
// request's last character (Serial Line V1.02 §2.5.1.1), and the client keeps t3.5 of
// silence before each request. The least a cycle can take is therefore
//     8 × (t3.5 + request + t3.5 + 1 ms + response)
// with an 8-byte request and a 13-byte response. The benchmark reports the cycle the client
// reaches (counter bus_ms_per_cycle) beside that sum (spec_ms_per_cycle), in virtual
// milliseconds on the line: exact and the same on every machine. Every run checks that each
// read returned the drive's defaults; a run that does not is reported as an error.
#include <benchmark/benchmark.h>

#include <array>
#include <chrono>
#include <cstdint>

#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/client.hpp"
#include "ferrule/modbus/sim/bus.hpp"

namespace {

using namespace ferrule;
using namespace std::chrono_literals;
namespace mb = ferrule::modbus;

constexpr int cycles = 100;
constexpr std::uint8_t drives = 8;
constexpr duration processing = 1ms;
constexpr std::size_t request_bytes = 8;   // unit, FC, address, quantity, CRC
constexpr std::size_t response_bytes = 13; // unit, FC, byte count, 4 registers, CRC

double ms(duration d) {
    return std::chrono::duration<double, std::milli>(d).count();
}

void poll(benchmark::State& state, std::uint32_t baud) {
    const serial_format f{baud, 8, parity::even, 1};
    const duration spec = drives * (mb::t35(f) + f.chars_time(request_bytes) + mb::t35(f) +
                                    processing + f.chars_time(response_bytes));
    duration bus_time{};
    int good = 0;
    for (auto _ : state) {
        mb::sim::bus<drives> bus;
        for (std::uint8_t u = 1; u <= drives; ++u) {
            mb::server_config cfg;
            cfg.units = {u};
            cfg.format = f;
            cfg.processing_time = processing;
            bus.add(cfg);
        }
        mock_serial line(f, &bus);
        mb::client_config cfg;
        cfg.format = f;
        cfg.inter_frame_gap = mb::t35(f);
        mb::client c(cfg);
        std::array<std::uint16_t, 4> regs{};
        good = 0;
        const time_point start = line.now();
        for (int i = 0; i < cycles; ++i)
            for (std::uint8_t u = 1; u <= drives; ++u) {
                regs = {};
                if (!mb::read_holding_registers(line, c, u, mb::sim::vfd_register::max_frequency,
                                                regs) &&
                    regs == std::array<std::uint16_t, 4>{5000, 50, 50, 0})
                    ++good;
            }
        // The first request went out at once; every later one after t3.5 of silence: the
        // gap owed before a next cycle completes the last.
        bus_time = line.now() + mb::t35(f) - start;
    }
    if (good != cycles * drives) state.SkipWithError("a read did not return the drive's values");
    state.counters["bus_ms_per_cycle"] = ms(bus_time) / cycles;
    state.counters["spec_ms_per_cycle"] = ms(spec);
    state.counters["reads_per_bus_s"] =
        cycles * drives / std::chrono::duration<double>(bus_time).count();
}

void rtu_9600(benchmark::State& state) {
    poll(state, 9600);
}
void rtu_115200(benchmark::State& state) {
    poll(state, 115200);
}

} // namespace

BENCHMARK(rtu_9600)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(rtu_115200)->Iterations(1)->Unit(benchmark::kMillisecond);
