// The PROFIBUS-DP ↔ Modbus RTU gateway on the wire.
//
// wire/<dp baud>/<drive baud>: in virtual time (gateway::sim::rig), a profibus::master
// exchanging 5 bytes each way with the gateway back to back, writing a new command
// (FC 6 to the simulated VFD's setpoint) every DP cycle for 1000 cycles. Counters: the DP
// cycle (virtual µs per Data_Exchange), the drive's transaction (virtual µs per FC 6 request
// and reply), commands delivered and overflowed, and delivered per second of virtual time.
// Exact and the same on every machine; a run whose counts do not add up is an error.
//
// pty_reaction: the DP-V0 slave served by host::serve() over host::serial_stream on one end
// of a pseudo-terminal; the other end writes FDL_Status requests (19.2 kbit/s settings,
// which a pty does not enforce) and measures, in wall time, from the return of write() to
// the first reply byte readable: the slave's min TSDR (11 tbit = 573 µs) plus the host's
// scheduling. Counters: median, 99th percentile and maximum over 2000 requests, and how
// many replies came later than max TSDR (60 tbit = 3125 µs).
#include <benchmark/benchmark.h>

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <asio/io_context.hpp>
#include <asio/serial_port.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>
#include <vector>

#include "ferrule/host/serial_stream.hpp"
#include "ferrule/host/serve.hpp"
#include "ferrule/gateway/sim/rig.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/slave.hpp"

