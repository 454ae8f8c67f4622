// Google Benchmark: the two forms of the Modbus RTU CRC over a whole ADU (256 bytes), to
// show what a size-optimised build (-Os: bit by bit, no 512-byte table) pays per frame.
// Both are checked against each other once before timing.
#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>

#include "ferrule/core/checksum.hpp"

namespace {

std::array<std::uint8_t, 256> adu() {
    std::array<std::uint8_t, 256> a{};
    for (std::size_t i = 0; i < a.size(); ++i) a[i] = static_cast<std::uint8_t>(i * 37 + 11);
    return a;
}

template <std::uint16_t (*Crc)(std::span<const std::uint8_t>, std::uint16_t)>
void crc16(benchmark::State& state) {
    const auto a = adu();
    if (Crc(a, 0xFFFF) != ferrule::detail::crc16_modbus_table_driven(a, 0xFFFF))
        state.SkipWithError("the two CRC forms disagree");
    for (auto _ : state) {
        std::uint16_t c = Crc(a, 0xFFFF);
        benchmark::DoNotOptimize(c);
    }
    state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * a.size()));
}
BENCHMARK(crc16<ferrule::detail::crc16_modbus_table_driven>)->Name("crc16_modbus/table/256");
BENCHMARK(crc16<ferrule::detail::crc16_modbus_bitwise>)->Name("crc16_modbus/bitwise/256");

} // namespace
