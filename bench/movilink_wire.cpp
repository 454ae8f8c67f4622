// Whole runs on the wire, in virtual time: how many 3PD cycles per second of bus time a
// master gets from a simulated MOVITRAC B at 9600 8E1, and what lost replies cost.
//
//   ferrule           movilink::master, manual timing (3.44 ms start pause, 50 ms timeout)
//   ferrule_5s        the same with the paper's 5 s response timeout
//   paper_plc/<scan>  the PLC program of the MOVILINK paper (seeds/000), as published:
//                     one state of its eight-state machine per PLC scan, GetByte() taking
//                     one byte per visit of state 4, a 5 s resend timeout
//
// The figures are virtual milliseconds on the line (counter bus_ms_per_cycle), not CPU
// time: they are exact and the same on every machine. Every run checks that each cycle
// returned the drive's PI words; a run that does not is reported as an error.
#include <benchmark/benchmark.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <span>

#include "ferrule/core/driver.hpp"
#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/movilink/access.hpp"
#include "ferrule/movilink/sim/bus.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::movilink;
using namespace std::chrono_literals;

constexpr int cycles = 200;
constexpr std::array<std::uint16_t, 3> po{0x0006, 7500, 1000}; // enable, 1500 rpm, 1 s

double ms(duration d) {
    return std::chrono::duration<double, std::milli>(d).count();
}

// One simulated drive at address 1 on a 9600 8E1 line; bus.drop_replies() loses replies.
struct lossy_line {
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    explicit lossy_line() { bus.add(); }
};

void report(benchmark::State& state, duration bus_time, int good, int lost) {
    if (good != cycles) state.SkipWithError("a cycle did not return the drive's PI words");
    state.counters["bus_ms_per_cycle"] = ms(bus_time) / cycles;
    state.counters["cycles_per_bus_s"] = cycles / std::chrono::duration<double>(bus_time).count();
    state.counters["replies_lost"] = lost;
}

void run_ferrule(benchmark::State& state, duration timeout, int drop_every) {
    duration bus_time{};
    int good = 0, lost = 0;
    for (auto _ : state) {
        lossy_line l;
        master_config cfg;
        cfg.response_timeout = timeout;
        master m(cfg);
        good = 0;
        lost = 0;
        for (int i = 0; i < cycles; ++i) {
            if (drop_every > 0 && i % drop_every == drop_every - 1) {
                l.bus.drop_replies(1);
                ++lost;
            }
            const auto pi = exchange(l.line, m, 1, po);
            if (pi && status_word{pi->words[0]}.ready()) ++good;
        }
        bus_time = l.line.now() - time_point{};
    }
    report(state, bus_time, good, lost);
}

// The paper's program: state 1 empties the receive buffer, 2 forms the telegram, 3 sends
// it (the library keeps the idle time), 4 waits for a byte (resend after 5 s), 5 stores
// it, 6 checks the reply. Each scan runs one state; GetByte() returns at most one byte.
class paper_plc {
public:
    paper_plc(mock_serial& line, duration scan) : line_(line), scan_(scan) {}

    // Runs until `n` cycles have returned a reply; false if one never did.
    bool run(int n, int drop_every, sim::bus<1>& bus, int& good, int& lost) {
        const telegram request{direction::request, 1, pdu_type::pd3, {}, {po[0], po[1], po[2]}};
        std::array<std::uint8_t, max_telegram_size> tx{};
        const std::size_t tx_size = *encode(request, tx);
        std::array<std::uint8_t, max_telegram_size> rx{};
        std::size_t rx_size = 0;
        int state = 1;
        time_point sent{};
        time_point last_activity{};
        int started = 0;
        while (good < n) {
            // The next scan; a write blocks the mock line for the telegram's wire time, while
            // a PLC goes on scanning in state 4 with nothing to read.
            scan_at_ += scan_;
            while (scan_at_ < line_.now()) scan_at_ += scan_;
            line_.sleep_until(scan_at_);
            if (line_.now() - sent > 60s) return false;
            std::uint8_t byte = 0;
            switch (state) {
            case 1:
                if (line_.read_some(std::span(&byte, 1), line_.now()).bytes == 0) state = 2;
                break;
            case 2: state = 3; break; // the telegram is formed (tx)
            case 3:
                // The UNM library inserts the idle time before a telegram itself.
                if (line_.now() - last_activity < start_pause) break;
                if (started++ % drop_every == drop_every - 1) {
                    bus.drop_replies(1);
                    ++lost;
                }
                (void)line_.write(std::span(tx.data(), tx_size));
                sent = last_activity = line_.now();
                rx_size = 0;
                state = 4;
                break;
            case 4:
                if (line_.now() - sent > 5s) {
                    state = 3;
                    break;
                }
                if (line_.read_some(std::span(&byte, 1), line_.now()).bytes == 1) {
                    rx[rx_size] = byte;
                    state = 5;
                }
                break;
            case 5:
                last_activity = line_.now();
                if (++rx_size == telegram_size(pdu_type::pd3))
                    state = 6;
                else
                    state = 4;
                break;
            case 6: {
                const auto reply = parse(std::span(rx.data(), rx_size));
                if (reply && reply->dir == direction::response && status_word{reply->pd[0]}.ready())
                    ++good;
                state = 2;
                break;
            }
            }
        }
        return true;
    }

private:
    mock_serial& line_;
    duration scan_;
    time_point scan_at_{};
};

void run_paper(benchmark::State& state, duration scan, int drop_every) {
    duration bus_time{};
    int good = 0, lost = 0;
    for (auto _ : state) {
        lossy_line l;
        paper_plc plc(l.line, scan);
        good = 0;
        lost = 0;
        if (!plc.run(cycles, drop_every > 0 ? drop_every : cycles + 1, l.bus, good, lost)) break;
        bus_time = l.line.now() - time_point{};
    }
    report(state, bus_time, good, lost);
}

void BM_ferrule(benchmark::State& s) {
    run_ferrule(s, response_timeout, 0);
}
void BM_ferrule_lossy(benchmark::State& s) {
    run_ferrule(s, response_timeout, 20);
}
void BM_ferrule_5s_lossy(benchmark::State& s) {
    run_ferrule(s, 5s, 20);
}
void BM_paper_plc(benchmark::State& s) {
    run_paper(s, std::chrono::microseconds(s.range(0)), 0);
}
void BM_paper_plc_lossy(benchmark::State& s) {
    run_paper(s, std::chrono::microseconds(s.range(0)), 20);
}

BENCHMARK(BM_ferrule)->Iterations(1);
BENCHMARK(BM_ferrule_lossy)->Iterations(1);
BENCHMARK(BM_ferrule_5s_lossy)->Iterations(1);
BENCHMARK(BM_paper_plc)->Arg(250)->Arg(1000)->Arg(5000)->Iterations(1);
BENCHMARK(BM_paper_plc_lossy)->Arg(1000)->Iterations(1);

} // namespace
