// LECOM master, poller and the simulated station (lecom::slave + Lenze drive) through every
// failure point of a transaction (tests/core/failure_sweep.hpp), a silent drive and the end
// of the stream.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>

#include "../core/failure_sweep.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/lecom/access.hpp"
#include "ferrule/lecom/poller.hpp"
#include "ferrule/lecom/sim/bus.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule::lecom;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::result;
using ferrule::test::injected;
namespace cn = ferrule::lecom::sim::code_number;

namespace {

constexpr std::int32_t setpoint = 1500 * value::scale; // C0046 of drive 1

struct master_rig {
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    master m;
    master_rig() { bus.add()->drive.preset(cn::c0046_speed_setpoint, setpoint); }
};

result<value> read_c0046(master_rig& r) {
    return read(r.line, r.m, 1, code(cn::c0046_speed_setpoint));
}

void read_setpoint(master_rig& r, const result<value>& v) {
    REQUIRE(v);
    CHECK(v->fixed == setpoint);
    CHECK_FALSE(r.m.error());
}

void nothing_read(const master_rig& r, const result<value>& v, std::error_code expected) {
    CHECK_FALSE(v);
    CHECK(v.error() == expected);
    CHECK(r.m.reply().value.fixed == 0);
    ferrule::test::failed_once(r.m, expected);
}

} // namespace

TEST_CASE("lecom master failure sweep", "[lecom][master][sweep]") {
    ferrule::test::failure_sweep<master_rig>(
        read_c0046,
        [](master_rig& r, const result<value>& v, std::size_t k) {
            ferrule::test::ended_at_failure(r.line, r.m, k);
            nothing_read(r, v, injected);
            CHECK(r.m.attempts() == 1); // not resent
        },
        read_setpoint);
}

TEST_CASE("lecom master: a silent drive is asked 3 times", "[lecom][master][sweep]") {
    master_rig r;
    r.bus.drop_replies(3); // the first attempt and the 2 resends
    const auto v = read_c0046(r);
    nothing_read(r, v, errc::timeout);
    CHECK(r.m.attempts() == 3);
    CHECK(r.m.stats().timeouts == 3);
    CHECK(r.m.stats().resends == 2);
    read_setpoint(r, read_c0046(r));
}

TEST_CASE("lecom master: the end of the stream ends the transaction", "[lecom][master][sweep]") {
    master_rig r;
    r.line.end_of_stream();
    const auto v = read_c0046(r);
    nothing_read(r, v, errc::transport);
    CHECK(r.m.attempts() == 1);
    r.line.end_of_stream(false);
    read_setpoint(r, read_c0046(r));
}

namespace {

struct poller_rig {
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    poller<> p;
    ferrule::poll_driver<mock_serial, poller<>> driver{line, p};
    poller_rig() {
        bus.add()->drive.preset(cn::c0046_speed_setpoint, setpoint);
        REQUIRE(p.add({1, code(cn::c0046_speed_setpoint)}));
    }
};

// Steps the driver until the next transaction has finished.
std::uint32_t one_poll(poller_rig& r) {
    return ferrule::test::step_until_next(r.line, r.driver, [&] { return r.p.completed(); });
}

void polled_setpoint(poller_rig& r, std::uint32_t completed) {
    CHECK(completed == 1);
    CHECK_FALSE(r.p.error());
    CHECK(r.p.state(0).valid);
    CHECK(r.p.state(0).last.fixed == setpoint);
    CHECK(r.p.drive(1)->online);
}

} // namespace

TEST_CASE("lecom poller failure sweep", "[lecom][poller][sweep]") {
    ferrule::test::failure_sweep<poller_rig>(
        one_poll,
        [](poller_rig& r, std::uint32_t completed, std::size_t) {
            CHECK(completed == 1);
            CHECK(r.p.error() == injected);
            const item_state& s = r.p.state(0);
            CHECK(s.error == injected);
            CHECK_FALSE(s.valid);
            CHECK(s.last.fixed == 0); // nothing invented
            CHECK(s.failures == 1);
            const drive_state& d = *r.p.drive(1);
            CHECK(d.failures == 1);
            CHECK(d.misses == 0);                      // the host's port failed, not the drive
            CHECK(r.p.session().stats().resends == 0); // not resent
            CHECK(r.p.session().stats().failed == 1);
        },
        polled_setpoint, 1);
}

