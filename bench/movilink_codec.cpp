// Google Benchmark: MOVILINK codec and master session, in memory.
//
// Telegrams are the golden vectors of protocols/movilink.md §4:
//   M1  02 01 05 00 06 3A 98 01 F4 57                          3PD request (cyclic)
//   M2  1D 01 85 02 06 00 00 06 06 9D                          3PD reply (acyclic)
//   D3  1D 01 86 31 00 20 87 00 00 00 14 18                    PARAM reply
//   D6  02 01 04 71 00 20 7E 00 00 00 00 00 06 07 D0 00 00 F9  PARAM + 3PD request
// Every case reports items/s (one item = one telegram or one transaction) and checks its
// result once before timing, so a broken codec cannot produce a fast, meaningless number.
#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <span>

#include "ferrule/movilink/frame.hpp"
#include "ferrule/movilink/master.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::movilink;
using namespace std::chrono_literals;

constexpr std::array<std::uint8_t, 10> m1_bytes{0x02, 0x01, 0x05, 0x00, 0x06,
                                                0x3A, 0x98, 0x01, 0xF4, 0x57};
constexpr std::array<std::uint8_t, 10> m2_reply{0x1D, 0x01, 0x85, 0x02, 0x06,
                                                0x00, 0x00, 0x06, 0x06, 0x9D};
constexpr std::array<std::uint8_t, 12> d3_reply{0x1D, 0x01, 0x86, 0x31, 0x00, 0x20,
                                                0x87, 0x00, 0x00, 0x00, 0x14, 0x18};
constexpr std::array<std::uint8_t, 18> d6_bytes{0x02, 0x01, 0x04, 0x71, 0x00, 0x20,
                                                0x7E, 0x00, 0x00, 0x00, 0x00, 0x00,
                                                0x06, 0x07, 0xD0, 0x00, 0x00, 0xF9};

telegram m1_request() {
    return {direction::request, 1, pdu_type::pd3, {}, {0x0006, 0x3A98, 0x01F4}};
}
telegram d6_request() {
    param_channel p = param_channel::make(service::read, 0x207E);
    p.set_handshake(true);
    return {direction::request, 1, pdu_type::param_3pd, p, {0x0006, 0x07D0, 0x0000}};
}

template <std::size_t N>
bool same(std::span<const std::uint8_t> a, const std::array<std::uint8_t, N>& b) {
    return a.size() == N && std::memcmp(a.data(), b.data(), N) == 0;
}

