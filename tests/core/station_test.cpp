// The station contract (core/station.hpp) held against every slave, server and simulated
// device, and station_driver (core/driver.hpp) serving a LECOM slave on a mock_serial line
// whose master side the test plays: request bytes put on the line, the reply read off its log.
#include <catch2/catch.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <span>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/core/queued_reply.hpp"
#include "ferrule/core/static_buffer.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/dimetix/sim/sensor.hpp"
#include "ferrule/lecom/poller.hpp"
#include "ferrule/lecom/sim/station.hpp"
#include "ferrule/lecom/slave.hpp"
#include "ferrule/lecom/value.hpp"
#include "ferrule/modbus/memory_model.hpp"
#include "ferrule/modbus/server.hpp"
#include "ferrule/modbus/sim/station.hpp"
#include "ferrule/movilink/sim/station.hpp"
#include "ferrule/movilink/slave.hpp"
#include "ferrule/profibus/slave.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace ferrule;
using namespace std::chrono_literals;

static_assert(station<modbus::server<modbus::memory_model<8, 8, 8, 8>>>);
static_assert(station<modbus::server<modbus::memory_model<8, 8, 8, 8>, modbus::link_mode::rtu>>);
static_assert(station<lecom::slave>);
static_assert(station<movilink::slave>);
static_assert(station<profibus::slave>);
static_assert(station<lecom::sim::station>);
static_assert(station<movilink::sim::station>);
static_assert(station<modbus::sim::station>);
static_assert(station<dimetix::sim::d_series>);
// The poll scheduler is a master: it has no wake-up time of its own to offer.
static_assert(!station<lecom::poller<>>);
static_assert(master_session<lecom::poller<>>);

namespace {

using byte_vector = std::vector<std::uint8_t>;

// lecom.md §4.1: #1 read C46 at drive 01, #2 its reply 35.4.
const byte_vector read_c46_at_01{0x04, 0x30, 0x31, 0x34, 0x36, 0x05};
const byte_vector reply_c46_35_4{0x02, 0x34, 0x36, 0x33, 0x35, 0x2E, 0x34, 0x03, 0x1D};

// What the station put on the line, in order.
byte_vector sent_by_station(const mock_serial& line) {
    byte_vector out;
    for (const wire_byte& b : line.wire())
        if (b.origin == wire_byte::from::session) out.push_back(b.value);
    return out;
}

// The application of a firmware super-loop: answers every RECEIVE of C46 with 35.4.
void answer(lecom::slave& s) {
    if (!s.has_request()) return;
    REQUIRE(s.request().code == lecom::code(46));
    REQUIRE_FALSE(s.respond({lecom::frame_kind::data, 0, lecom::code(46),
                             *lecom::parse_value(std::string_view("35.4"))}));
}

} // namespace

TEST_CASE("station_driver: a slave in a super-loop answers processing_time after the request",
          "[core][station][driver]") {
    mock_serial line(lecom::default_format);
    lecom::slave slave;
    station_driver driver(line, slave);

    // Nothing heard, nothing due: a step neither waits nor writes.
    const time_point t0 = line.now();
    CHECK_FALSE(driver.step());
    CHECK(line.now() == t0);
    CHECK(line.writes() == 0);

    line.inject(read_c46_at_01, t0 + 1ms);
    const time_point request_end = t0 + 1ms + lecom::default_format.chars_time(6);
    line.sleep_until(request_end);
    CHECK_FALSE(driver.step());
    REQUIRE(slave.has_request());
    CHECK(slave.request_end() == request_end);
    answer(slave);

    // The reply waits for its time: steps before it write nothing.
    CHECK(slave.wake_at() == request_end + lecom::processing_time);
    CHECK_FALSE(driver.step());
    CHECK(line.writes() == 0);
    line.sleep_until(slave.wake_at() - 1ms);
    CHECK_FALSE(driver.step());
    CHECK(line.writes() == 0);

    line.sleep_until(slave.wake_at());
    CHECK_FALSE(driver.step());
    CHECK(sent_by_station(line) == reply_c46_35_4);
    REQUIRE_FALSE(line.wire().empty());
    CHECK(line.wire()[line.wire().size() - reply_c46_35_4.size()].start ==
          request_end + lecom::processing_time);
    CHECK(slave.wake_at() == never);
    CHECK(slave.stats().replies == 1);
}

