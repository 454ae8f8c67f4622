// The PROFIBUS-DP slave and the DP ↔ Modbus gateway never allocate: the slave through
// Set_Prm, Chk_Cfg and 100 Data_Exchanges, and gateway::core (transparent mode) running
// commands from a DP master to a simulated drive (gateway::sim::rig), with the counting
// global operator new of counting_new.hpp, and the count must not move.
#include <catch2/catch.hpp>

#include <array>
#include <atomic>
#include <cstddef>
#include <memory>
#include <vector>

#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/gateway/sim/rig.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/slave.hpp"

// The counter of counting_new.hpp, whose operator new may be defined in one file only
// (no_heap_test.cpp): an inline variable, so this identical declaration names the same one.
namespace ferrule_test {
inline std::atomic<std::size_t> allocations{0};
} // namespace ferrule_test

using namespace std::chrono_literals;
using namespace ferrule;
namespace pb = ferrule::profibus;
namespace mb = ferrule::modbus;
namespace gw = ferrule::gateway;

namespace {

using octets = std::vector<std::uint8_t>;

// Master 2 to slave 8 (§B.9).
octets request(std::uint8_t fc, std::uint8_t dsap, const octets& du) {
    pb::telegram t;
    t.da = 8;
    t.sa = 2;
    t.fc = fc;
    t.dsap = dsap;
    t.ssap = dsap == pb::no_sap ? pb::no_sap : pb::master_sap;
    t.data = du;
    octets out(pb::max_telegram);
    out.resize(*pb::encode(t, out));
    return out;
}

} // namespace

TEST_CASE("PROFIBUS slave start-up and data exchange allocate nothing", "[alloc][profibus]") {
    // Every telegram is built before counting starts.
    const octets cfg{0x11, 0x21};
    pb::prm_data p;
    p.station_status = pb::prm::lock_req | pb::prm::wd_on;
    p.wd_fact1 = 10;
    p.wd_fact2 = 10;
    p.ident = 0x0815;
    octets prm_du(pb::max_data);
    prm_du.resize(*pb::encode_prm(p, prm_du));
    const auto fc = [](bool fcb, bool fcv) {
        return pb::request_code(pb::request_fn::srd_high, fcb, fcv);
    };
    std::vector<octets> reqs;
    reqs.push_back(request(fc(true, false), static_cast<std::uint8_t>(pb::sap::set_prm), prm_du));
    reqs.push_back(request(fc(false, true), static_cast<std::uint8_t>(pb::sap::chk_cfg), cfg));
    for (int i = 0; i < 100; ++i)
        reqs.push_back(request(fc(i % 2 == 0, true), pb::no_sap,
                               {static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(~i)}));
    pb::slave_config c;
    c.address = 8;
    c.ident = 0x0815;
    c.cfg = cfg;
    auto s = std::make_unique<pb::slave>(c);
    const std::array<std::uint8_t, 2> inputs{0xAB, 0xCD};

    // The counter is the one operator new counts.
    const auto probe_before = ferrule_test::allocations.load();
    auto probe = std::make_unique<int>(1);
    REQUIRE(ferrule_test::allocations.load() == probe_before + 1);

    std::size_t replies = 0;
    time_point now{};
    const auto before = ferrule_test::allocations.load();
    for (const octets& req : reqs) {
        now += 2ms;
        s->set_inputs(inputs);
        s->on_receive(req, now);
        // The reply is due after min TSDR; a later deadline is the watchdog's.
        for (auto a = s->next(now); a.what != session_action::kind::idle; a = s->next(now)) {
            if (a.what == session_action::kind::send) {
                ++replies;
                continue;
            }
            if (a.deadline >= now + 5ms) break;
            now = a.deadline;
        }
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(replies == reqs.size());
    CHECK(s->state() == pb::slave_state::data_exchange);
    CHECK(s->stats().data_exchanges == 100);
    CHECK(s->outputs()[0] == 99);
}

TEST_CASE("the DP to Modbus gateway allocates nothing in transparent mode", "[alloc][gateway]") {
    // 5 octets out, 5 octets in: a Modbus request PDU and its reply (seeds/002).
    const octets cfg5{0x24, 0x14};
    const std::array<gw::safe_write, 1> stop{{{1, mb::sim::vfd_register::control_word, 0}}};
    gw::config c;
    c.dp.baud = 19'200;
    c.dp.address = 8;
    c.dp.ident = 0x0F2A;
    c.dp.cfg = cfg5;
    c.modbus.format = {19'200, 8, parity::even, 1};
    c.modbus.inter_frame_gap = mb::t35(c.modbus.format);
    c.modbus.response_timeout = 100ms;
    c.safe_writes = stop;
    auto rig = std::make_unique<gw::sim::rig<2>>(c);
    mb::server_config drive;
    drive.units = {1};
    drive.format = c.modbus.format;
    REQUIRE(rig->drives().add(drive));
    auto dp_line = std::make_unique<mock_serial>(pb::format(19'200), rig.get());
    pb::master_config mc;
    mc.format = pb::format(19'200);
    mc.address = 2;
    auto master = std::make_unique<pb::master>(mc);
    pb::prm_data p;
    p.station_status = pb::prm::lock_req | pb::prm::wd_on;
    p.wd_fact1 = 10;
    p.wd_fact2 = 10;
    p.ident = 0x0F2A;
    // Start, a setpoint, stop: FC 6 to the control word and the setpoint (seeds/002).
    const std::array<std::array<std::uint8_t, 5>, 3> commands{{{0x06, 0xC8, 0x00, 0x00, 0x25},
                                                               {0x06, 0xC8, 0x01, 0x13, 0x88},
                                                               {0x06, 0xC8, 0x00, 0x00, 0x00}}};

    const auto probe_before = ferrule_test::allocations.load();
    auto probe = std::make_unique<int>(1);
    REQUIRE(ferrule_test::allocations.load() == probe_before + 1);

    std::size_t failures = 0;
    std::size_t echoed = 0;
    const auto before = ferrule_test::allocations.load();
    failures += static_cast<bool>(pb::bring_up(*dp_line, *master, 8, p, cfg5));
    for (const auto& cmd : commands) {
        std::array<std::uint8_t, 5> in{};
        for (int cycle = 0; cycle < 20 && in != cmd; ++cycle)
            failures += static_cast<bool>(pb::data_exchange(*dp_line, *master, 8, cmd, in));
        echoed += in == cmd;
        dp_line->clear_wire_log();
        rig->drive_line().clear_wire_log();
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(failures == 0);
    CHECK(echoed == commands.size());
    CHECK(rig->core().stats().delivered == commands.size());
    CHECK(rig->drives()[0].drive().control_word() == 0x0000);
}
