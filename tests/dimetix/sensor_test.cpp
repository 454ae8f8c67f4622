// Dimetix sensor session against a scripted sensor on mock_serial, in virtual time.
#include <catch2/catch.hpp>

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/dimetix/access.hpp"
#include "ferrule/dimetix/sensor.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule::dimetix;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::script_step;
using ferrule::time_point;

namespace {

std::span<const std::uint8_t> b(std::string_view s) {
    return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}
script_step reply_with(std::string_view req, std::string_view rsp, ferrule::duration delay = 5ms) {
    script_step s;
    s.expect = b(req);
    s.reply = b(rsp);
    s.delay = delay;
    return s;
}
script_step silent(std::string_view req) {
    script_step s;
    s.expect = b(req);
    return s;
}
// Requests the session put on the wire, in order.
std::vector<std::string> requests(const mock_serial& line) {
    std::vector<std::string> out;
    std::string cur;
    for (const auto& w : line.wire()) {
        if (w.origin != ferrule::wire_byte::from::session) continue;
        cur += static_cast<char>(w.value);
        if (w.value == '\n') {
            out.push_back(cur);
            cur.clear();
        }
    }
    return out;
}

} // namespace

TEST_CASE("a distance measurement: one command, one answer, exact timing", "[dimetix][sensor]") {
    const std::array steps{reply_with("s0g\r\n", "g0g+00012345\r\n", 120ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    const auto m = measure(line, s, 0);
    REQUIRE(m);
    CHECK(m->distance == 12345);
    CHECK(m->fields == 1);
    CHECK(peer.mismatches() == 0);
    CHECK(s.attempts() == 1);
    CHECK(line.now() ==
          time_point{} + default_format.chars_time(5) + 120ms + default_format.chars_time(14));
}

TEST_CASE("no answer: retries, then errc::timeout after each measurement timeout",
          "[dimetix][sensor]") {
    const std::array steps{silent("s0g\r\n"), silent("s0g\r\n"), silent("s0g\r\n")};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    CHECK(measure(line, s, 0).error() == errc::timeout);
    CHECK(peer.finished());
    CHECK(s.attempts() == 3);
    CHECK(s.stats().timeouts == 3);
    CHECK(s.stats().resends == 2);
    CHECK(s.stats().failed == 1);
    CHECK(line.now() == time_point{} + 3 * (default_format.chars_time(5) + measurement_timeout));
}

TEST_CASE("configuration commands use the short command timeout", "[dimetix][sensor]") {
    const std::array steps{silent("s0uo\r\n")};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor_config cfg;
    cfg.retries = 0;
    cfg.command_timeout = 200ms;
    sensor s(cfg);
    CHECK(transact(line, s, *get(0, "uo")).error() == errc::timeout);
    CHECK(line.now() == time_point{} + default_format.chars_time(6) + 200ms);
}

TEST_CASE("a garbage line is retried and the next answer accepted", "[dimetix][sensor]") {
    const std::array steps{reply_with("s0g\r\n", "g0#g+0000\x01\r\n"),
                           reply_with("s0g\r\n", "g0g+00000101\r\n")};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    const auto m = measure(line, s, 0);
    REQUIRE(m);
    CHECK(m->distance == 101);
    CHECK(s.stats().malformed_lines == 1);
    CHECK(s.attempts() == 2);
}

TEST_CASE("a garbled answer is retried, another ID's garbled line only skipped",
          "[dimetix][sensor]") {
    script_step second = reply_with("s1g\r\n", "g01g+00000777\r\n", 50ms);
    second.noise = b("g2g+12x\r\n");
    const std::array steps{reply_with("s1g\r\n", "g1g+12x\r\n"), second};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    const auto m = measure(line, s, 1);
    REQUIRE(m);
    CHECK(m->distance == 777);
    CHECK(s.reply().id == 1);
    CHECK(s.reply().id_digits == 1); // as answered(): the leading zero is not kept
    CHECK(s.stats().malformed_lines == 1);
    CHECK(s.stats().foreign_lines == 1);
    CHECK(s.attempts() == 2);
    CHECK(peer.finished());
}

TEST_CASE("an answer from another ID is skipped, not accepted", "[dimetix][sensor]") {
    script_step st = reply_with("s1g\r\n", "g1g+00000777\r\n", 50ms);
    st.noise = b("g2g+00009999\r\n");
    const std::array steps{st};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    const auto m = measure(line, s, 1);
    REQUIRE(m);
    CHECK(m->distance == 777);
    CHECK(s.stats().foreign_lines == 1);
    CHECK(s.attempts() == 1);
}

TEST_CASE("only another ID answers: timeout, never its value", "[dimetix][sensor]") {
    const std::array steps{reply_with("s1g\r\n", "g2g+00009999\r\n")};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor_config cfg;
    cfg.retries = 0;
    sensor s(cfg);
    CHECK(measure(line, s, 1).error() == errc::timeout);
    CHECK(s.stats().foreign_lines == 1);
}

TEST_CASE("@E255 ends the command with the device error and its text", "[dimetix][sensor]") {
    const std::array steps{reply_with("s0g\r\n", "g0@E255\r\n", 400ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    const auto m = measure(line, s, 0);
    REQUIRE_FALSE(m);
    CHECK(m.error() == make_device_error(255));
    CHECK(std::error_code(m.error()).category() == device_category());
    CHECK(std::error_code(m.error()).message() ==
          "@E255: received signal too low or distance not in range: use a more reflective target");
    CHECK(s.error() == make_device_error(255));
    CHECK(s.reply().kind == reply_kind::error);
    CHECK(s.attempts() == 1); // device errors are not retried by default
    CHECK(s.stats().device_errors == 1);
    CHECK(s.consecutive_failures() == 0); // the line works: no step towards the fault latch
}

TEST_CASE("device errors are retried when configured", "[dimetix][sensor]") {
    const std::array steps{reply_with("s0g\r\n", "g0@E255\r\n"),
                           reply_with("s0g\r\n", "g0g+00000042\r\n")};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor_config cfg;
    cfg.retry_device_errors = true;
    sensor s(cfg);
    CHECK(measure(line, s, 0).value_or({}).distance == 42);
}

TEST_CASE("a measurement that takes 3.9 s succeeds with the default timeout", "[dimetix][sensor]") {
    const std::array steps{reply_with("s0g\r\n", "g0g+00012345\r\n", 3900ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    const auto m = measure(line, s, 0);
    REQUIRE(m);
    CHECK(m->distance == 12345);
    CHECK(s.attempts() == 1);
}

TEST_CASE("the startup string arriving unsolicited is not the answer to a measurement",
          "[dimetix][sensor]") {
    script_step st = reply_with("s0g\r\n", "g0g+00001234\r\n", 300ms);
    st.noise = b("g0?\r\n"); // the sensor was just powered on (S1 §8.1.5)
    const std::array steps{st};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    const auto m = measure(line, s, 0);
    REQUIRE(m);
    CHECK(m->distance == 1234);
    CHECK(s.stats().startups == 1);
}

TEST_CASE("stop while tracking drains the queued gNh lines until gN?", "[dimetix][sensor]") {
    script_step st = reply_with("s0c\r\n", "g0?\r\n", 20ms);
    st.noise = b("g0h+00001000\r\ng0h+00001001\r\ng0h+00001002\r\n");
    const std::array steps{st};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    REQUIRE_FALSE(stop(line, s, 0));
    CHECK(s.stats().skipped_lines == 3);
    CHECK(s.attempts() == 1);
    CHECK(s.reply().kind == reply_kind::startup_or_ack);
}

TEST_CASE("connect sends sNc until the sensor answers gN?", "[dimetix][sensor]") {
    const std::array steps{silent("s1c\r\n"), silent("s1c\r\n"), reply_with("s1c\r\n", "g1?\r\n")};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    REQUIRE_FALSE(connect(line, s, 1));
    CHECK(s.attempts() == 3);
    CHECK(requests(line) == std::vector<std::string>(3, "s1c\r\n"));
    CHECK(peer.finished());
}

TEST_CASE("connect gives up after connect_attempts", "[dimetix][sensor]") {
    std::vector<script_step> steps(4, silent("s1c\r\n"));
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor_config cfg;
    cfg.connect_attempts = 4;
    sensor s(cfg);
    CHECK(connect(line, s, 1) == errc::timeout);
    CHECK(peer.finished());
    CHECK(s.start_connect(100) == errc::invalid_argument);
}

TEST_CASE("the fault latch refuses everything but sNc, whose gN? clears it", "[dimetix][sensor]") {
    std::vector<script_step> steps(2, silent("s0g\r\n"));
    steps.push_back(reply_with("s0c\r\n", "g0?\r\n"));
    steps.push_back(reply_with("s0g\r\n", "g0g+00000005\r\n"));
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor_config cfg;
    cfg.retries = 0;
    cfg.fault_threshold = 2;
    sensor s(cfg);
    CHECK(measure(line, s, 0).error() == errc::timeout);
    CHECK_FALSE(s.fault_latched());
    CHECK(measure(line, s, 0).error() == errc::timeout);
    CHECK(s.fault_latched());
    CHECK(measure(line, s, 0).error() == errc::fault_latched);
    REQUIRE_FALSE(stop(line, s, 0));
    CHECK_FALSE(s.fault_latched());
    CHECK(measure(line, s, 0).value_or({}).distance == 5);
    CHECK(peer.finished());
}

TEST_CASE("continuous commands are refused on a multi-drop line unless forced",
          "[dimetix][sensor]") {
    sensor s;
    CHECK(s.start(tracking(0)) == errc::invalid_argument);
    CHECK(s.start(tracking(0, 100)) == errc::invalid_argument);
    CHECK(s.start(signal(0, true)) == errc::invalid_argument);
    CHECK(s.start(generation()) == errc::invalid_argument); // ID-less: one device only
    CHECK_FALSE(s.start(tracking_buffered(0, 100)));

    sensor_config forced;
    forced.force_continuous = true;
    sensor f(forced);
    CHECK_FALSE(f.start(tracking(0)));
    CHECK(f.start(tracking(0, 100)) == errc::busy);
    sensor_config p2p;
    p2p.multi_drop = false;
    sensor single(p2p);
    CHECK_FALSE(single.start(generation()));
}

TEST_CASE("invalid commands are refused before anything is sent", "[dimetix][sensor]") {
    sensor s;
    CHECK(s.start(distance(100)) == errc::invalid_argument);
    CHECK(s.start(make_command(0, "eg", 100)) == errc::invalid_argument);
    CHECK(s.start(make_command(0, "g", 1)) == errc::invalid_argument); // sNg has no parameter
    CHECK(s.start(make_command(command::no_id, "g")) == errc::invalid_argument);
    command wide = *set(0, "uo", std::array{300});
    wide.digits = 11; // more than a request holds, as encode() refuses it
    CHECK(s.start(wide) == errc::invalid_argument);
    CHECK(s.next(time_point{}).what == ferrule::session_action::kind::idle);
}

TEST_CASE("a planned command carries the table's answer and timeout into start()",
          "[dimetix][sensor]") {
    // plan() of a constant is a constant: the command table is read at compile time.
    static constexpr planned_command g = plan(distance(0));
    static_assert(g.expect == answer::value && g.measures);
    static constexpr planned_command uo = plan(make_command(0, "uo", 300));
    static_assert(uo.expect == answer::set_ack && !uo.measures);
    static_assert(plan(distance(100)).expect == answer::none);
    static_assert(plan(make_command(0, "g", 1)).expect == answer::none);

    const std::array steps{silent("s0uo+300\r\n"), reply_with("s0g\r\n", "g0g+00000042\r\n")};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor_config cfg;
    cfg.retries = 0;
    cfg.command_timeout = 200ms;
    sensor s(cfg);
    CHECK(s.start(plan(make_command(0, "eg", 100))) == errc::invalid_argument);
    REQUIRE_FALSE(s.start(uo));
    CHECK(ferrule::run(line, s) ==
          errc::timeout); // the command timeout, not the measurement timeout
    CHECK(line.now() == time_point{} + default_format.chars_time(10) + 200ms);
    s.clear();
    REQUIRE_FALSE(s.start(g));
    REQUIRE_FALSE(ferrule::run(line, s));
    CHECK(s.reply().values[0] == 42);
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("forced tracking on a single-sensor line: done with its first line",
          "[dimetix][sensor]") {
    const std::array steps{reply_with("s0h+100\r\n", "g0h+00001000\r\n", 100ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor_config cfg;
    cfg.force_continuous = true;
    sensor s(cfg);
    const auto first = transact(line, s, tracking(0, 100));
    REQUIRE(first);
    CHECK(first->values[0] == 1000);
    CHECK(measurement_of(*first).value_or({}).distance == 1000);
    CHECK(s.start(tracking(0)) == std::error_code{});
}

TEST_CASE("buffered tracking via sNf and sNq reports the buffer status", "[dimetix][sensor]") {
    const std::array steps{reply_with("s0f+500\r\n", "g0f?\r\n"),
                           reply_with("s0q\r\n", "g0q+00012000+1\r\n"),
                           reply_with("s0q\r\n", "g0q+00012000+0\r\n"),
                           reply_with("s0q\r\n", "g0q+00012100+2\r\n"),
                           reply_with("s0c\r\n", "g0?\r\n"),
                           reply_with("s0q\r\n", "g0@E210+0\r\n")};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    REQUIRE_FALSE(start_buffered_tracking(line, s, 0, 500));
    auto v = read_buffer(line, s, 0);
    REQUIRE(v);
    CHECK(v->distance == 12000);
    CHECK(v->status == buffer_status::new_value);
    CHECK(read_buffer(line, s, 0).value_or({}).status == buffer_status::no_new_value);
    v = read_buffer(line, s, 0);
    CHECK(v->distance == 12100);
    CHECK(v->status == buffer_status::overwritten);
    REQUIRE_FALSE(stop(line, s, 0));
    CHECK(read_buffer(line, s, 0).error() == make_device_error(210));
    CHECK(s.reply().buffer_status == 0);
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("the other helpers send their commands and read their answers", "[dimetix][sensor]") {
    const std::array steps{reply_with("s0t\r\n", "g0t-00000023\r\n"),
                           reply_with("s0m+0\r\n", "g0m+00008384\r\n"),
                           reply_with("s0o\r\n", "g0?\r\n"),
                           reply_with("s0re\r\n", "g0re+255+200\r\n"),
                           reply_with("s0ce\r\n", "g0ce?\r\n"),
                           reply_with("s0uo+300\r\n", "g0uo?\r\n"),
                           reply_with("s0g\r\n", "g0g+00000234+008384+254\r\n"),
                           reply_with("s11+20050+19950\r\n", "g11?\r\n")};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    sensor s;
    CHECK(temperature(line, s, 0).value_or(0) == -23);
    CHECK(signal_strength(line, s, 0).value_or(0) == 8384);
    CHECK_FALSE(laser_on(line, s, 0));
    const auto stack = read_error_stack(line, s, 0);
    REQUIRE(stack);
    CHECK(stack->count == 2);
    CHECK(stack->values[0] == 255);
    CHECK_FALSE(clear_error_stack(line, s, 0));
    CHECK(transact(line, s, *set(0, "uo", std::array{300})));
    const auto m = measure(line, s, 0);
    REQUIRE(m);
    CHECK(m->fields == 3);
    CHECK(m->temperature == 254);
    const auto do1 = transact(line, s, *set(1, "1", std::array{20050, 19950}));
    REQUIRE(do1);
    CHECK(do1->id == 1);
    CHECK(do1->kind == reply_kind::set_ack);
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
}

TEST_CASE("a reply split into single bytes with gaps is assembled", "[dimetix][sensor]") {
    script_step st = reply_with("s0g\r\n", "g0g+00012345\r\n", 10ms);
    st.chunk = 1;
    st.chunk_gap = 3ms;
    const std::array steps{st};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    line.set_read_size(1);
    sensor s;
    CHECK(measure(line, s, 0).value_or({}).distance == 12345);
}

TEST_CASE("stale input is dropped before a command", "[dimetix][sensor]") {
    const std::array steps{reply_with("s0g\r\n", "g0g+00000001\r\n")};
    ferrule::script_peer peer(steps);
    mock_serial line(default_format, &peer);
    line.inject(b("g0g+00009999\r\n"), time_point{});
    line.advance(50ms);
    sensor s;
    CHECK(measure(line, s, 0).value_or({}).distance == 1);
    CHECK(line.discarded() == 14);
}

TEST_CASE("a transport error ends the command with it", "[dimetix][sensor]") {
    mock_serial line(default_format);
    line.fail_at(1); // the command's write
    sensor s;
    CHECK(measure(line, s, 0).error() == errc::transport);
    CHECK(line.writes() == 0);
    CHECK_FALSE(s.busy());
    CHECK(s.start(distance(0)) == std::error_code{});
}
