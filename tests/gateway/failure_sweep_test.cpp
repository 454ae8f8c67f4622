// The PROFIBUS-DP ↔ Modbus RTU gateway through every failure point (tests/core/failure_sweep.hpp):
// its Modbus side (the drive line of gateway::sim::rig) during a transparent command, and its
// DP side as a station served on its own line.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "../core/failure_sweep.hpp"
#include "ferrule/gateway/sim/rig.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule;
namespace pb = ferrule::profibus;
namespace mb = ferrule::modbus;
namespace gw = ferrule::gateway;
using octets = std::vector<std::uint8_t>;
using ferrule::test::injected;

namespace {

// 5 octets out, 5 octets in: a Modbus request PDU and its reply.
const std::array<std::uint8_t, 2> cfg5{0x24, 0x14};
constexpr std::uint16_t ident = 0x0F2A;

gw::config transparent() {
    gw::config c;
    c.dp.baud = 187'500;
    c.dp.address = 8;
    c.dp.ident = ident;
    c.dp.cfg = cfg5;
    c.modbus.format = {19'200, 8, parity::even, 1};
    c.modbus.inter_frame_gap = mb::t35(c.modbus.format);
    c.modbus.response_timeout = 100ms;
    c.modbus.retries = 1;
    c.drive = 1;
    return c;
}

pb::prm_data locked_no_watchdog() {
    pb::prm_data p;
    p.station_status = pb::prm::lock_req;
    p.ident = ident;
    return p;
}

pb::master_config dp_master() {
    pb::master_config c;
    c.format = pb::format(187'500);
    return c;
}

// The DP master on its line, the gateway with one VFD on the drive line (`line`, swept).
struct command_rig {
    gw::sim::rig<1> rig{transparent()};
    mock_serial& line = rig.drive_line();
    mock_serial dp_line{pb::format(187'500), &rig};
    pb::master master{dp_master()};
    std::uint8_t setpoint = 0;
    command_rig() {
        mb::server_config drive;
        drive.format = transparent().modbus.format;
        REQUIRE(rig.drives().add(drive));
        REQUIRE_FALSE(pb::bring_up(dp_line, master, 8, locked_no_watchdog(), cfg5));
    }
};

struct command_outcome {
    octets command;
    octets inputs; // after the gateway has finished the command
    gw::stats stats;
};

// FC 6, a new frequency setpoint each time (a command is new when the outputs change), sent
// in every DP cycle until the gateway has finished it, then one cycle more for its reply.
command_outcome setpoint_command(command_rig& r) {
    ++r.setpoint;
    const octets cmd{0x06, 0xC8, 0x01, 0x00, r.setpoint};
    const gw::stats before = r.rig.core().stats();
    const auto finished = [&] {
        const gw::stats& s = r.rig.core().stats();
        return s.delivered + s.failed != before.delivered + before.failed;
    };
    octets in(5);
    for (int cycle = 0; cycle < 200 && !finished(); ++cycle)
        REQUIRE_FALSE(pb::data_exchange(r.dp_line, r.master, 8, cmd, in));
    REQUIRE_FALSE(pb::data_exchange(r.dp_line, r.master, 8, cmd, in));
    gw::stats delta = r.rig.core().stats();
    delta.commands -= before.commands;
    delta.delivered -= before.delivered;
    delta.failed -= before.failed;
    return {cmd, in, delta};
}

void delivered(command_rig& r, const command_outcome& o) {
    CHECK(o.stats.commands == 1);
    CHECK(o.stats.delivered == 1);
    CHECK(o.stats.failed == 0);
    CHECK(o.inputs == o.command); // FC 6 is answered with its echo
    CHECK(r.rig.core().online(1));
    CHECK(r.rig.drives()[0].drive().setpoint() == r.setpoint);
}

} // namespace

TEST_CASE("gateway Modbus side failure sweep", "[gateway][sweep]") {
    ferrule::test::failure_sweep<command_rig>(
        setpoint_command,
        [](command_rig& r, const command_outcome& o, std::size_t) {
            CHECK(o.stats.commands == 1);
            CHECK(o.stats.delivered == 0);
            CHECK(o.stats.failed == 1); // not resent: the host's port failed
            CHECK(r.rig.core().modbus().error() == injected);
            CHECK(o.inputs == octets(5, 0)); // drive_loss::clear: no reply invented
            CHECK_FALSE(r.rig.core().online(1));
        },
        delivered);
}

TEST_CASE("gateway Modbus side: a drive that answers too late and then in time",
          "[gateway][sweep]") {
    command_rig r;
    // Both attempts (retries = 1) are answered 300 ms late, after the 100 ms timeout of the
    // second one: the replies come while the gateway awaits none.
    r.rig.drives().delay_replies(2, 300ms);
    const command_outcome late = setpoint_command(r);
    CHECK(late.stats.failed == 1);
    CHECK(late.stats.delivered == 0);
    CHECK(r.rig.core().modbus().error() == errc::timeout);
    CHECK(late.inputs == octets(5, 0));
    CHECK_FALSE(r.rig.core().online(1));
    r.dp_line.advance(500ms); // the late replies arrive
    CHECK(r.rig.core().modbus().stats().stale_bytes == 2 * 8);
    delivered(r, setpoint_command(r));
}

namespace {

// The gateway's DP side as a station: what serve() and a mock_peer take.
struct dp_side {
    gw::core* gateway;
    void on_receive(std::span<const std::uint8_t> bytes, time_point end) {
        gateway->on_dp_receive(bytes, end);
    }
    session_action next(time_point now) { return gateway->next_dp(now); }
    time_point wake_at() const { return gateway->dp_wake_at(); }
};

// A station as the peer of a mock_serial, to bring it up with a master.
struct station_peer final : mock_peer {
    dp_side station;
    explicit station_peer(dp_side s) : station(s) {}
    void on_receive(mock_serial&, std::span<const std::uint8_t> bytes, time_point end) override {
        station.on_receive(bytes, end);
    }
    time_point wake_at() const noexcept override { return station.wake_at(); }
    void on_wake(mock_serial& line, time_point now) override {
        for (session_action a = station.next(now); a.what == session_action::kind::send;
             a = station.next(now))
            line.inject(a.bytes, now);
    }
};

// A Data_Exchange with no command (outputs all zero), as a master's first request to 8.
octets idle_exchange() {
    pb::master m{dp_master()};
    const std::array<std::uint8_t, 5> zero{};
    REQUIRE_FALSE(m.start_data_exchange(8, zero));
    const auto a = m.next(time_point{} + 1s);
    REQUIRE(a.what == session_action::kind::send);
    return {a.bytes.begin(), a.bytes.end()};
}

struct dp_rig {
    gw::core gateway{transparent()};
    mock_serial line{pb::format(187'500)};
    dp_rig() {
        station_peer peer{{&gateway}};
        mock_serial bring_up_line{pb::format(187'500), &peer};
        pb::master m{dp_master()};
        REQUIRE_FALSE(pb::bring_up(bring_up_line, m, 8, locked_no_watchdog(), cfg5));
        line.advance(bring_up_line.now() - time_point{} + 1s); // the gateway's time goes on
    }
};

test::served serve_idle_exchange(dp_rig& r) {
    dp_side station{&r.gateway};
    return test::serve_request(r.line, station, idle_exchange(), 20ms);
}

void answered_zeros(dp_rig& r, const test::served& s) {
    CHECK(s.errors == 0);
    // SD2 DL reply from 8 to 2 with the 5 input bytes, all zero.
    const octets dx_res{0x68, 0x08, 0x08, 0x68, 0x02, 0x08, 0x08, 0, 0, 0, 0, 0, 0x12, 0x16};
    CHECK(s.sent == dx_res);
    CHECK(r.gateway.dp().state() == pb::slave_state::data_exchange);
}

} // namespace

TEST_CASE("gateway DP side failure sweep", "[gateway][sweep]") {
    test::station_sweep<dp_rig>(serve_idle_exchange, answered_zeros);
}
