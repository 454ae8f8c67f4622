// The Dimetix sensor session through every failure point of a measurement
// (tests/core/failure_sweep.hpp), a silent sensor and the end of the stream, against a
// simulated D-Series.
#include <catch2/catch.hpp>

#include "../core/failure_sweep.hpp"
#include "ferrule/dimetix/access.hpp"
#include "ferrule/dimetix/sim/bus.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace ferrule::dimetix;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::result;
using ferrule::test::injected;

namespace {

struct rig {
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    sensor s;
    rig() { bus.add(); } // ID 0, a constant 1234.5 mm
};

result<measurement> measure_0(rig& r) {
    return measure(r.line, r.s, 0);
}

void measured(rig& r, const result<measurement>& m) {
    REQUIRE(m);
    CHECK(m->distance == 12345);
    CHECK_FALSE(r.s.error());
}

// Nothing of an answer was taken for the failed command.
void no_answer(const rig& r, const result<measurement>& m, std::error_code expected) {
    CHECK_FALSE(m);
    CHECK(m.error() == expected);
    CHECK(r.s.reply().count == 0);
    ferrule::test::failed_once(r.s, expected);
}

} // namespace

TEST_CASE("dimetix sensor failure sweep", "[dimetix][sensor][sweep]") {
    ferrule::test::failure_sweep<rig>(
        measure_0,
        [](rig& r, const result<measurement>& m, std::size_t k) {
            ferrule::test::ended_at_failure(r.line, r.s, k);
            no_answer(r, m, injected);
            CHECK(r.s.attempts() == 1); // not resent
            CHECK_FALSE(r.s.fault_latched());
        },
        measured);
}

TEST_CASE("dimetix sensor: a silent sensor, resends, the fault latch and sNc",
          "[dimetix][sensor][sweep]") {
    rig r;
    r.bus.drop_replies(3); // the first attempt and the 2 resends
    const auto m = measure_0(r);
    no_answer(r, m, errc::timeout);
    CHECK(r.s.attempts() == 3);
    CHECK(r.s.stats().timeouts == 3);
    CHECK(r.s.stats().resends == 2);
    CHECK(r.s.consecutive_failures() == 1);
    CHECK_FALSE(r.s.fault_latched());
    measured(r, measure_0(r));

    r.bus.drop_replies(5 * 3); // 5 failed commands in a row (fault_threshold)
    for (int i = 0; i < 5; ++i) CHECK(measure_0(r).error() == errc::timeout);
    CHECK(r.s.fault_latched());
    CHECK(measure_0(r).error() == errc::fault_latched);
    REQUIRE_FALSE(connect(r.line, r.s, 0)); // gN? has the sensor back in hand
    CHECK_FALSE(r.s.fault_latched());
    measured(r, measure_0(r));
}

TEST_CASE("dimetix sensor: the end of the stream ends the command", "[dimetix][sensor][sweep]") {
    rig r;
    r.line.end_of_stream();
    const auto m = measure_0(r);
    no_answer(r, m, errc::transport);
    CHECK(r.s.attempts() == 1);
    CHECK_FALSE(r.s.fault_latched());
    r.line.end_of_stream(false);
    measured(r, measure_0(r));
}
