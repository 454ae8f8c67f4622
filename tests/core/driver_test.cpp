// core/driver.hpp on its own: run() and poll_driver with a scripted master session on
// mock_serial, in virtual time. The session says what the test tells it to and records what
// the driver hands it.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <span>
#include <system_error>
#include <utility>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::session_action;
using ferrule::time_point;
using kind = session_action::kind;
using bytes = std::vector<std::uint8_t>;

namespace {

const ferrule::serial_format f8e1{9600, 8, ferrule::parity::even, 1};
const ferrule::error io_error = ferrule::from_error_code(std::make_error_code(std::errc::io_error));

// A master session that answers next() from a script: action i for the i-th call, the last
// one for every call after it.
struct scripted_session {
    explicit scripted_session(std::vector<session_action> actions, ferrule::error result = {})
        : script(std::move(actions)), outcome(result) {}

    std::vector<session_action> script;
    ferrule::error outcome;
    std::vector<time_point> asked;         // `now` of each next()
    std::vector<bytes> received;           // each on_receive()
    std::vector<time_point> received_at;   // its time
    std::vector<ferrule::error> transport; // each on_transport_error()

    session_action next(time_point now) {
        asked.push_back(now);
        return script[std::min(asked.size(), script.size()) - 1];
    }
    void on_receive(std::span<const std::uint8_t> in, time_point now) {
        received.emplace_back(in.begin(), in.end());
        received_at.push_back(now);
    }
    void on_transport_error(ferrule::error ec) { transport.push_back(ec); }
    ferrule::error error() const { return outcome; }
};
static_assert(ferrule::master_session<scripted_session>);

const std::array<std::uint8_t, 3> request{0x01, 0x02, 0x03};
const std::array<std::uint8_t, 2> stale{0xEE, 0xEF};

} // namespace

TEST_CASE("run: an idle session ends at once, without I/O", "[core][driver]") {
    mock_serial line(f8e1);
    scripted_session s{{session_action::idle()}};
    CHECK_FALSE(ferrule::run(line, s));
    CHECK(s.asked.size() == 1);
    CHECK(line.io_operations() == 0);
}

TEST_CASE("run: a done session returns its outcome, without I/O", "[core][driver]") {
    mock_serial line(f8e1);
    scripted_session s{{session_action::done()}, errc::bad_checksum};
    CHECK(ferrule::run(line, s) == errc::bad_checksum);
    CHECK(line.io_operations() == 0);
    CHECK(s.transport.empty());
}

TEST_CASE("run: send drops stale input first only when the session asks", "[core][driver]") {
    for (const bool discard : {true, false}) {
        INFO("discard_input " << discard);
        mock_serial line(f8e1);
        line.inject(stale, line.now());
        line.advance(10ms); // both stale bytes have arrived
        scripted_session s{{session_action::send(request, discard), session_action::done()}};
        CHECK_FALSE(ferrule::run(line, s));
        CHECK(line.writes() == 1);
        CHECK(line.wire().size() == stale.size() + request.size());
        CHECK(line.wire().back().value == 0x03);
        CHECK(line.discarded() == (discard ? 2u : 0u));
        CHECK(line.pending() == (discard ? 0u : 2u));
        CHECK(s.received.empty());
    }
}

TEST_CASE("run: bytes that arrive during a wait go to on_receive with their time",
          "[core][driver]") {
    const std::array<std::uint8_t, 2> reply{0xA0, 0xA1};
    std::array<ferrule::script_step, 1> steps{};
    steps[0].reply = reply;
    steps[0].delay = 2ms;
    ferrule::script_peer peer(steps);
    mock_serial line(f8e1, &peer);
    const time_point deadline = time_point{} + 1s;
    scripted_session s{{session_action::send(request, false), session_action::wait_until(deadline),
                        session_action::wait_until(deadline), session_action::done()}};
    CHECK_FALSE(ferrule::run(line, s));
    REQUIRE(s.received.size() == 2); // one byte per read: the second is still on the wire
    CHECK(s.received[0] == bytes{0xA0});
    CHECK(s.received[1] == bytes{0xA1});
    const time_point request_end = time_point{} + f8e1.chars_time(3);
    CHECK(s.received_at[0] == request_end + 2ms + f8e1.char_time());
    CHECK(s.received_at[1] == request_end + 2ms + f8e1.chars_time(2));
    CHECK(s.asked.back() == s.received_at[1]); // asked again at once, not at the deadline
    CHECK(s.transport.empty());
}

TEST_CASE("run: a wait that times out asks the session again at its deadline", "[core][driver]") {
    mock_serial line(f8e1); // a silent far end
    const time_point deadline = time_point{} + 250ms;
    scripted_session s{{session_action::wait_until(deadline), session_action::done()},
                       errc::timeout};
    CHECK(ferrule::run(line, s) == errc::timeout);
    REQUIRE(s.asked.size() == 2);
    CHECK(s.asked[1] == deadline);
    CHECK(line.now() == deadline);
    CHECK(s.received.empty());
    CHECK(s.transport.empty()); // a timeout is the session's to judge
}

