// A class-1 master cycling three DP-V0 slaves on one simulated line (profibus::sim::bus), in
// virtual time, stepped by poll_driver as a super-loop does: all brought to Data_Exchange,
// I/O both ways, a slave with the wrong ident or locked to another master kept out, DH
// answered by a diagnosis read, a slave that stops answering brought back, and a wait for
// the first retry when no slave can run.
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/profibus/cycle.hpp"
#include "ferrule/profibus/sim/bus.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule;
namespace pb = ferrule::profibus;

namespace {

const std::array<std::uint8_t, 2> cfg_a{0x11, 0x21}; // 2 in, 2 out
const std::array<std::uint8_t, 1> cfg_b{0x33};       // 4 in, 4 out
const std::array<std::uint8_t, 1> cfg_c{0x10};       // 1 in

pb::slave_config slave(std::uint8_t address, std::uint16_t ident,
                       std::span<const std::uint8_t> cfg) {
    pb::slave_config c;
    c.baud = 187'500;
    c.address = address;
    c.ident = ident;
    c.cfg = cfg;
    return c;
}

pb::prm_data prm(std::uint16_t ident) {
    pb::prm_data p;
    p.station_status = pb::prm::lock_req | pb::prm::wd_on;
    p.wd_fact1 = 10;
    p.wd_fact2 = 10;
    p.ident = ident;
    return p;
}

struct line3 {
    pb::sim::bus<3> bus;
    mock_serial line{pb::format(187'500), &bus};
    pb::master master{[] {
        pb::master_config c;
        c.format = pb::format(187'500);
        return c;
    }()};
    std::array<std::uint8_t, 2> out_a{0x12, 0x34};
    std::array<std::uint8_t, 4> out_b{1, 2, 3, 4};
    std::array<std::uint8_t, 2> in_a{};
    std::array<std::uint8_t, 4> in_b{};
    std::array<std::uint8_t, 1> in_c{};
    std::array<pb::cycle_slave, 3> slaves{};
    pb::cycle cycle{master, slaves};
    poll_driver<mock_serial, pb::cycle> driver{line, cycle};

    explicit line3(std::uint16_t ident_c_expected = 0x0C00) {
        bus.add(slave(5, 0x0A00, cfg_a));
        bus.add(slave(6, 0x0B00, cfg_b));
        bus.add(slave(7, 0x0C00, cfg_c));
        slaves[0] = {
            .address = 5, .prm = prm(0x0A00), .cfg = cfg_a, .outputs = out_a, .inputs = in_a};
        slaves[1] = {
            .address = 6, .prm = prm(0x0B00), .cfg = cfg_b, .outputs = out_b, .inputs = in_b};
        slaves[2] = {.address = 7,
                     .prm = prm(ident_c_expected),
                     .cfg = cfg_c,
                     .outputs = {},
                     .inputs = in_c};
    }
    // Steps the super-loop until the pass under way ends; the Data_Exchanges it carried.
    std::size_t pass() {
        const auto passes = cycle.passes();
        const time_point limit = line.now() + 5s;
        while (cycle.passes() == passes && before(line.now(), limit)) {
            driver.step();
            line.advance(20us); // the rest of the main loop
        }
        REQUIRE(cycle.passes() == passes + 1);
        return cycle.last_pass_exchanges();
    }
};

} // namespace

TEST_CASE("profibus master cycle brings three slaves up and exchanges their I/O",
          "[profibus][cycle]") {
    line3 l;
    const std::array<std::uint8_t, 2> a_in{0xAB, 0xCD};
    const std::array<std::uint8_t, 4> b_in{9, 8, 7, 6};
    const std::array<std::uint8_t, 1> c_in{0x5A};
    l.bus[0].set_inputs(a_in);
    l.bus[1].set_inputs(b_in);
    l.bus[2].set_inputs(c_in);
    CHECK(l.pass() == 3);
    for (std::size_t i = 0; i < 3; ++i) {
        CHECK(l.bus[i].state() == pb::slave_state::data_exchange);
        CHECK(l.slaves[i].bring_ups == 1);
        CHECK(l.bus[i].master_address() == 2);
    }
    CHECK(l.in_a == a_in);
    CHECK(l.in_b == b_in);
    CHECK(l.in_c == c_in);
    CHECK(l.bus[0].outputs()[1] == 0x34);
    CHECK(l.bus[1].outputs()[3] == 4);
    for (int i = 0; i < 10; ++i) CHECK(l.pass() == 3);
    CHECK(l.slaves[1].exchanges == 11);
    CHECK(l.slaves[1].failures == 0);
}

TEST_CASE("profibus master cycle keeps a slave with the wrong ident out, the others run",
          "[profibus][cycle]") {
    line3 l(0x0C01); // the master expects 0x0C01; slave 7 is 0x0C00
    CHECK(l.pass() == 2);
    CHECK_FALSE(l.slaves[2].exchanging);
    CHECK(l.slaves[2].last_error == pb::device_errc::prm_fault);
    CHECK((l.bus[2].diagnosis().status1 & pb::diag::prm_fault) != 0);
    // Not tried again before retry_after.
    const auto tries = l.slaves[2].bring_ups;
    CHECK(l.pass() == 2);
    CHECK(l.slaves[2].bring_ups == tries);
}

TEST_CASE("profibus master cycle reads the diagnosis a DH reply announces", "[profibus][cycle]") {
    line3 l;
    REQUIRE(l.pass() == 3);
    const std::array<std::uint8_t, 3> block{0x03, 0x00, 0x01};
    l.bus[1].set_ext_diag(block, true);
    CHECK(l.pass() == 3);
    CHECK(l.slaves[1].diag_reads == 1);
    CHECK((l.slaves[1].diag.status1 & pb::diag::ext_diag) != 0);
    CHECK(l.slaves[1].exchanging); // still ready: it goes on
    CHECK(l.pass() == 3);
    CHECK(l.slaves[1].diag_reads == 1);
}

TEST_CASE("profibus master cycle brings back a slave that stopped answering", "[profibus][cycle]") {
    line3 l;
    REQUIRE(l.pass() == 3);
    l.bus.drop_replies(2); // slave 5's next reply and its repeat are lost
    CHECK(l.pass() == 2);
    CHECK_FALSE(l.slaves[0].exchanging);
    CHECK(l.slaves[0].last_error == errc::timeout);
    CHECK(l.pass() == 3);
    CHECK(l.slaves[0].bring_ups == 2);
    CHECK(l.slaves[0].exchanging);
}

TEST_CASE("profibus master cycle keeps a slave locked to another master out",
          "[profibus][cycle][lock]") {
    line3 l;
    pb::master_config c3;
    c3.format = pb::format(187'500);
    c3.address = 3;
    pb::master other(c3);
    REQUIRE_FALSE(pb::bring_up(l.line, other, 6, prm(0x0B00), cfg_b));
    CHECK(l.pass() == 2);
    CHECK_FALSE(l.slaves[1].exchanging);
    CHECK(l.slaves[1].last_error == pb::device_errc::master_lock);
    CHECK(l.bus[1].master_address() == 3);
    CHECK(l.slaves[1].bring_ups == 1);
}

TEST_CASE("profibus master cycle waits for the first retry when no slave can run",
          "[profibus][cycle]") {
    line3 l(0x0C01);
    l.slaves[0].address = 20; // no station there
    l.slaves[1].prm.ident = 0x0B01;
    pb::cycle c(l.master, l.slaves, {.retry_after = 300ms, .diag_polls = 2});
    poll_driver<mock_serial, pb::cycle> driver(l.line, c);
    const time_point limit = l.line.now() + 2s;
    while (c.passes() == 0 && before(l.line.now(), limit)) {
        driver.step();
        l.line.advance(20us);
    }
    REQUIRE(c.passes() == 1);
    CHECK(c.last_pass_exchanges() == 0);
    CHECK(l.slaves[0].last_error == errc::timeout);
    CHECK(l.slaves[1].last_error == pb::device_errc::prm_fault);
    CHECK(l.slaves[2].last_error == pb::device_errc::prm_fault);
    // Nothing to send: the session waits for slave 20's retry, the earliest.
    const session_action a = c.next(l.line.now());
    REQUIRE(a.what == session_action::kind::wait);
    CHECK(a.deadline == l.slaves[0].retry_at);
    const std::size_t written = l.line.wire().size();
    CHECK(driver.step() == session_action::kind::wait);
    CHECK(l.line.wire().size() == written);
    l.line.advance(a.deadline - l.line.now());
    CHECK(driver.step() == session_action::kind::send);
    CHECK(l.line.wire().size() > written);
    CHECK(l.slaves[0].bring_ups == 2);
}
