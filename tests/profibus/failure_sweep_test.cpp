// PROFIBUS-DP master, profibus::cycle and profibus::slave through every failure point of a
// Data_Exchange (tests/core/failure_sweep.hpp), a silent slave and the end of the stream,
// against slave 8 (2 input, 2 output bytes) brought up without a watchdog.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <vector>

#include "../core/failure_sweep.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/cycle.hpp"
#include "ferrule/profibus/sim/bus.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule::profibus;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::test::injected;

namespace {

using io = std::array<std::uint8_t, 2>;
const std::array<std::uint8_t, 2> cfg_2in_2out{0x11, 0x21};
constexpr io outputs{0x12, 0x34};
constexpr io slave_inputs{0xAB, 0xCD};
constexpr io untouched{0xEE, 0xEE};

slave_config slave_8() {
    slave_config c;
    c.address = 8;
    c.ident = 0x0815;
    c.cfg = cfg_2in_2out;
    return c;
}

prm_data locked_no_watchdog() {
    prm_data p;
    p.station_status = prm::lock_req;
    p.min_tsdr = 11;
    p.ident = 0x0815;
    return p;
}

struct master_rig {
    sim::bus<1> bus;
    mock_serial line{format(19200), &bus};
    master m;
    io in = untouched;
    master_stats before{};
    master_rig() {
        bus.add(slave_8())->set_inputs(slave_inputs);
        REQUIRE_FALSE(bring_up(line, m, 8, locked_no_watchdog(), cfg_2in_2out));
        before = m.stats();
    }
};

std::error_code exchange(master_rig& r) {
    r.in = untouched;
    return data_exchange(r.line, r.m, 8, outputs, r.in);
}

void exchanged(master_rig& r, std::error_code ec) {
    CHECK_FALSE(ec);
    CHECK(r.in == slave_inputs);
    CHECK(std::ranges::equal(r.bus[0].outputs(), outputs));
}

void nothing_exchanged(const master_rig& r, std::error_code ec, std::error_code expected) {
    CHECK(ec == expected);
    CHECK(r.m.error() == expected);
    CHECK_FALSE(r.m.busy());
    CHECK(r.in == untouched);
    CHECK(r.m.reply().empty());
    CHECK(r.m.stats().transactions == r.before.transactions + 1);
    CHECK(r.m.stats().succeeded == r.before.succeeded);
    CHECK(r.m.stats().failed == r.before.failed + 1);
}

} // namespace

TEST_CASE("profibus master failure sweep", "[profibus][master][sweep]") {
    ferrule::test::failure_sweep<master_rig>(
        exchange,
        [](master_rig& r, std::error_code ec, std::size_t) {
            nothing_exchanged(r, ec, injected);
            CHECK(r.m.attempts() <= 1); // 0: it failed while the line was kept idle (TSYN)
            CHECK(r.m.stats().resends == r.before.resends);
        },
        exchanged);
}

TEST_CASE("profibus master: a silent slave, then the end of the stream",
          "[profibus][master][sweep]") {
    master_rig r;
    r.bus.drop_replies(2); // the first attempt and the retry
    nothing_exchanged(r, exchange(r), errc::timeout);
    CHECK(r.m.attempts() == 2);
    CHECK(r.m.stats().timeouts == r.before.timeouts + 2);
    CHECK(r.m.stats().resends == r.before.resends + 1);
    exchanged(r, exchange(r));

    master_rig closed;
    closed.line.end_of_stream();
    nothing_exchanged(closed, exchange(closed), errc::transport);
    closed.line.end_of_stream(false);
    exchanged(closed, exchange(closed));
}

