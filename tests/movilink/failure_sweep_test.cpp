// MOVILINK master, movilink::cyclic and the simulated station (movilink::slave + MOVITRAC B)
// through every failure point of a transaction (tests/core/failure_sweep.hpp), a silent drive
// and the end of the stream.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>

#include "../core/failure_sweep.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/host/serve.hpp"
#include "ferrule/movilink/access.hpp"
#include "ferrule/movilink/cyclic.hpp"
#include "ferrule/movilink/sim/bus.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule::movilink;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::result;
using ferrule::test::injected;

namespace {

constexpr std::uint16_t p014 = 0x2087; // heat sink temperature, 20 degC in the simulated drive

struct master_rig {
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    master m;
    master_rig() { bus.add(); }
};

result<std::uint32_t> read_p014(master_rig& r) {
    return read_parameter(r.line, r.m, 1, p014);
}

void read_20_degrees(master_rig& r, const result<std::uint32_t>& v) {
    REQUIRE(v);
    CHECK(*v == 20);
    CHECK_FALSE(r.m.error());
}

} // namespace

TEST_CASE("movilink master failure sweep", "[movilink][master][sweep]") {
    ferrule::test::failure_sweep<master_rig>(
        read_p014,
        [](master_rig& r, const result<std::uint32_t>& v, std::size_t k) {
            ferrule::test::ended_at_failure(r.line, r.m, k);
            REQUIRE_FALSE(v);
            CHECK(v.error() == injected);
            CHECK(r.m.attempts() <= 1); // 0: it failed during the start pause; never resent
            CHECK(r.m.reply() == telegram{});
            CHECK_FALSE(r.m.fault_latched());
        },
        read_20_degrees);
}

TEST_CASE("movilink master: a silent drive, resends, the fault latch and a reset",
          "[movilink][master][sweep]") {
    master_rig r;
    r.bus.drop_replies(5); // the first attempt and the 4 resends
    const auto v = read_p014(r);
    REQUIRE_FALSE(v);
    CHECK(v.error() == errc::timeout);
    CHECK(r.m.attempts() == 5);
    CHECK(r.m.stats().timeouts == 5);
    CHECK(r.m.stats().resends == 4);
    CHECK(r.m.stats().failed == 1);
    CHECK(r.m.reply() == telegram{});
    CHECK(r.m.fault_latched()); // 5 failed attempts in a row (fault_threshold)
    CHECK(read_p014(r).error() == errc::fault_latched);
    r.m.reset_fault();
    read_20_degrees(r, read_p014(r));
    CHECK(r.m.consecutive_failures() == 0);
}

TEST_CASE("movilink master: the end of the stream ends the transaction",
          "[movilink][master][sweep]") {
    master_rig r;
    r.line.end_of_stream();
    const auto v = read_p014(r);
    REQUIRE_FALSE(v);
    CHECK(v.error() == errc::transport);
    CHECK(r.m.attempts() <= 1);
    CHECK(r.m.stats().failed == 1);
    CHECK(r.m.reply() == telegram{});
    CHECK_FALSE(r.m.fault_latched());
    r.line.end_of_stream(false);
    read_20_degrees(r, read_p014(r));
}

namespace {

struct cyclic_rig {
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    master m;
    cyclic c{m, 1};
    ferrule::poll_driver<mock_serial, cyclic> driver{line, c};
    cyclic_rig() { bus.add(); }
};

// Steps the driver until the next cycle has finished.
std::uint32_t one_cycle(cyclic_rig& r) {
    return ferrule::test::step_until_next(r.line, r.driver, [&] { return r.c.cycles(); });
}

// PI of a drive whose PO are all 0: status word 1 "ready, PO data enabled, no enable"
// (unit status 2), 0 rpm, 0 % current.
void no_enable_pi(cyclic_rig& r, std::uint32_t cycles) {
    CHECK(cycles == 1);
    CHECK_FALSE(r.c.error());
    CHECK(r.c.pi(0) == 0x0206);
    CHECK(r.c.pi(1) == 0);
    CHECK(r.c.pi(2) == 0);
}

} // namespace

TEST_CASE("movilink cyclic failure sweep", "[movilink][cyclic][sweep]") {
    ferrule::test::failure_sweep<cyclic_rig>(
        one_cycle,
        [](cyclic_rig& r, std::uint32_t cycles, std::size_t) {
            CHECK(cycles == 1);
            CHECK(r.c.error() == injected);
            CHECK(r.c.failed_cycles() == 1);
            for (std::size_t i = 0; i < 3; ++i) CHECK(r.c.pi(i) == 0); // nothing invented
            CHECK(r.m.stats().resends == 0);
            CHECK_FALSE(r.m.fault_latched());
        },
        no_enable_pi, 1);
}

TEST_CASE("movilink cyclic: a transport error in the cycle just started is not the last one's",
          "[movilink][cyclic][sweep]") {
    const std::size_t n = [] {
        cyclic_rig r;
        one_cycle(r);
        return r.line.io_operations();
    }();
    cyclic_rig r;
    r.line.fail_at(n, injected); // the next cycle's first operation
    no_enable_pi(r, one_cycle(r));
    CHECK(one_cycle(r) == 1);
    CHECK(r.c.error() == injected);
    CHECK(r.c.failed_cycles() == 1);
    no_enable_pi(r, one_cycle(r));
}

namespace {

struct station_rig {
    mock_serial line{default_format};
    sim::station st{slave_config{}};
};

// A 3PD exchange for drive 1 (SC01 Fig. 23, M2).
const std::array<std::uint8_t, 10> m2_req{0x02, 0x01, 0x85, 0x00, 0x06,
                                          0x20, 0x00, 0x0B, 0xB8, 0x13};

ferrule::test::served exchange_m2(station_rig& r) {
    return ferrule::test::serve_request(r.line, r.st, m2_req, 100ms);
}

void answered_m2(station_rig&, const ferrule::test::served& s) {
    CHECK(s.errors == 0);
    const auto reply = parse(s.sent);
    REQUIRE(reply);
    CHECK(reply->dir == direction::response);
    CHECK(reply->address == 1);
    CHECK(reply->type == pdu_type::pd3_acyclic);
}

} // namespace

TEST_CASE("movilink station failure sweep", "[movilink][slave][sweep]") {
    ferrule::test::station_sweep<station_rig>(exchange_m2, answered_m2);
}