void BM_encode_3pd(benchmark::State& state) {
    telegram t = m1_request();
    std::array<std::uint8_t, max_telegram_size> buf{};
    if (auto n = encode(t, buf); !n || !same(std::span(buf.data(), *n), m1_bytes))
        state.SkipWithError("encode(M1) wrong");
    for (auto _ : state) {
        benchmark::DoNotOptimize(t); // the telegram may change between iterations
        auto n = encode(t, buf);
        benchmark::DoNotOptimize(n);
        benchmark::DoNotOptimize(buf.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_encode_3pd);

void BM_encode_fixed_pd3(benchmark::State& state) {
    telegram t = m1_request();
    std::array<std::uint8_t, telegram_size(pdu_type::pd3)> buf{};
    encode_fixed<pdu_type::pd3>(t, buf);
    if (!same(buf, m1_bytes)) state.SkipWithError("encode_fixed<pd3>(M1) wrong");
    for (auto _ : state) {
        benchmark::DoNotOptimize(t);
        encode_fixed<pdu_type::pd3>(t, buf);
        benchmark::DoNotOptimize(buf.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_encode_fixed_pd3);

void BM_encode_param_3pd(benchmark::State& state) {
    telegram t = d6_request();
    std::array<std::uint8_t, max_telegram_size> buf{};
    if (auto n = encode(t, buf); !n || !same(std::span(buf.data(), *n), d6_bytes))
        state.SkipWithError("encode(D6) wrong");
    for (auto _ : state) {
        benchmark::DoNotOptimize(t);
        auto n = encode(t, buf);
        benchmark::DoNotOptimize(n);
        benchmark::DoNotOptimize(buf.data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_encode_param_3pd);

template <std::size_t N>
void parse_case(benchmark::State& state, const std::array<std::uint8_t, N>& wire,
                pdu_type expected) {
    // Held in a max-size buffer, as a receiver would (and so that GCC's -Warray-bounds at
    // -O3 does not flag parse()'s unreachable PARAM branch for a 10-byte array).
    std::array<std::uint8_t, max_telegram_size> buf{};
    std::memcpy(buf.data(), wire.data(), N);
    const std::span<const std::uint8_t> in(buf.data(), N);
    if (auto t = parse(in); !t || t->type != expected) state.SkipWithError("parse wrong");
    for (auto _ : state) {
        benchmark::DoNotOptimize(in.data()); // the bytes may change between iterations
        benchmark::ClobberMemory();
        auto t = parse(in);
        benchmark::DoNotOptimize(t);
    }
    state.SetItemsProcessed(state.iterations());
    state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(N));
}
void BM_parse_3pd_reply(benchmark::State& state) {
    parse_case(state, m2_reply, pdu_type::pd3_acyclic);
}
void BM_parse_param_reply(benchmark::State& state) {
    parse_case(state, d3_reply, pdu_type::param_acyclic);
}
BENCHMARK(BM_parse_3pd_reply);
BENCHMARK(BM_parse_param_reply);

// One item = one complete reply framed by the decoder (after an idle gap).
void BM_decoder_bytewise(benchmark::State& state) {
    std::array<std::uint8_t, m2_reply.size()> in = m2_reply;
    decoder d(decoder::accept::responses);
    for (auto _ : state) {
        benchmark::DoNotOptimize(in.data());
        benchmark::ClobberMemory();
        d.idle();
        decoder::status st = decoder::status::need_more;
        for (std::size_t i = 0; i < in.size(); ++i) st = d.feed({&in[i], 1}).what;
        if (st != decoder::status::frame) {
            state.SkipWithError("decoder did not frame M2");
            break;
        }
        benchmark::DoNotOptimize(d.frame().data());
    }
    state.SetItemsProcessed(state.iterations());
    state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(in.size()));
}
BENCHMARK(BM_decoder_bytewise);

void BM_decoder_chunk(benchmark::State& state) {
    std::array<std::uint8_t, m2_reply.size()> in = m2_reply;
    decoder d(decoder::accept::responses);
    for (auto _ : state) {
        benchmark::DoNotOptimize(in.data());
        benchmark::ClobberMemory();
        d.idle();
        const auto s = d.feed(in);
        if (s.what != decoder::status::frame) {
            state.SkipWithError("decoder did not frame M2");
            break;
        }
        benchmark::DoNotOptimize(d.frame().data());
    }
    state.SetItemsProcessed(state.iterations());
    state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(in.size()));
}
BENCHMARK(BM_decoder_chunk);

// One complete transaction in memory: start_exchange -> next (send the M2 request) ->
// on_receive (the M2 reply, in one chunk) -> next (done). Virtual time moves on by 50 ms
// per transaction, so the start pause never makes the session wait.
void BM_master_transaction(benchmark::State& state) {
    master m;
    const std::uint16_t po[3] = {0x0006, 0x2000, 0x0BB8};
    std::array<std::uint8_t, m2_reply.size()> reply = m2_reply;
    const duration wire = default_format.chars_time(telegram_size(pdu_type::pd3_acyclic));
    time_point now = time_point{} + 1s;
    for (auto _ : state) {
        now += 50ms;
        if (m.start_exchange(1, pdu_type::pd3_acyclic, po)) {
            state.SkipWithError("start_exchange failed");
            break;
        }
        const auto send = m.next(now);
        if (send.what != session_action::kind::send) {
            state.SkipWithError("master did not send");
            break;
        }
        benchmark::DoNotOptimize(send.bytes.data());
        benchmark::DoNotOptimize(reply.data());
        benchmark::ClobberMemory();
        m.on_receive(reply, now + 2 * wire + 2ms);
        const auto done = m.next(now + 2 * wire + 2ms);
        if (done.what != session_action::kind::done || m.error()) {
            state.SkipWithError("transaction did not succeed");
            break;
        }
        benchmark::DoNotOptimize(m.reply().pd[0]);
    }
    state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_master_transaction);

} // namespace
