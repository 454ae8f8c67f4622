// Whole runs on the wire, in virtual time: six simulated Lenze 4900 drives on one 9600 Bd
// LECOM-B line, each read for its actual speed (C0050), as in the LECOM paper (seeds/003).
//
//   ferrule/<format>      lecom::poller, every item interval 0: the next read goes out as
//                         soon as the last reply is in
//   ferrule_lossy         the same with 1 reply in 20 lost (100 ms timeout, 2 resends)
//   paper_plc             the paper's CP440 "sends master commands to the slaves every
//                         50 ms", read as one command per 50 ms tick, round the six drives
//
// The figures are virtual milliseconds on the line (counter bus_ms_per_round: one read of
// each of the six drives), exact and the same on every machine. Every run checks that each
// read returned the drive's speed; a run that does not is reported as an error.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdint>

#include "ferrule/core/driver.hpp"
#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/lecom/access.hpp"
#include "ferrule/lecom/poller.hpp"
#include "ferrule/lecom/sim/bus.hpp"

namespace {

using namespace ferrule;
using namespace std::chrono_literals;
namespace lc = ferrule::lecom;

constexpr int rounds = 100;
constexpr int drives = 6;

double ms(duration d) {
    return std::chrono::duration<double, std::milli>(d).count();
}

// Six drives running at 1500 rpm (setpoint C0046, reached after the 2 s ramp), so each
// C0050 reply carries a 4-digit value: 9 characters, as in the poller's worked example.
struct line6 {
    lc::sim::bus<drives> bus;
    mock_serial line;
    explicit line6(const serial_format& f) : line(f, &bus) {
        for (std::uint8_t a = 1; a <= drives; ++a) {
            lc::slave_config cfg;
            cfg.address = a;
            bus.add(cfg)->drive.preset(46, 1500 * lc::value::scale);
        }
        bus.advance(line.now());
        line.sleep_until(line.now() + 3s);
        bus.advance(line.now());
    }
};

void report(benchmark::State& state, duration bus_time, int good, int lost) {
    if (good != rounds * drives) state.SkipWithError("a read did not return the drive's speed");
    state.counters["bus_ms_per_round"] = ms(bus_time) / rounds;
    state.counters["reads_per_bus_s"] =
        rounds * drives / std::chrono::duration<double>(bus_time).count();
    state.counters["replies_lost"] = lost;
}

// The poller until it has done `rounds` rounds; each completed read is checked.
void run_poller(benchmark::State& state, const serial_format& f, int drop_every) {
    duration bus_time{};
    int good = 0, lost = 0;
    for (auto _ : state) {
        line6 l(f);
        lc::poller_config cfg;
        cfg.master.format = f;
        lc::poller<drives> p(cfg);
        for (std::uint8_t a = 1; a <= drives; ++a) (void)p.add({a, lc::code(50)});
        good = lost = 0;
        std::uint32_t seen = 0;
        int sent = 0;
        std::array<std::uint8_t, 64> buf{};
        time_point start = never;
        for (;;) {
            const session_action a = p.next(l.line.now());
            if (p.completed() != seen) {
                seen = p.completed();
                if (!p.last_event().error && p.last_event().value.fixed == 1500 * lc::value::scale)
                    ++good;
            }
            // cycles() counts the starts of item 0's reads after its first: here `rounds`
            // whole rounds are on the wire, and the next begins now.
            if (static_cast<int>(p.cycles()) == rounds) {
                bus_time = l.line.now() - start;
                break;
            }
            if (a.what == session_action::kind::send) {
                if (a.discard_input) l.line.discard_input();
                if (start == never) start = l.line.now();
                if (drop_every > 0 && ++sent % drop_every == 0) {
                    l.bus.drop_replies(1);
                    ++lost;
                }
                (void)l.line.write(a.bytes);
            } else if (a.what == session_action::kind::wait) {
                const io_result r = l.line.read_some(buf, a.deadline);
                if (r.bytes > 0) p.on_receive({buf.data(), r.bytes}, l.line.now());
            }
        }
    }
    report(state, bus_time, good, lost);
}

void ferrule_8e1(benchmark::State& state) {
    run_poller(state, lc::lenze_4900.format, 0);
}
void ferrule_7e1(benchmark::State& state) {
    run_poller(state, lc::lenze_8200.format, 0);
}
void ferrule_lossy(benchmark::State& state) {
    run_poller(state, lc::lenze_4900.format, 20);
}

// One read per 50 ms tick, drive 1, 2, … 6, 1, …
void paper_plc(benchmark::State& state) {
    duration bus_time{};
    int good = 0;
    for (auto _ : state) {
        line6 l(lc::lenze_4900.format);
        lc::master m;
        good = 0;
        const time_point start = l.line.now();
        for (int i = 0; i < rounds * drives; ++i) {
            l.line.sleep_until(start + i * 50ms);
            const auto v =
                lc::read(l.line, m, static_cast<std::uint8_t>(1 + i % drives), lc::code(50));
            if (v && v->fixed == 1500 * lc::value::scale) ++good;
        }
        l.line.sleep_until(start + rounds * drives * 50ms);
        bus_time = l.line.now() - start;
    }
    report(state, bus_time, good, 0);
}

} // namespace

BENCHMARK(ferrule_8e1)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(ferrule_7e1)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(ferrule_lossy)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(paper_plc)->Iterations(1)->Unit(benchmark::kMillisecond);