TEST_CASE("station_driver: a write that fails is the step's error, the next request is served",
          "[core][station][driver]") {
    mock_serial line(lecom::default_format);
    lecom::slave slave;
    station_driver driver(line, slave);

    line.inject(read_c46_at_01, line.now());
    line.sleep_until(line.now() + lecom::default_format.chars_time(6));
    CHECK_FALSE(driver.step());
    answer(slave);
    line.sleep_until(slave.wake_at());
    line.fail_at(2); // a step reads (operation 1), then writes the due reply (operation 2)
    CHECK(driver.step() == errc::transport);
    CHECK(line.writes() == 0);
    CHECK(sent_by_station(line).empty());

    line.inject(read_c46_at_01, line.now() + 5ms);
    line.sleep_until(line.now() + 5ms + lecom::default_format.chars_time(6));
    CHECK_FALSE(driver.step());
    answer(slave);
    line.sleep_until(slave.wake_at());
    CHECK_FALSE(driver.step());
    CHECK(sent_by_station(line) == reply_c46_35_4);
}

TEST_CASE("queued_reply: waits for its time, goes out once, or is dropped",
          "[core][station][queued_reply]") {
    queued_reply<4> reply;
    CHECK(reply.next(time_point{}).what == session_action::kind::idle);
    CHECK(reply.due() == never);
    reply.buffer()[0] = 0xAA;
    reply.buffer()[1] = 0xBB;
    const time_point due = time_point{} + 20ms;
    reply.queue(2, due);
    CHECK(reply.due() == due);
    const session_action early = reply.next(due - 1ms);
    CHECK(early.what == session_action::kind::wait);
    CHECK(early.deadline == due);
    const session_action a = reply.next(due);
    REQUIRE(a.what == session_action::kind::send);
    CHECK(byte_vector(a.bytes.begin(), a.bytes.end()) == byte_vector{0xAA, 0xBB});
    CHECK_FALSE(a.discard_input);
    CHECK(reply.next(due).what == session_action::kind::idle);

    reply.queue(1, due);
    reply.drop();
    CHECK(reply.due() == never);
    CHECK(reply.next(due + 1s).what == session_action::kind::idle);
}

TEST_CASE("held_bytes: keeps what fits with the latest end, hands it over once",
          "[core][station][held_bytes]") {
    held_bytes<4> held;
    CHECK(held.empty());
    const byte_vector first{1, 2, 3};
    const byte_vector second{4, 5, 6};
    CHECK(held.hold(first, time_point{} + 1ms) == 0);
    CHECK(held.hold(second, time_point{} + 2ms) == 2); // 5 and 6 do not fit
    CHECK(held.end() == time_point{} + 2ms);
    byte_vector released;
    time_point end{};
    held.release([&](std::span<const std::uint8_t> in, time_point t) {
        released.assign(in.begin(), in.end());
        end = t;
    });
    CHECK(released == byte_vector{1, 2, 3, 4});
    CHECK(end == time_point{} + 2ms);
    CHECK(held.empty());
}

TEST_CASE("queued_reply: a slave's next() is done while the application has a request",
          "[core][station][queued_reply]") {
    queued_reply<2> reply;
    std::uint32_t replies = 0;
    const time_point due = time_point{} + 5ms;
    reply.queue(1, due);
    CHECK(reply.next(due, true, replies).what == session_action::kind::done);
    CHECK(reply.queued());
    CHECK(reply.next(due - 1ms, false, replies).what == session_action::kind::wait);
    CHECK(replies == 0);
    CHECK(reply.next(due, false, replies).what == session_action::kind::send);
    CHECK(replies == 1);
    CHECK(reply.next(due, false, replies).what == session_action::kind::idle);
    CHECK(replies == 1);
}
