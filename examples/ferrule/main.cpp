// ferrule: the command-line tool. `ferrule demo` runs a MOVILINK master against two
// simulated SEW MOVITRAC B drives on an RS-485 line at 9600 8E1, in virtual time: every
// byte takes its wire time, so the timestamps shown are what a real bus would see.
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <span>
#include <string_view>
#include <system_error>

#include "ferrule/core/driver.hpp"
#include "ferrule/core/mock_serial.hpp"
#include "ferrule/movilink/access.hpp"
#include "ferrule/movilink/master.hpp"
#include "ferrule/movilink/process_data.hpp"
#include "ferrule/movilink/sim_bus.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::movilink;
using namespace std::chrono_literals;
namespace ix = movilink::sim::parameter_index;

double ms(time_point t) {
    return std::chrono::duration<double, std::milli>(t.time_since_epoch()).count();
}
double ms(duration d) {
    return std::chrono::duration<double, std::milli>(d).count();
}

// Prints the telegrams that crossed the line since the last call: bytes of one side with
// less than a start pause between them form one telegram.
class tracer {
public:
    explicit tracer(mock_serial& line, bool on) : line_(line), on_(on) {}

    // Also empties the line's log, so a long run never fills it.
    void flush() {
        const auto log = line_.wire();
        std::size_t next = 0;
        while (on_ && next < log.size()) {
            const std::size_t first = next;
            std::size_t last = first;
            while (last + 1 < log.size() && log[last + 1].origin == log[first].origin &&
                   log[last + 1].start - log[last].end < start_pause)
                ++last;
            print(log.subspan(first, last - first + 1));
            next = last + 1;
        }
        bytes_ += log.size();
        line_.clear_wire_log();
    }
    std::size_t bytes_on_line() const noexcept { return bytes_; }

private:
    static void print(std::span<const wire_byte> t) {
        std::array<std::uint8_t, 64> bytes{};
        std::size_t n = 0;
        for (const auto& b : t)
            if (n < bytes.size()) bytes[n++] = b.value;
        const bool master = t.front().origin == wire_byte::from::session;
        std::printf("    %10.3f ms %s ", ms(t.front().start), master ? "master ->" : "drive  <-");
        for (std::size_t i = 0; i < n; ++i) std::printf(" %02X", bytes[i]);
        const auto parsed = parse(std::span<const std::uint8_t>(bytes.data(), n));
        if (parsed)
            std::printf("   ADR %u TYP 0x%02X", parsed->address,
                        static_cast<unsigned>(parsed->type));
        else
            std::printf("   (%s)", parsed.error().message().c_str());
        std::printf("\n");
    }

    mock_serial& line_;
    bool on_;
    std::size_t bytes_ = 0;
};

void show_error(const char* what, std::error_code ec) {
    std::printf("  %-44s -> %s\n", what, ec.message().c_str());
}

