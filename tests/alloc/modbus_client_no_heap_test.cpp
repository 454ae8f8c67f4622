// The Modbus client and codecs never allocate: reads, writes, broadcasts, CRC errors,
// timeouts and exceptions on a scripted line, RTU and TCP, run with the counting global
// operator new of counting_new.hpp and the count must not move.
#include <catch2/catch.hpp>

#include <array>
#include <atomic>
#include <cstddef>
#include <memory>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/tcp.hpp"

// The counter of counting_new.hpp, whose operator new may be defined in one file only
// (no_heap_test.cpp): an inline variable, so this identical declaration names the same one.
namespace ferrule_test {
inline std::atomic<std::size_t> allocations{0};
} // namespace ferrule_test

using namespace std::chrono_literals;
using namespace ferrule::modbus;

namespace {

std::vector<std::uint8_t> rtu(std::uint8_t unit, const std::vector<std::uint8_t>& pdu) {
    std::vector<std::uint8_t> out(max_rtu_adu);
    out.resize(*encode_rtu(unit, pdu, out));
    return out;
}
std::vector<std::uint8_t> tcp(std::uint16_t id, std::uint8_t unit,
                              const std::vector<std::uint8_t>& pdu) {
    std::vector<std::uint8_t> out(max_tcp_adu);
    out.resize(*encode_tcp(id, unit, pdu, out));
    return out;
}

} // namespace

TEST_CASE("modbus client RTU traffic allocates nothing", "[alloc][modbus]") {
    // Every script step and frame is built before counting starts.
    const auto read = rtu(1, {0x03, 0x00, 0x10, 0x00, 0x02});
    const auto regs = rtu(1, {0x03, 0x04, 0x12, 0x34, 0x56, 0x78});
    const auto write = rtu(1, {0x10, 0x00, 0x20, 0x00, 0x02, 0x04, 0x00, 0x01, 0x00, 0x02});
    const auto written = rtu(1, {0x10, 0x00, 0x20, 0x00, 0x02});
    const auto broadcast = rtu(0, {0x05, 0x00, 0x07, 0xFF, 0x00});
    const auto coils = rtu(1, {0x01, 0x00, 0x00, 0x00, 0x0A});
    const auto exception = rtu(1, {0x81, 0x02});
    std::vector<ferrule::script_step> steps;
    for (int i = 0; i < 20; ++i) {
        ferrule::script_step r;
        r.expect = read;
        r.reply = regs;
        r.delay = 3ms;
        if (i % 5 == 2) r.corrupt_index = 7; // bad CRC, resent
        if (i % 5 == 4) r.reply = {};        // timeout, resent
        steps.push_back(r);
        if (i % 5 == 2 || i % 5 == 4) {
            r.corrupt_index = -1;
            r.reply = regs;
            steps.push_back(r);
        }
        ferrule::script_step w;
        w.expect = write;
        w.reply = written;
        w.delay = 3ms;
        steps.push_back(w);
        ferrule::script_step b;
        b.expect = broadcast;
        steps.push_back(b);
        ferrule::script_step c;
        c.expect = coils;
        c.reply = exception;
        c.delay = 3ms;
        steps.push_back(c);
    }
    auto peer = std::make_unique<ferrule::script_peer>(steps);
    auto line = std::make_unique<ferrule::mock_serial>(
        ferrule::serial_format{9600, 8, ferrule::parity::even, 1}, peer.get());
    client_config cfg;
    cfg.format = line->format();
    cfg.inter_frame_gap = t35(cfg.format);
    cfg.response_timeout = 100ms;
    cfg.turnaround = 20ms;
    cfg.retries = 1;
    auto c = std::make_unique<client>(cfg);

    // The counter is the one operator new counts.
    const auto probe_before = ferrule_test::allocations.load();
    auto probe = std::make_unique<int>(1);
    REQUIRE(ferrule_test::allocations.load() == probe_before + 1);

    std::size_t failures = 0;
    std::size_t exceptions = 0;
    const auto before = ferrule_test::allocations.load();
    for (int i = 0; i < 20; ++i) {
        std::array<std::uint16_t, 2> r{};
        failures += static_cast<bool>(read_holding_registers(*line, *c, 1, 0x10, r));
        failures += to_u32(r[0], r[1]) != 0x12345678;
        const std::array<std::uint16_t, 2> w{1, 2};
        failures += static_cast<bool>(write_registers(*line, *c, 1, 0x20, w));
        failures += static_cast<bool>(write_coil(*line, *c, 0, 7, true));
        std::array<bool, 10> bits{};
        exceptions += read_coils(*line, *c, 1, 0, bits) == device_errc::illegal_data_address;
        line->clear_wire_log();
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(failures == 0);
    CHECK(exceptions == 20);
    CHECK(peer->finished());
    CHECK(peer->mismatches() == 0);
    CHECK(c->stats().timeouts == 4);
    CHECK(c->stats().bad_checksums == 4);
    CHECK(c->stats().broadcasts == 20);
}

TEST_CASE("modbus client TCP traffic allocates nothing", "[alloc][modbus]") {
    std::vector<std::vector<std::uint8_t>> frames;
    std::vector<ferrule::script_step> steps;
    frames.reserve(64);
    for (std::uint16_t id = 1; id <= 30; ++id) {
        frames.push_back(tcp(id, 5, {0x04, 0x00, 0x00, 0x00, 0x01}));
        frames.push_back(tcp(id, 5, {0x04, 0x02, 0x00, static_cast<std::uint8_t>(id)}));
    }
    for (std::size_t i = 0; i < frames.size(); i += 2) {
        ferrule::script_step s;
        s.expect = frames[i];
        s.reply = frames[i + 1];
        s.delay = 1ms;
        steps.push_back(s);
    }
    auto peer = std::make_unique<ferrule::script_peer>(steps);
    auto line = std::make_unique<ferrule::mock_serial>(
        ferrule::serial_format{115200, 8, ferrule::parity::none, 1}, peer.get());
    client_config cfg;
    cfg.rtu = false;
    auto c = std::make_unique<client>(cfg);
    std::size_t failures = 0;
    const auto before = ferrule_test::allocations.load();
    for (std::uint16_t id = 1; id <= 30; ++id) {
        std::array<std::uint16_t, 1> r{};
        failures += static_cast<bool>(read_input_registers(*line, *c, 5, 0, r));
        failures += r[0] != id;
        line->clear_wire_log();
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(failures == 0);
    CHECK(peer->mismatches() == 0);
}
