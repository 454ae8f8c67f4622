// The Dimetix sensor session, codec and simulator never allocate: steady-state traffic on a
// simulated multi-drop line runs with the counting global operator new of counting_new.hpp
// and the count must not move.
#include <catch2/catch.hpp>

#include <array>
#include <atomic>
#include <cstddef>
#include <memory>

#include "ferrule/core/driver.hpp"
#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/dimetix/access.hpp"
#include "ferrule/dimetix/sim/bus.hpp"

// The counter of counting_new.hpp, whose operator new may be defined in one file only
// (no_heap_test.cpp): an inline variable, so this identical declaration names the same one.
namespace ferrule_test {
inline std::atomic<std::size_t> allocations{0};
} // namespace ferrule_test

using namespace std::chrono_literals;
using namespace ferrule::dimetix;

TEST_CASE("Dimetix measurements, buffered tracking and faults allocate nothing",
          "[alloc][dimetix]") {
    auto devices = std::make_unique<sim::bus<3>>();
    for (std::uint8_t id : {1, 11, 42}) {
        sim::d_series_config cfg;
        cfg.id = id;
        cfg.noise = 5;
        devices->add(cfg);
    }
    auto line = std::make_unique<ferrule::mock_serial>(default_format, devices.get());
    auto s = std::make_unique<sensor>();

    // The counter is the one operator new counts.
    const auto probe_before = ferrule_test::allocations.load();
    auto probe = std::make_unique<int>(1);
    REQUIRE(ferrule_test::allocations.load() == probe_before + 1);

    std::size_t failures = 0;
    const auto before = ferrule_test::allocations.load();
    for (std::uint8_t id : {1, 11, 42}) failures += static_cast<bool>(connect(*line, *s, id));
    for (std::uint8_t id : {1, 11, 42})
        failures += static_cast<bool>(start_buffered_tracking(*line, *s, id, 100));
    for (int i = 0; i < 60; ++i) {
        const std::uint8_t id = i % 3 == 0 ? 1 : i % 3 == 1 ? 11 : 42;
        if (i % 10 == 5) devices->drop_replies(1);
        if (i % 10 == 7) devices->corrupt_replies(1, 2, 0x80);
        failures += !read_buffer(*line, *s, id);
        failures += !temperature(*line, *s, id);
        line->clear_wire_log();
    }
    for (std::uint8_t id : {1, 11, 42}) failures += static_cast<bool>(stop(*line, *s, id));
    failures += !measure(*line, *s, 42);
    const auto r = transact(*line, *s, *set(1, "1", std::array{500, 495}));
    failures += !r;
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(failures == 0);
    CHECK(s->stats().timeouts == 6);
    CHECK(s->stats().malformed_lines == 6);
}
