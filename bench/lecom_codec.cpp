// Google Benchmark: LECOM telegram encoder, reply parser, stream decoder and master session,
// in memory. Telegrams are test vectors of protocols/lecom.md §4:
//   04 30 31 34 36 05                      read C46 @01
//   04 33 34 02 31 31 39 35 2E 32 03 13    write C11 = 95.2 @34
//   02 34 36 33 35 2E 34 03 1D             reply C46 = 35.4
//   02 36 38 48 30 39 30 30 03 4C          reply C68 = H0900
// Every case checks its result once before timing, so a broken codec cannot produce a fast,
// meaningless number.
#include <benchmark/benchmark.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "ferrule/lecom/frame.hpp"
#include "ferrule/lecom/master.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::lecom;
using namespace std::chrono_literals;

const std::array<std::uint8_t, 6> read46{0x04, 0x30, 0x31, 0x34, 0x36, 0x05};
const std::array<std::uint8_t, 12> write11{0x04, 0x33, 0x34, 0x02, 0x31, 0x31,
                                           0x39, 0x35, 0x2E, 0x32, 0x03, 0x13};
const std::array<std::uint8_t, 9> reply46{0x02, 0x34, 0x36, 0x33, 0x35, 0x2E, 0x34, 0x03, 0x1D};
const std::array<std::uint8_t, 10> reply68{0x02, 0x36, 0x38, 0x48, 0x30,
                                           0x39, 0x30, 0x30, 0x03, 0x4C};

template <std::size_t N>
void encode_case(benchmark::State& state, const frame& f, const std::array<std::uint8_t, N>& want) {
    std::array<std::uint8_t, max_frame_length> buf{};
    if (auto n = encode(f, buf); !n || *n != N || std::memcmp(buf.data(), want.data(), N) != 0)
        state.SkipWithError("encode gave the wrong bytes");
    for (auto _ : state) {
        auto n = encode(f, buf);
        benchmark::DoNotOptimize(n);
        benchmark::DoNotOptimize(buf.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
}
void BM_encode_read(benchmark::State& s) {
    encode_case(s, read_request(1, code(46)), read46);
}
void BM_encode_write(benchmark::State& s) {
    encode_case(s, write_request(34, code(11), decimal_fixed(952'000)), write11);
}
BENCHMARK(BM_encode_read);
BENCHMARK(BM_encode_write);

template <std::size_t N>
void parse_case(benchmark::State& state, const std::array<std::uint8_t, N>& in,
                bool (*ok)(const frame&)) {
    const auto first = parse_reply(in);
    if (!first || !ok(*first)) state.SkipWithError("parse_reply gave the wrong answer");
    for (auto _ : state) {
        benchmark::DoNotOptimize(in.data());
        auto r = parse_reply(in);
        benchmark::DoNotOptimize(r);
    }
    state.SetItemsProcessed(state.iterations());
    state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(N));
}
void BM_parse_reply_decimal(benchmark::State& s) {
    parse_case(s, reply46, [](const frame& f) {
        return f.kind == frame_kind::data && f.code == code(46) && f.value.fixed == 354'000;
    });
}
void BM_parse_reply_hex(benchmark::State& s) {
    parse_case(s, reply68, [](const frame& f) {
        return f.kind == frame_kind::data && f.code == code(68) && f.value.hex == 0x0900;
    });
}
BENCHMARK(BM_parse_reply_decimal);
BENCHMARK(BM_parse_reply_hex);

// A drive's side of the line: requests and replies interleaved, as a bus monitor sees them.
std::vector<std::uint8_t> bus_stream() {
    std::vector<std::uint8_t> s;
    using view = std::span<const std::uint8_t>;
    for (const view t : {view(read46), view(reply46), view(write11), view(&ack, 1)})
        s.insert(s.end(), t.begin(), t.end());
    return s;
}

void decode_case(benchmark::State& state, std::size_t chunk) {
    const auto in = bus_stream();
    frame_decoder d(frame_decoder::accept::both);
    for (auto _ : state) {
        int frames = 0;
        for (std::size_t pos = 0; pos < in.size(); pos += chunk) {
            auto piece =
                std::span<const std::uint8_t>(in).subspan(pos, std::min(chunk, in.size() - pos));
            while (!piece.empty()) {
                const auto s = d.feed(piece);
                piece = piece.subspan(s.consumed);
                frames += s.what == frame_decoder::status::frame;
            }
        }
        if (frames != 4) {
            state.SkipWithError("the decoder did not find the 4 telegrams");
            break;
        }
        benchmark::DoNotOptimize(d.frame().data());
    }
    state.SetItemsProcessed(state.iterations() * 4);
    state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(in.size()));
}
void BM_decode_stream_bytewise(benchmark::State& s) {
    decode_case(s, 1);
}
void BM_decode_stream_one_span(benchmark::State& s) {
    decode_case(s, 1024);
}
BENCHMARK(BM_decode_stream_bytewise);
BENCHMARK(BM_decode_stream_one_span);

// One read in memory: start -> next (send) -> on_receive (reply) -> next (done).
void BM_master_read(benchmark::State& state) {
    master m;
    time_point now = time_point{} + 1s;
    for (auto _ : state) {
        now += 50ms;
        if (m.start_read(1, code(46))) {
            state.SkipWithError("start failed");
            break;
        }
        const auto send = m.next(now);
        if (send.what != session_action::kind::send || send.bytes.size() != read46.size()) {
            state.SkipWithError("master did not send the request");
            break;
        }
        benchmark::DoNotOptimize(send.bytes.data());
        m.on_receive(reply46, now + 30ms);
        const auto done = m.next(now + 30ms);
        if (done.what != session_action::kind::done || m.error() ||
            m.reply().value.fixed != 354'000) {
            state.SkipWithError("read did not succeed");
            break;
        }
        m.clear();
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_master_read);

} // namespace
