// Google Benchmark: Dimetix request builder, line decoder, answer parser and sensor session,
// in memory. Lines are golden vectors of protocols/dimetix.md §8:
//   s0g                        single distance request
//   s0uof-00000123             user offset -12.3 mm (the sign is the separator)
//   g0g+00001234               distance, user output format 0
//   g0g+00000234+008384+254    distance, signal, temperature (format 300)
// Every case checks its result once before timing, so a broken codec cannot produce a fast,
// meaningless number.
#include <benchmark/benchmark.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <span>
#include <string_view>

#include "ferrule/dimetix/command.hpp"
#include "ferrule/dimetix/reply.hpp"
#include "ferrule/dimetix/sensor.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::dimetix;
using namespace std::chrono_literals;

std::span<const std::uint8_t> bytes(std::string_view s) {
    return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

void BM_encode_distance(benchmark::State& state) {
    const command c = distance(0);
    std::array<std::uint8_t, max_request_length> buf{};
    if (auto n = encode(c, buf); !n || std::memcmp(buf.data(), "s0g\r\n", 5) != 0)
        state.SkipWithError("encode(s0g) wrong");
    for (auto _ : state) {
        auto n = encode(c, buf);
        benchmark::DoNotOptimize(n);
        benchmark::DoNotOptimize(buf.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_encode_distance);

void BM_encode_negative_offset(benchmark::State& state) {
    command c = *set(0, "uof", std::array<std::int32_t, 1>{-123});
    c.digits = 8;
    std::array<std::uint8_t, max_request_length> buf{};
    if (auto n = encode(c, buf);
        !n || std::string_view(reinterpret_cast<char*>(buf.data()), *n) != "s0uof-00000123\r\n")
        state.SkipWithError("encode(s0uof-00000123) wrong");
    for (auto _ : state) {
        auto n = encode(c, buf);
        benchmark::DoNotOptimize(n);
        benchmark::DoNotOptimize(buf.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_encode_negative_offset);

void parse_case(benchmark::State& state, std::string_view line, std::int32_t distance, int fields) {
    const auto in = bytes(line);
    const auto first = parse_reply(in);
    if (!first || !measurement_of(*first) || measurement_of(*first)->distance != distance ||
        measurement_of(*first)->fields != fields)
        state.SkipWithError("parse_reply gave the wrong answer");
    for (auto _ : state) {
        benchmark::DoNotOptimize(in.data());
        auto r = parse_reply(in);
        benchmark::DoNotOptimize(r);
    }
    state.SetItemsProcessed(state.iterations());
    state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(line.size()));
}
void BM_parse_distance(benchmark::State& s) {
    parse_case(s, "g0g+00001234", 1234, 1);
}
void BM_parse_format_300(benchmark::State& s) {
    parse_case(s, "g0g+00000234+008384+254", 234, 3);
}
BENCHMARK(BM_parse_distance);
BENCHMARK(BM_parse_format_300);

void BM_line_decoder_bytewise(benchmark::State& state) {
    const auto in = bytes("g0g+00000234+008384+254\r\n");
    line_decoder d;
    for (auto _ : state) {
        bool got = false;
        for (std::size_t i = 0; i < in.size(); ++i)
            got = d.feed(in.subspan(i, 1)).what == line_decoder::status::line;
        if (!got) {
            state.SkipWithError("no line");
            break;
        }
        benchmark::DoNotOptimize(d.line().data());
    }
    state.SetItemsProcessed(state.iterations());
    state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(in.size()));
}
BENCHMARK(BM_line_decoder_bytewise);

// One measurement in memory: start(s0g) -> next (send) -> on_receive (answer) -> next (done).
void BM_sensor_measurement(benchmark::State& state) {
    sensor s;
    const auto answer = bytes("g0g+00001234\r\n");
    const command c = distance(0);
    time_point now = time_point{} + 1s;
    for (auto _ : state) {
        now += 10ms;
        if (s.start(c)) {
            state.SkipWithError("start failed");
            break;
        }
        const auto send = s.next(now);
        if (send.what != session_action::kind::send) {
            state.SkipWithError("sensor did not send");
            break;
        }
        benchmark::DoNotOptimize(send.bytes.data());
        s.on_receive(answer, now + 1ms);
        const auto done = s.next(now + 1ms);
        if (done.what != session_action::kind::done || s.error() || s.reply().values[0] != 1234) {
            state.SkipWithError("measurement did not succeed");
            break;
        }
        s.clear();
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_sensor_measurement);

} // namespace