int demo(bool trace) {
    sim::bus<2> bus;
    mock_serial line(default_format, &bus);
    slave_config drive1;
    drive1.address = 1;
    slave_config drive2;
    drive2.address = 2;
    drive2.processing_time = 2ms;
    bus.add(drive1);
    bus.add(drive2);
    master m; // the manual's timing: 3.44 ms start pause, 50 ms response timeout, 4 resends
    tracer tr(line, trace);

    std::printf("ferrule demo: MOVILINK master <-> 2 simulated MOVITRAC B (addresses 1, 2)\n"
                "RS-485 %u baud 8E1 in virtual time (1 character = %.3f ms)%s\n\n",
                default_format.baud, ms(default_format.char_time()),
                trace ? "; every telegram is shown with its start time" : "");

    std::printf("1. Parameter channel, acyclic PARAM (TYP 0x86)\n");
    struct named {
        const char* name;
        std::uint8_t address;
        std::uint16_t index;
    };
    for (const named p :
         {named{"drive 1 P070 unit type", 1, ix::p070_unit_type},
          named{"drive 1 P014 heat sink temperature [degC]", 1, ix::p014_heat_sink_temperature},
          named{"drive 2 P810 RS-485 address", 2, ix::p810_rs485_address}}) {
        const auto v = read_parameter(line, m, p.address, p.index);
        tr.flush();
        if (v)
            std::printf("  %-44s =  %ld (0x%08X)\n", p.name,
                        static_cast<long>(static_cast<std::int32_t>(*v)),
                        static_cast<unsigned>(*v));
        else
            show_error(p.name, v.error());
    }
    const auto written = write_parameter(line, m, 1, ix::p812_rs485_timeout_delay, 1000);
    tr.flush();
    if (written)
        show_error("drive 1 P812 := 1.000 s (write volatile)", written);
    else
        std::printf("  %-44s ok\n", "drive 1 P812 timeout := 1.000 s (volatile)");

    std::printf("\n2. Drive errors come back with the manual's text. The paper's master resends a\n"
                "   failed request 4 times, then latches a fault until it is reset:\n");
    const auto bad = read_parameter(line, m, 1, 0x1234);
    tr.flush();
    show_error("drive 1 read index 0x1234", bad.error());
    std::printf("  %-44s    %u requests sent, fault latched: %s\n", "", m.attempts(),
                m.fault_latched() ? "yes" : "no");
    m.reset_fault();
    const auto big = write_parameter(line, m, 2, ix::p810_rs485_address, 150);
    tr.flush();
    show_error("drive 2 P810 := 150", big);
    m.reset_fault();

    std::printf("\n3. Cyclic process data, 3PD (TYP 0x05): enable, 1500 rpm, ramp 1 s\n");
    std::array<std::uint16_t, 3> po{control_word::enable().value, rpm_to_digits(1500),
                                    ramp_to_digits(1000ms)};
    const time_point start = line.now();
    std::uint32_t cycles = 0;
    time_point last_print = start - 1s;
    const auto cycle_until = [&](auto&& done) {
        for (;;) {
            const auto pi = exchange(line, m, 1, po);
            tr.flush();
            ++cycles;
            if (!pi) {
                show_error("cycle", pi.error());
                m.reset_fault();
                continue;
            }
            const status_word sw{pi->words[0]};
            const bool finished = done(pi->words[1]);
            if (finished || line.now() - last_print >= 200ms) {
                std::printf(
                    "  t=%8.1f ms  status 0x%04X (ready %d, output stage %d, unit status %u)"
                    "  speed %7.1f rpm  current %5.1f %% I_N\n",
                    ms(line.now() - start), sw.value, sw.ready(), sw.output_stage_enabled(),
                    sw.unit_status(), digits_to_rpm(pi->words[1]), digits_to_current(pi->words[2]));
                last_print = line.now();
            }
            if (finished) return;
        }
    };
    cycle_until([](std::uint16_t speed) { return speed == rpm_to_digits(1500); });
    const duration ramp_time = line.now() - start;
    std::printf("  %u cycles in %.1f ms: %.3f ms per cycle (start pause + 10 + 10 characters"
                " + the drive's start pause)\n",
                cycles, ms(ramp_time), ms(ramp_time) / cycles);

    std::printf(
        "\n4. A parameter read riding on cyclic PARAM+3PD (TYP 0x04), handshake bit toggled\n");
    if (auto ec = m.start_parameter(1, pdu_type::param_3pd,
                                    param_channel::make(service::read, ix::p000_speed), po))
        show_error("start", ec);
    const auto ec = run(line, m);
    tr.flush();
    if (ec)
        show_error("drive 1 P000 speed", ec);
    else
        std::printf("  %-44s =  %.3f rpm (handshake %d)\n", "drive 1 P000 speed",
                    static_cast<std::int32_t>(m.reply().param.data) / 1000.0,
                    m.reply().param.handshake());

    std::printf(
        "\n5. Two replies lost on the line: timeout after 50 ms, resend, process data goes on\n");
    bus.drop_replies(2);
    const auto before = m.stats();
    const auto lost = exchange(line, m, 1, po);
    tr.flush();
    std::printf("  cycle %s after %u requests; timeouts so far %u, resends %u\n",
                lost ? "succeeded" : lost.error().message().c_str(), m.attempts(),
                m.stats().timeouts - before.timeouts, m.stats().resends - before.resends);

    std::printf("\n6. Stop with the ramp (control word 0x0002)\n");
    po[0] = control_word::stop().value;
    const time_point stop_at = line.now();
    last_print = stop_at - 1s;
    cycle_until([](std::uint16_t speed) { return speed == 0; });
    std::printf("  standstill %.1f ms after the stop command\n", ms(line.now() - stop_at));

    std::printf(
        "\n7. Broadcast (ADR 255) rapid stop: no drive answers; the next request waits 25 ms\n");
    const std::array<std::uint16_t, 3> rapid{control_word::rapid_stop().value, 0, 0};
    if (auto err = m.start_exchange(address_broadcast, pdu_type::pd3, rapid))
        show_error("start", err);
    const auto broadcast = run(line, m);
    tr.flush();
    show_error("broadcast", broadcast);
    const time_point broadcast_end = line.now();
    const auto after = read_parameter(line, m, 1, ix::p094_po1_setpoint);
    const time_point next_start = line.wire().front().start;
    tr.flush();
    if (after)
        std::printf("  drive 1 P094 PO1 setpoint = 0x%04X; that read started %.3f ms after the"
                    " broadcast\n",
                    static_cast<unsigned>(*after), ms(next_start - broadcast_end));
    else
        show_error("drive 1 P094 PO1 setpoint", after.error());

    const auto& s = m.stats();
    std::printf(
        "\nmaster: %u transactions, %u succeeded, %u failed; %u timeouts, %u invalid replies,"
        " %u drive errors, %u resends; %zu bytes on the line in %.1f ms of bus time\n",
        s.transactions, s.succeeded, s.failed, s.timeouts, s.invalid_replies, s.device_errors,
        s.resends, tr.bytes_on_line(), ms(line.now()));
    return 0;
}

void usage(std::FILE* to) {
    std::fprintf(to, "usage: ferrule demo [--trace]\n"
                     "  demo     MOVILINK master against two simulated MOVITRAC B drives\n"
                     "           (RS-485 9600 8E1 in virtual time)\n"
                     "  --trace  show every telegram with its time on the line\n");
}

} // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    const std::string_view cmd = argv[1];
    if (cmd == "-h" || cmd == "--help") {
        usage(stdout);
        return 0;
    }
    if (cmd != "demo") {
        std::fprintf(stderr, "ferrule: unknown command '%s'\n", argv[1]);
        usage(stderr);
        return 2;
    }
    bool trace = false;
    for (int i = 2; i < argc; ++i) {
        if (std::strcmp(argv[i], "--trace") == 0) {
            trace = true;
        } else {
            std::fprintf(stderr, "ferrule demo: unknown option '%s'\n", argv[i]);
            return 2;
        }
    }
    return demo(trace);
}