TEST_CASE("run: a write error goes to on_transport_error once and ends the run", "[core][driver]") {
    mock_serial line(f8e1);
    line.fail_at(1, io_error);
    scripted_session s{{session_action::send(request, true), session_action::done()}};
    CHECK(ferrule::run(line, s) == io_error);
    REQUIRE(s.transport.size() == 1);
    CHECK(s.transport[0] == io_error);
    CHECK(s.asked.size() == 1); // not asked again after the error
    CHECK(line.writes() == 0);
}

TEST_CASE("run: a read error goes to on_transport_error once and ends the run", "[core][driver]") {
    mock_serial line(f8e1);
    line.fail_at(2, io_error);
    scripted_session s{{session_action::send(request, false),
                        session_action::wait_until(time_point{} + 1s), session_action::done()}};
    CHECK(ferrule::run(line, s) == io_error);
    REQUIRE(s.transport.size() == 1);
    CHECK(s.transport[0] == io_error);
    CHECK(s.asked.size() == 2);
    CHECK(s.received.empty());
}

TEST_CASE("run: the end of the stream during a wait is a transport error", "[core][driver]") {
    mock_serial line(f8e1);
    line.end_of_stream();
    const time_point deadline = time_point{} + 1s;
    scripted_session s{{session_action::wait_until(deadline), session_action::done()}};
    CHECK(ferrule::run(line, s) == errc::transport);
    REQUIRE(s.transport.size() == 1);
    CHECK(s.transport[0] == errc::transport);
    CHECK(line.now() == time_point{}); // ended at once, not at the deadline
}

TEST_CASE("poll_driver: idle and done steps do no I/O", "[core][driver]") {
    mock_serial line(f8e1);
    scripted_session s{{session_action::idle(), session_action::done()}};
    ferrule::poll_driver driver(line, s);
    CHECK(driver.step() == kind::idle);
    CHECK(driver.step() == kind::done);
    CHECK(driver.step() == kind::done);
    CHECK(line.io_operations() == 0);
    CHECK(s.transport.empty());
}

TEST_CASE("poll_driver: a send step writes once, dropping stale input when asked",
          "[core][driver]") {
    for (const bool discard : {true, false}) {
        INFO("discard_input " << discard);
        mock_serial line(f8e1);
        line.inject(stale, line.now());
        line.advance(10ms);
        scripted_session s{{session_action::send(request, discard), session_action::done()}};
        ferrule::poll_driver driver(line, s);
        CHECK(driver.step() == kind::send);
        CHECK(line.io_operations() == 1);
        CHECK(line.writes() == 1);
        CHECK(line.discarded() == (discard ? 2u : 0u));
        CHECK(driver.step() == kind::done);
        CHECK(line.io_operations() == 1);
    }
}

TEST_CASE("poll_driver: a wait step never blocks, and hands over what has arrived",
          "[core][driver]") {
    const std::array<std::uint8_t, 2> reply{0xA0, 0xA1};
    mock_serial line(f8e1);
    const time_point deadline = time_point{} + 5s;
    scripted_session s{{session_action::wait_until(deadline)}};
    ferrule::poll_driver driver(line, s);
    const time_point t0 = line.now();
    CHECK(driver.step() == kind::wait);
    CHECK(line.now() == t0); // nothing had arrived: no wait for it, nor for the deadline
    CHECK(s.received.empty());
    CHECK(s.transport.empty()); // "nothing yet" is no error

    line.inject(reply, line.now() + 1ms);
    line.advance(1ms + f8e1.char_time()); // the first byte has arrived, the second not yet
    const time_point t1 = line.now();
    CHECK(driver.step() == kind::wait);
    CHECK(line.now() == t1);
    REQUIRE(s.received.size() == 1);
    CHECK(s.received[0] == bytes{0xA0});
    CHECK(s.received_at[0] == t1);
    CHECK(line.io_operations() == 2); // one read per step
}

TEST_CASE("poll_driver: write and read errors go to on_transport_error once each",
          "[core][driver]") {
    SECTION("write") {
        mock_serial line(f8e1);
        line.fail_at(1, io_error);
        scripted_session s{{session_action::send(request, false), session_action::done()}};
        ferrule::poll_driver driver(line, s);
        CHECK(driver.step() == kind::send);
        CHECK(driver.step() == kind::done);
        REQUIRE(s.transport.size() == 1);
        CHECK(s.transport[0] == io_error);
        CHECK(line.writes() == 0);
    }
    SECTION("read") {
        mock_serial line(f8e1);
        line.fail_at(2, io_error);
        const time_point deadline = time_point{} + 1s;
        scripted_session s{{session_action::wait_until(deadline),
                            session_action::wait_until(deadline),
                            session_action::wait_until(deadline), session_action::done()}};
        ferrule::poll_driver driver(line, s);
        CHECK(driver.step() == kind::wait);
        CHECK(s.transport.empty());
        CHECK(driver.step() == kind::wait);
        REQUIRE(s.transport.size() == 1);
        CHECK(s.transport[0] == io_error);
        CHECK(driver.step() == kind::wait);
        CHECK(driver.step() == kind::done);
        CHECK(s.transport.size() == 1);
    }
    SECTION("end of stream") {
        mock_serial line(f8e1);
        line.end_of_stream();
        scripted_session s{{session_action::wait_until(time_point{} + 1s)}};
        ferrule::poll_driver driver(line, s);
        CHECK(driver.step() == kind::wait);
        REQUIRE(s.transport.size() == 1);
        CHECK(s.transport[0] == errc::transport);
    }
}