namespace {

using namespace ferrule;
using namespace std::chrono_literals;
namespace pb = ferrule::profibus;
namespace mb = ferrule::modbus;
namespace gw = ferrule::gateway;

const std::array<std::uint8_t, 2> cfg5{0x24, 0x14};
constexpr std::uint16_t ident = 0x0F2A;

double us(duration d) {
    return std::chrono::duration<double, std::micro>(d).count();
}

void wire(benchmark::State& state) {
    const auto dp_baud = static_cast<std::uint32_t>(state.range(0));
    const auto drive_baud = static_cast<std::uint32_t>(state.range(1));
    constexpr int commands = 1000;
    double dp_cycle = 0, drive_tx = 0, delivered = 0, overflowed = 0, per_s = 0;
    for (auto _ : state) {
        gw::config c;
        c.dp.baud = dp_baud;
        c.dp.address = 8;
        c.dp.ident = ident;
        c.dp.cfg = cfg5;
        c.modbus.format = {drive_baud, 8, parity::even, 1};
        c.modbus.inter_frame_gap = mb::t35(c.modbus.format);
        c.modbus.response_timeout = 100ms;
        gw::sim::rig<1> rig(c);
        mb::server_config drive;
        drive.units = {1};
        drive.format = c.modbus.format;
        rig.drives().add(drive);
        mock_serial dp_line(pb::format(dp_baud), &rig);
        pb::master_config mc;
        mc.format = pb::format(dp_baud);
        pb::master master(mc);
        pb::prm_data p;
        p.station_status = pb::prm::lock_req | pb::prm::wd_on;
        p.wd_fact1 = p.wd_fact2 = 10;
        p.ident = ident;
        if (pb::bring_up(dp_line, master, 8, p, cfg5)) return state.SkipWithError("bring-up");
        std::array<std::uint8_t, 5> in{};
        const time_point start = dp_line.now();
        for (int i = 1; i <= commands; ++i) {
            const std::array<std::uint8_t, 5> out{
                0x06, 0xC8, 0x01, static_cast<std::uint8_t>(i >> 8), static_cast<std::uint8_t>(i)};
            if (pb::data_exchange(dp_line, master, 8, out, in))
                return state.SkipWithError("data exchange");
        }
        const duration run = dp_line.now() - start;
        rig.run_until(dp_line.now() + 1s);
        const gw::stats& st = rig.core().stats();
        if (st.commands + st.overflowed != commands ||
            st.delivered + st.failed + st.discarded + rig.core().waiting_commands() !=
                st.commands ||
            st.failed != 0)
            return state.SkipWithError("commands do not add up");
        dp_cycle = us(run) / commands;
        // FC 6: 8 bytes out, 8 back, t3.5 before each request.
        drive_tx = us(c.modbus.format.chars_time(16) + c.modbus.inter_frame_gap);
        delivered = st.delivered;
        overflowed = st.overflowed;
        per_s = st.delivered / std::chrono::duration<double>(run).count();
    }
    state.counters["dp_cycle_us"] = dp_cycle;
    state.counters["drive_tx_us"] = drive_tx;
    state.counters["delivered"] = delivered;
    state.counters["overflowed"] = overflowed;
    state.counters["delivered_per_s"] = per_s;
}

// --- the slave on a pty, in wall time ------------------------------------------------------

void pty_reaction(benchmark::State& state) {
    constexpr int requests = 2000;
    std::vector<double> reaction_us;
    for (auto _ : state) {
        int master_fd = -1, slave_fd = -1;
        std::array<char, 256> name{};
        if (openpty(&master_fd, &slave_fd, name.data(), nullptr, nullptr) != 0)
            return state.SkipWithError("openpty");
        for (int fd : {master_fd, slave_fd}) {
            termios t{};
            tcgetattr(fd, &t);
            cfmakeraw(&t);
            tcsetattr(fd, TCSANOW, &t);
        }
        std::atomic<bool> stop{false};
        std::thread station([&] {
            ::asio::io_context ctx;
            ::asio::serial_port port(ctx, name.data());
            host::serial_stream line(ctx, port);
            pb::slave_config sc;
            sc.address = 8;
            sc.ident = ident;
            sc.cfg = cfg5;
            pb::slave slave(sc);
            host::serve(line, slave, stop, 20ms);
        });
        std::this_thread::sleep_for(100ms);
        const std::array<std::uint8_t, 6> fdl_status{0x10, 0x08, 0x02, 0x49, 0x53, 0x16};
        std::array<std::uint8_t, 16> reply{};
        reaction_us.clear();
        for (int i = 0; i < requests; ++i) {
            if (write(master_fd, fdl_status.data(), fdl_status.size()) != 6) break;
            const auto sent = std::chrono::steady_clock::now();
            pollfd p{master_fd, POLLIN, 0};
            if (poll(&p, 1, 1000) != 1) break;
            const auto first = std::chrono::steady_clock::now();
            std::size_t got = 0;
            while (got < 6) {
                const ssize_t n = read(master_fd, reply.data() + got, reply.size() - got);
                if (n <= 0) break;
                got += static_cast<std::size_t>(n);
                if (got < 6 && poll(&p, 1, 1000) != 1) break;
            }
            if (got != 6 || reply[3] != 0x00) break;
            reaction_us.push_back(std::chrono::duration<double, std::micro>(first - sent).count());
            std::this_thread::sleep_for(2ms); // the master's idle time and more
        }
        stop = true;
        station.join();
        close(master_fd);
        close(slave_fd);
    }
    if (reaction_us.size() != requests) return state.SkipWithError("a request got no reply");
    std::sort(reaction_us.begin(), reaction_us.end());
    const double max_tsdr = us(pb::bit_times(19'200, pb::max_tsdr_bits(19'200)));
    state.counters["median_us"] = reaction_us[reaction_us.size() / 2];
    state.counters["p99_us"] = reaction_us[reaction_us.size() * 99 / 100];
    state.counters["max_us"] = reaction_us.back();
    state.counters["min_tsdr_us"] = us(pb::bit_times(19'200, pb::min_tsdr_bits));
    state.counters["late"] = static_cast<double>(std::count_if(
        reaction_us.begin(), reaction_us.end(), [&](double v) { return v > max_tsdr; }));
}

} // namespace

BENCHMARK(wire)
    ->ArgsProduct({{19'200, 187'500}, {2'400, 9'600, 19'200}})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(pty_reaction)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();