TEST_CASE("lecom poller: a silent drive goes offline and comes back", "[lecom][poller][sweep]") {
    poller_rig r;
    r.bus.drop_replies(3 * 3); // 3 transactions of 3 attempts (offline_after)
    for (int i = 0; i < 3; ++i) {
        CHECK(one_poll(r) == 1);
        CHECK(r.p.error() == errc::timeout);
    }
    CHECK(r.p.session().stats().timeouts == 9);
    CHECK(r.p.session().stats().resends == 6);
    CHECK_FALSE(r.p.drive(1)->online);
    CHECK(r.p.drive(1)->misses == 3);
    CHECK_FALSE(r.p.state(0).valid);
    CHECK(r.p.state(0).last.fixed == 0);
    polled_setpoint(r, one_poll(r));
}

namespace {

struct station_rig {
    mock_serial line{default_format};
    sim::station st{slave_config{}};
    station_rig() { st.drive.preset(cn::c0046_speed_setpoint, setpoint); }
};

// RECEIVE C0046 of drive 1: EOT "01" "46" ENQ.
const std::array<std::uint8_t, 6> read_request{0x04, '0', '1', '4', '6', 0x05};

ferrule::test::served serve_read(station_rig& r) {
    return ferrule::test::serve_request(r.line, r.st, read_request, 100ms);
}

void answered_setpoint(station_rig&, const ferrule::test::served& s) {
    CHECK(s.errors == 0);
    const auto reply = parse_reply(s.sent);
    REQUIRE(reply);
    CHECK(reply->kind == frame_kind::data);
    CHECK(reply->code == code(cn::c0046_speed_setpoint));
    CHECK(reply->value.fixed == setpoint);
}

} // namespace

TEST_CASE("lecom station failure sweep", "[lecom][slave][sweep]") {
    ferrule::test::station_sweep<station_rig>(serve_read, answered_setpoint);
}

TEST_CASE("lecom master: fault_threshold failed attempts in a row latch the fault",
          "[lecom][master][latch]") {
    master_rig r;
    r.m = master(master_config{.fault_threshold = 4});
    r.bus.drop_replies(3); // the first read: 3 attempts, 3 failures in a row
    CHECK(read_c0046(r).error() == errc::timeout);
    CHECK(r.m.consecutive_failures() == 3);
    CHECK_FALSE(r.m.fault_latched());
    r.bus.drop_replies(1); // the 4th failure in a row latches: no resend
    CHECK(read_c0046(r).error() == errc::timeout);
    CHECK(r.m.attempts() == 1);
    CHECK(r.m.fault_latched());
    const std::size_t writes = r.line.writes();
    CHECK(read_c0046(r).error() == errc::fault_latched);
    CHECK(r.line.writes() == writes); // refused before anything was sent
    r.m.reset_fault();
    CHECK(r.m.consecutive_failures() == 0);
    read_setpoint(r, read_c0046(r));

    r.bus.drop_replies(2); // a success clears the count: 2 + 2 failures latch nothing
    read_setpoint(r, read_c0046(r));
    r.bus.drop_replies(2);
    read_setpoint(r, read_c0046(r));
    CHECK_FALSE(r.m.fault_latched());
}

TEST_CASE("lecom poller: its master's latch never stops the polls, the live list does",
          "[lecom][poller][latch]") {
    sim::bus<1> bus;
    bus.add()->drive.preset(cn::c0046_speed_setpoint, setpoint);
    mock_serial line{default_format, &bus};
    poller_config cfg;
    cfg.master.fault_threshold = 1;
    poller<> p{cfg};
    REQUIRE(p.add({1, code(cn::c0046_speed_setpoint)}));
    ferrule::poll_driver<mock_serial, poller<>> driver{line, p};
    const auto one_poll = [&] {
        return ferrule::test::step_until_next(line, driver, [&] { return p.completed(); });
    };

    bus.drop_replies(1); // one failed attempt latches the master: this poll is not resent
    CHECK(one_poll() == 1);
    CHECK(p.error() == errc::timeout);
    CHECK(p.session().attempts() == 1);
    CHECK(one_poll() == 1); // the next poll goes out all the same, and is answered
    CHECK_FALSE(p.error());
    CHECK_FALSE(p.session().fault_latched());
    CHECK(p.state(0).last.fixed == setpoint);
}