namespace {

struct cycle_rig {
    sim::bus<1> bus;
    mock_serial line{format(19200), &bus};
    master m;
    io in = untouched;
    std::array<cycle_slave, 1> slaves{};
    cycle c{m, slaves};
    ferrule::poll_driver<mock_serial, cycle> driver{line, c};
    cycle_rig() {
        bus.add(slave_8())->set_inputs(slave_inputs);
        slaves[0] = {.address = 8,
                     .prm = locked_no_watchdog(),
                     .cfg = cfg_2in_2out,
                     .outputs = outputs,
                     .inputs = in};
        REQUIRE(pass() == 1); // brought up and exchanging
    }
    // Steps the driver until the pass under way ends; the Data_Exchanges it carried.
    std::size_t pass() {
        in = untouched;
        REQUIRE(ferrule::test::step_until_next(
                    line, driver, [&] { return c.passes(); }, 100'000) == 1);
        return c.last_pass_exchanges();
    }
};

} // namespace

TEST_CASE("profibus cycle failure sweep", "[profibus][cycle][sweep]") {
    ferrule::test::failure_sweep<cycle_rig>(
        [](cycle_rig& r) { return r.pass(); },
        [](cycle_rig& r, std::size_t exchanged, std::size_t) {
            const cycle_slave& s = r.slaves[0];
            CHECK(exchanged == 0);
            CHECK(s.last_error == injected);
            CHECK(s.failures == 1);
            CHECK(s.exchanges == 1);   // the rig's pass only
            CHECK_FALSE(s.exchanging); // brought up again in the next pass
            CHECK(r.in == untouched);
            CHECK(r.c.error() == injected);
        },
        [](cycle_rig& r, std::size_t exchanged) {
            CHECK(exchanged == 1);
            CHECK(r.slaves[0].exchanging);
            CHECK(r.in == slave_inputs);
        },
        1);
}

namespace {

// Slave 8 as bring_up() leaves it: parametrized, configured, exchanging data.
slave exchanging_slave() {
    sim::bus<1> bus;
    mock_serial line{format(19200), &bus};
    bus.add(slave_8())->set_inputs(slave_inputs);
    master m;
    REQUIRE_FALSE(bring_up(line, m, 8, locked_no_watchdog(), cfg_2in_2out));
    return bus[0];
}

// A Data_Exchange as a master's first request to slave 8 sends it (FCV 0: no repeat).
std::vector<std::uint8_t> exchange_request() {
    master m;
    REQUIRE_FALSE(m.start_data_exchange(8, outputs));
    const auto a = m.next(ferrule::time_point{} + 1s);
    REQUIRE(a.what == ferrule::session_action::kind::send);
    return {a.bytes.begin(), a.bytes.end()};
}

struct station_rig {
    mock_serial line{format(19200)};
    slave st = exchanging_slave();
    station_rig() { line.advance(1s); } // past the bring-up's time on its own line
};

ferrule::test::served serve_exchange(station_rig& r) {
    return ferrule::test::serve_request(r.line, r.st, exchange_request(), 50ms);
}

void answered_inputs(station_rig& r, const ferrule::test::served& s) {
    // SD2 DL reply from 8 to 2 with the inputs (§B.9).
    const std::vector<std::uint8_t> dx_res_dl{0x68, 0x05, 0x05, 0x68, 0x02, 0x08,
                                              0x08, 0xAB, 0xCD, 0x8A, 0x16};
    CHECK(s.errors == 0);
    CHECK(s.sent == dx_res_dl);
    CHECK(std::ranges::equal(r.st.outputs(), outputs));
    CHECK(r.st.state() == slave_state::data_exchange);
}

} // namespace

TEST_CASE("profibus slave failure sweep", "[profibus][slave][sweep]") {
    ferrule::test::station_sweep<station_rig>(serve_exchange, answered_inputs);
}

TEST_CASE("profibus master: fault_threshold failed attempts in a row latch the fault",
          "[profibus][master][latch]") {
    master_rig r;
    master_config cfg;
    cfg.fault_threshold = 3;
    r.m = master(cfg); // retries 1: two attempts a transaction
    REQUIRE_FALSE(bring_up(r.line, r.m, 8, locked_no_watchdog(), cfg_2in_2out));
    r.bus.drop_replies(2);
    CHECK(exchange(r) == errc::timeout);
    CHECK(r.m.consecutive_failures() == 2);
    CHECK_FALSE(r.m.fault_latched());
    r.bus.drop_replies(1); // the 3rd failure in a row latches: no resend
    CHECK(exchange(r) == errc::timeout);
    CHECK(r.m.attempts() == 1);
    CHECK(r.m.fault_latched());
    const std::size_t writes = r.line.writes();
    CHECK(exchange(r) == errc::fault_latched);
    CHECK(r.in == untouched);
    CHECK(r.line.writes() == writes); // refused before anything was sent
    r.m.reset_fault();
    exchanged(r, exchange(r));
    CHECK_FALSE(r.m.fault_latched());
}
