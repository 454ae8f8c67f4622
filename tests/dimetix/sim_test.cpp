// The simulated D-Series sensor, alone (sans-I/O) and on a simulated multi-drop line with
// the sensor session in front of it.
#include <catch2/catch.hpp>

#include <string>
#include <string_view>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/dimetix/access.hpp"
#include "ferrule/dimetix/sim/bus.hpp"
#include "ferrule/dimetix/sim/sensor.hpp"

using namespace std::chrono_literals;
using namespace ferrule::dimetix;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::session_action;
using ferrule::time_point;

namespace {

std::span<const std::uint8_t> b(std::string_view s) {
    return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

// Drives a lone simulator: the lines it sends up to `until`, with their times.
struct harness {
    sim::d_series dev;
    time_point now{};
    std::vector<std::pair<time_point, std::string>> out;

    explicit harness(const sim::d_series_config& cfg = {}) : dev(cfg) {}
    void send(std::string_view req) { dev.on_receive(b(req), now); }
    void run_until(time_point until) {
        for (;;) {
            const session_action a = dev.next(now);
            if (a.what == session_action::kind::send) {
                out.emplace_back(now, std::string(a.bytes.begin(), a.bytes.end()));
                continue;
            }
            if (a.what != session_action::kind::wait || a.deadline > until) break;
            now = a.deadline;
        }
        now = until;
    }
    std::string ask(std::string_view req, ferrule::duration wait = 10ms) {
        out.clear();
        send(req);
        run_until(now + wait);
        std::string all;
        for (const auto& [t, s] : out) all += s;
        return all;
    }
};

} // namespace

TEST_CASE("sim: a measurement answers after the measurement time", "[dimetix][sim]") {
    sim::d_series_config cfg;
    cfg.distance = 12345;
    cfg.measurement_time = 250ms;
    harness h(cfg);
    h.send("s0g\r\n");
    CHECK(h.dev.next(h.now).what == session_action::kind::wait);
    CHECK(h.dev.next(h.now).deadline == time_point{} + 250ms);
    h.run_until(time_point{} + 1s);
    REQUIRE(h.out.size() == 1);
    CHECK(h.out[0].first == time_point{} + 250ms);
    CHECK(h.out[0].second == "g0g+00012345\r\n");
    CHECK(h.dev.next(h.now).what == session_action::kind::idle);
}

TEST_CASE("sim: only its own ID is answered, dt and dg always", "[dimetix][sim]") {
    sim::d_series_config cfg;
    cfg.id = 7;
    harness h(cfg);
    CHECK(h.ask("s0g\r\n", 1s).empty());
    CHECK(h.ask("s17g\r\n", 1s).empty());
    CHECK(h.ask("s7t\r\n") == "g7t+00000254\r\n");
    CHECK(h.ask("dt\r\n") == "g7dt+0401\r\n");
    CHECK(h.ask("dg\r\n") == "g7dg+084+07\r\n");
    CHECK(h.ask("s7xyz\r\n") == "g7@E203\r\n");
    CHECK(h.ask("s7g+\r\n") == "g7@E203\r\n");
    CHECK(h.ask("s8g+\r\n").empty());
}

TEST_CASE("sim: s11 addresses ID 1's DO1, s11c ID 11", "[dimetix][sim]") {
    sim::d_series_config one;
    one.id = 1;
    sim::d_series_config eleven;
    eleven.id = 11;
    harness h1(one), h11(eleven);
    CHECK(h1.ask("s11+20050+19950\r\n") == "g11?\r\n");
    CHECK(h11.ask("s11+20050+19950\r\n").empty());
    CHECK(h1.ask("s11\r\n") == "g11+00020050+00019950\r\n");
    CHECK(h11.ask("s11c\r\n") == "g11?\r\n");
    CHECK(h1.ask("s11c\r\n").empty());
}

TEST_CASE("sim: user output formats 200, 300 and 301", "[dimetix][sim]") {
    sim::d_series_config cfg;
    cfg.distance = 1234;
    harness h(cfg);
    CHECK(h.ask("s0uof-10000\r\n") == "g0uof?\r\n");
    CHECK(h.ask("s0uga-1+1\r\n") == "g0uga?\r\n");
    CHECK(h.ask("s0uo+200\r\n") == "g0uo?\r\n");
    CHECK(h.ask("s0g\r\n", 200ms) == "g0g+00008766\r\n"); // (1234 - 10000) * -1
    CHECK(h.ask("s0uga+1+1\r\n") == "g0uga?\r\n");
    CHECK(h.ask("s0uof+0\r\n") == "g0uof?\r\n");
    CHECK(h.ask("s0uo+300\r\n") == "g0uo?\r\n");
    CHECK(h.ask("s0g\r\n", 200ms) == "g0g+00001234+008384+254\r\n");
    CHECK(h.ask("s0uo+301\r\n") == "g0uo?\r\n");
    CHECK(h.ask("s0g\r\n", 200ms) == "g0g+00001234+008384+254+000000\r\n");
    CHECK(h.ask("s0uo+139\r\n") == "g0@E203\r\n"); // display format not simulated
    CHECK(h.ask("s0uo\r\n") == "g0uo+00000301\r\n");
}

TEST_CASE("sim: a ramp moves and reports its speed", "[dimetix][sim]") {
    sim::d_series_config cfg;
    cfg.shape = sim::profile::ramp;
    cfg.distance = 10000;
    cfg.slope = 5000; // 0.1 mm/s: 500 mm/s
    harness h(cfg);
    CHECK(h.dev.distance_at(time_point{} + 2s) == 20000);
    h.ask("s0uo+301\r\n");
    h.now = time_point{} + 900ms;
    CHECK(h.ask("s0g\r\n", 200ms) == "g0g+00015000+008384+254+000500\r\n");
}

TEST_CASE("sim: a sine profile and noise stay within their amplitudes", "[dimetix][sim]") {
    sim::d_series_config cfg;
    cfg.shape = sim::profile::sine;
    cfg.distance = 50000;
    cfg.amplitude = 1000;
    cfg.period = 4s;
    cfg.noise = 20;
    cfg.seed = 7;
    harness h(cfg);
    CHECK(h.dev.distance_at(time_point{} + 1s) == 51000);
    CHECK(h.dev.distance_at(time_point{} + 3s) == 49000);
    std::vector<std::int32_t> seen;
    for (int i = 0; i < 20; ++i) {
        const auto r = parse_reply(b(h.ask("s0g\r\n", 200ms)));
        REQUIRE(r);
        const auto t = h.now - 100ms;
        CHECK(std::abs(r->values[0] - h.dev.distance_at(t)) <= 20);
        seen.push_back(r->values[0] - h.dev.distance_at(t));
    }
    CHECK(std::count(seen.begin(), seen.end(), seen[0]) < 20); // it is noisy
    // Deterministic: the same seed gives the same readings.
    harness again(cfg);
    for (int i = 0; i < 20; ++i) {
        const auto r = parse_reply(b(again.ask("s0g\r\n", 200ms)));
        CHECK(r->values[0] - again.dev.distance_at(again.now - 100ms) ==
              seen[static_cast<std::size_t>(i)]);
    }
}

TEST_CASE("sim: injected error, error stack and boot marker", "[dimetix][sim]") {
    harness h;
    CHECK(h.ask("s0re\r\n") == "g0re+000\r\n");
    h.dev.inject_error(255);
    CHECK(h.ask("s0g\r\n", 200ms) == "g0@E255\r\n");
    CHECK(h.ask("s0g\r\n", 200ms) == "g0g+00012345\r\n"); // only the next measurement
    h.out.clear();
    h.dev.power_on(h.now);
    h.run_until(h.now + 1s);
    REQUIRE(h.out.size() == 1);
    CHECK(h.out[0].second == "g0?\r\n");
    CHECK(h.ask("s0re\r\n") == "g0re+200+255\r\n");
    CHECK(h.dev.error_stack().size() == 2);
    CHECK(h.ask("s0ce\r\n") == "g0ce?\r\n");
    CHECK(h.ask("s0re\r\n") == "g0re+000\r\n");
}

TEST_CASE("sim: configuration range checks answer @E203", "[dimetix][sim]") {
    harness h;
    CHECK(h.ask("s0vm+2\r\n") == "g0@E203\r\n");
    CHECK(h.ask("s0ve+500\r\n") == "g0@E203\r\n");
    CHECK(h.ask("s0ve+999\r\n") == "g0ve?\r\n");
    CHECK(h.ask("s0fi+10+2+1\r\n") == "g0@E203\r\n"); // 2*2 + 1 > 0.4 * 10
    CHECK(h.ask("s0fi+1+0+0\r\n") == "g0@E203\r\n");  // length 0 or 2..32
    CHECK(h.ask("s0fi+10+1+2\r\n") == "g0fi?\r\n");
    CHECK(h.ask("s0fi\r\n") == "g0fi+10+01+02\r\n");
    CHECK(h.ask("s0uga+1+0\r\n") == "g0@E203\r\n");
    CHECK(h.ask("s0DI1+5\r\n") == "g0@E203\r\n");
    CHECK(h.ask("s0br+3\r\n") == "g0@E203\r\n");
    CHECK(h.ask("s0afi+2+0\r\n") == "g0@E203\r\n");
    CHECK(h.ask("s0afi+2+100\r\n") == "g0afi+2?\r\n");
    CHECK(h.ask("s0afi+2\r\n") == "g0afi+2+00000100\r\n");
    CHECK(h.ask("s0ado+2+1+1+995\r\n") == "g0ado+2?\r\n");
    CHECK(h.ask("s02-500-495\r\n") == "g02?\r\n");
    CHECK(h.ask("s02\r\n") == "g02-00000500-00000495\r\n");
    CHECK(h.ask("s0o\r\n") == "g0?\r\n");
    CHECK(h.dev.laser_on());
    CHECK(h.ask("s0c\r\n") == "g0?\r\n");
    CHECK_FALSE(h.dev.laser_on());
    CHECK(h.ask("s0SSI+29\r\n") == "g0SSI?\r\n");
    CHECK(h.ask("s0SSI\r\n") == "g0SSI+029\r\n");
    CHECK(h.ask("s0RI\r\n") == "g0RI+0\r\n");
}

TEST_CASE("sim: settings are volatile until sNs, sNd restores the factory values",
          "[dimetix][sim]") {
    harness h;
    CHECK(h.ask("s0mc+1\r\n") == "g0mc?\r\n");
    h.dev.power_on(h.now);
    h.run_until(h.now + 1s);
    CHECK(h.ask("s0mc\r\n") == "g0mc+00000000\r\n");
    CHECK(h.ask("s0mc+2\r\n") == "g0mc?\r\n");
    CHECK(h.ask("s0s\r\n", 200ms) == "g0s?\r\n");
    h.dev.power_on(h.now);
    h.run_until(h.now + 1s);
    CHECK(h.ask("s0mc\r\n") == "g0mc+00000002\r\n");
    CHECK(h.ask("s0d\r\n", 200ms) == "g0?\r\n");
    CHECK(h.ask("s0mc\r\n") == "g0mc+00000000\r\n");
}

TEST_CASE("sim: sNid and sNbr", "[dimetix][sim]") {
    harness h;
    CHECK(h.ask("s0id+5\r\n") == "g0?\r\n"); // acknowledged with the old ID
    CHECK(h.dev.id() == 5);
    CHECK(h.ask("s0g\r\n", 200ms).empty());
    CHECK(h.ask("s5br+11\r\n") == "g5?\r\n");
    CHECK(h.dev.comm_setting() == 7); // after a power cycle only
    CHECK(h.ask("dg\r\n") == "g5dg+084+07\r\n");
    h.dev.power_on(h.now);
    h.run_until(h.now + 1s);
    CHECK(h.dev.comm_setting() == 11);
    CHECK(h.ask("dg\r\n") == "g5dg+084+11\r\n");
}

TEST_CASE("sim: tracking streams until sNc, which comes after the backlog", "[dimetix][sim]") {
    sim::d_series_config cfg;
    cfg.measurement_time = 50ms;
    cfg.tracking_backlog = 2;
    harness h(cfg);
    h.send("s0h+100\r\n");
    h.run_until(time_point{} + 455ms);
    REQUIRE(h.out.size() == 5); // at 50, 150, 250, 350, 450 ms
    CHECK(h.out[1].first == time_point{} + 150ms);
    CHECK(h.out[4].second == "g0h+00012345\r\n");
    CHECK(h.ask("s0g\r\n") == "g0@E212\r\n");
    const std::string stop = h.ask("s0c\r\n");
    CHECK(stop == "g0h+00012345\r\ng0h+00012345\r\ng0?\r\n");
    CHECK_FALSE(h.dev.tracking());
    CHECK(h.ask("s0t\r\n", 1s) == "g0t+00000254\r\n");
}

TEST_CASE("sim: buffered tracking status follows the samples taken", "[dimetix][sim]") {
    sim::d_series_config cfg;
    cfg.measurement_time = 100ms;
    harness h(cfg);
    CHECK(h.ask("s0q\r\n") == "g0@E210+0\r\n");
    CHECK(h.ask("s0f+500\r\n") == "g0f?\r\n");
    CHECK(h.ask("s0f\r\n") == "g0f+00000500\r\n");
    CHECK(h.ask("s0q\r\n") == "g0q+00000000+0\r\n"); // nothing measured yet
    h.run_until(time_point{} + 200ms);               // sample at 110 ms
    CHECK(h.ask("s0q\r\n") == "g0q+00012345+1\r\n");
    CHECK(h.ask("s0q\r\n") == "g0q+00012345+0\r\n");
    h.run_until(h.now + 1500ms); // samples at 610, 1110, 1610 ms
    CHECK(h.ask("s0q\r\n") == "g0q+00012345+2\r\n");
    CHECK(h.ask("s0g\r\n") == "g0@E212\r\n");
    h.dev.inject_error(255);
    CHECK(h.ask("s0q\r\n") == "g0@E255+0\r\n");
    CHECK(h.ask("s0c\r\n") == "g0?\r\n");
    CHECK(h.ask("s0q\r\n") == "g0@E210+0\r\n");
}

TEST_CASE("sim: a new command cancels a running measurement", "[dimetix][sim]") {
    sim::d_series_config cfg;
    cfg.measurement_time = 1s;
    harness h(cfg);
    h.send("s0g\r\n");
    h.run_until(h.now + 100ms);
    CHECK(h.ask("s0t\r\n", 2s) == "g0t+00000254\r\n");
}

TEST_CASE("session and simulator: connect, measure, configure", "[dimetix][sim][sensor]") {
    sim::bus<1> line_devices;
    sim::d_series_config cfg;
    cfg.id = 3;
    cfg.distance = 4321;
    line_devices.add(cfg);
    mock_serial line(default_format, &line_devices);
    sensor s;
    REQUIRE_FALSE(connect(line, s, 3));
    CHECK(measure(line, s, 3).value_or({}).distance == 4321);
    REQUIRE(transact(line, s, *set(3, "uo", std::array{301})));
    const auto m = measure(line, s, 3);
    REQUIRE(m);
    CHECK(m->fields == 4);
    CHECK(m->signal == 8384);
    const auto info = transact(line, s, device_type(3));
    CHECK(info->values[0] == d_series_device_type);
    CHECK(transact(line, s, *get(3, "uo"))->values[0] == 301);
}

TEST_CASE("several sensors on one bus, each answering its own ID", "[dimetix][sim][sensor]") {
    sim::bus<3> devices;
    for (std::uint8_t id : {1, 11, 42}) {
        sim::d_series_config cfg;
        cfg.id = id;
        cfg.distance = 1000 * id;
        devices.add(cfg);
    }
    mock_serial line(default_format, &devices);
    sensor s;
    for (int round = 0; round < 3; ++round)
        for (std::uint8_t id : {1, 11, 42})
            CHECK(measure(line, s, id).value_or({}).distance == 1000 * id);
    CHECK(measure(line, s, 5).error() == ferrule::errc::timeout);
    CHECK(line.collisions() == 0);
    // DO1 of ID 1 vs. ID 11: the acknowledge g11? goes to the right command.
    REQUIRE(transact(line, s, *set(1, "1", std::array{500, 495})));
    CHECK(devices[0].setting("1", 0) == 500);
    CHECK(devices[1].setting("1", 0) == 0);
    REQUIRE(transact(line, s, stop_clear(11)));
    // Buffered tracking on all three, polled with sNq.
    for (std::uint8_t id : {1, 11, 42}) REQUIRE_FALSE(start_buffered_tracking(line, s, id, 200));
    line.advance(1s);
    for (std::uint8_t id : {1, 11, 42}) {
        const auto v = read_buffer(line, s, id);
        REQUIRE(v);
        CHECK(v->distance == 1000 * id);
        CHECK(v->status == buffer_status::overwritten);
    }
}

TEST_CASE("bus fault knobs: dropped, corrupted and late answers are retried",
          "[dimetix][sim][sensor]") {
    sim::bus<1> devices;
    devices.add();
    mock_serial line(default_format, &devices);
    sensor s;
    devices.drop_replies(1);
    CHECK(measure(line, s, 0).value_or({}).distance == 12345);
    CHECK(s.stats().timeouts == 1);
    devices.corrupt_replies(1, 3, 0x80); // the '+' gets bit 7: not 7-bit ASCII
    CHECK(measure(line, s, 0).value_or({}).distance == 12345);
    CHECK(s.stats().malformed_lines == 1);
    devices.delay_replies(1, 6s);
    CHECK(measure(line, s, 0).value_or({}).distance == 12345);
    CHECK(devices.replies_dropped() == 1);
    CHECK(s.attempts() == 2);
}

TEST_CASE("power-up: a command during boot is lost, the startup string is skipped",
          "[dimetix][sim][sensor]") {
    sim::bus<1> devices;
    devices.add();
    mock_serial line(default_format, &devices);
    sensor s;
    devices.power_on(line.now());
    // s0g is not heard while booting; g0? comes at 500 ms, the resend is answered.
    CHECK(measure(line, s, 0).value_or({}).distance == 12345);
    CHECK(s.stats().startups == 1);
    CHECK(s.attempts() == 2);
}

TEST_CASE("stop after forced tracking drains the simulator's lines", "[dimetix][sim][sensor]") {
    sim::bus<1> devices;
    sim::d_series_config dcfg;
    dcfg.measurement_time = 20ms;
    dcfg.tracking_backlog = 3;
    devices.add(dcfg);
    mock_serial line(default_format, &devices);
    sensor_config cfg;
    cfg.force_continuous = true;
    cfg.discard_stale_input = false;
    sensor s(cfg);
    REQUIRE(transact(line, s, tracking(0)));
    line.advance(100ms); // more lines come meanwhile
    REQUIRE_FALSE(stop(line, s, 0));
    CHECK(s.stats().skipped_lines >= 3 + 5);
    CHECK_FALSE(devices[0].tracking());
}

TEST_CASE("sim: the distance profile starts at the first power-up", "[dimetix][sim]") {
    // On a host clock, time 0 is long ago: a ramp must still start at its configured distance.
    ferrule::dimetix::sim::d_series_config cfg;
    cfg.shape = ferrule::dimetix::sim::profile::ramp;
    cfg.distance = 10'000;
    cfg.slope = 200; // 20 mm/s
    ferrule::dimetix::sim::d_series dev(cfg);
    const ferrule::time_point boot = ferrule::time_point{} + std::chrono::hours(100);
    dev.power_on(boot);
    CHECK(dev.distance_at(boot) == 10'000);
    CHECK(dev.distance_at(boot + std::chrono::seconds(2)) == 10'400);
    dev.power_on(boot + std::chrono::seconds(10)); // a later power cycle does not restart it
    CHECK(dev.distance_at(boot + std::chrono::seconds(10)) == 12'000);
}
