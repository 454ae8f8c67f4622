// The Modbus server, its data models and the simulated VFD line never allocate: every
// function code, exceptions, broadcasts, diagnostics and CRC errors over RTU and TCP, with
// the counting global operator new of counting_new.hpp, and the count must not move.
#include <catch2/catch.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/modbus/memory_model.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/server.hpp"
#include "ferrule/modbus/sim/bus.hpp"
#include "ferrule/modbus/tcp.hpp"

// The counter of counting_new.hpp, whose operator new may be defined in one file only
// (no_heap_test.cpp): an inline variable, so this identical declaration names the same one.
namespace ferrule_test {
inline std::atomic<std::size_t> allocations{0};
} // namespace ferrule_test

using namespace std::chrono_literals;
using namespace ferrule;
using namespace ferrule::modbus;

namespace {

using byte_vector = std::vector<std::uint8_t>;

// One request PDU of every kind the server handles, good and bad.
const std::vector<byte_vector> pdus{
    {0x01, 0x00, 0x00, 0x00, 0x20},
    {0x02, 0x00, 0x00, 0x00, 0x08},
    {0x03, 0x00, 0x00, 0x00, 0x7D},
    {0x04, 0x00, 0x00, 0x00, 0x08},
    {0x05, 0x00, 0x01, 0xFF, 0x00},
    {0x06, 0x00, 0x02, 0x12, 0x34},
    {0x08, 0x00, 0x00, 0xAB, 0xCD},
    {0x08, 0x00, 0x0B, 0x00, 0x00},
    {0x0F, 0x00, 0x00, 0x00, 0x0A, 0x02, 0xCD, 0x01},
    {0x10, 0x00, 0x00, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02},
    {0x17, 0x00, 0x00, 0x00, 0x02, 0x00, 0x05, 0x00, 0x01, 0x02, 0xBE, 0xEF},
    {0x2B, 0x0E, 0x01, 0x00},
    {0x2B, 0x0E, 0x04, 0x02},
    {0x03, 0xFF, 0x00, 0x00, 0x7D},
    {0x05, 0x00, 0x01, 0x12, 0x34},
    {0x07},
};

byte_vector rtu(std::uint8_t unit, const byte_vector& pdu) {
    byte_vector out(max_rtu_adu);
    out.resize(*encode_rtu(unit, pdu, out));
    return out;
}

byte_vector tcp(std::uint16_t transaction, const byte_vector& pdu) {
    byte_vector out(max_tcp_adu);
    out.resize(*encode_tcp(transaction, 1, pdu, out));
    return out;
}

} // namespace

TEST_CASE("the Modbus server allocates nothing over RTU and TCP", "[alloc][modbus]") {
    std::vector<byte_vector> rtu_requests, tcp_requests;
    for (const auto& p : pdus) {
        rtu_requests.push_back(rtu(1, p));
        rtu_requests.push_back(rtu(0, p));
        rtu_requests.push_back(rtu(9, p));
        byte_vector bad = rtu(1, p);
        bad.back() ^= 0xFF;
        rtu_requests.push_back(bad);
        tcp_requests.push_back(tcp(static_cast<std::uint16_t>(tcp_requests.size()), p));
    }
    using model = memory_model<128, 64, 128, 16>;
    auto r = std::make_unique<server<model>>();
    server_config tcp_cfg;
    tcp_cfg.transport = transport::tcp;
    auto t = std::make_unique<server<model>>(tcp_cfg);

    const auto probe_before = ferrule_test::allocations.load();
    auto probe = std::make_unique<int>(1);
    REQUIRE(ferrule_test::allocations.load() == probe_before + 1);

    std::size_t replies = 0;
    time_point now{};
    const auto before = ferrule_test::allocations.load();
    for (int round = 0; round < 10; ++round) {
        for (const auto& req : rtu_requests) {
            now += 10ms;
            r->on_receive(req, now);
            for (auto a = r->next(now); a.what != session_action::kind::idle; a = r->next(now)) {
                if (a.what == session_action::kind::send) ++replies;
                if (a.what == session_action::kind::wait) now = a.deadline;
            }
        }
        for (const auto& req : tcp_requests) {
            t->on_receive(req, now);
            for (auto a = t->next(now); a.what != session_action::kind::idle; a = t->next(now))
                if (a.what == session_action::kind::send) ++replies;
        }
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(replies == 10 * 2 * pdus.size());
    CHECK(r->stats().bad_crc == 10 * pdus.size());
}

TEST_CASE("the simulated Modbus VFD line allocates nothing", "[alloc][modbus]") {
    auto bus = std::make_unique<sim::bus<2>>();
    REQUIRE(bus->add());
    server_config cfg;
    cfg.units = {2};
    REQUIRE(bus->add(cfg));
    auto line = std::make_unique<mock_serial>(default_format, bus.get());
    const byte_vector start = rtu(1, {0x06, 0xC8, 0x00, 0x00, 0x25});
    const byte_vector status = rtu(2, {0x03, 0xC8, 0x02, 0x00, 0x03});
    const byte_vector setpoint = rtu(2, {0x06, 0xC8, 0x01, 0x13, 0x88});

    std::array<std::uint8_t, 64> buf{};
    std::size_t received = 0;
    const auto before = ferrule_test::allocations.load();
    for (int i = 0; i < 50; ++i) {
        for (const auto* req : {&start, &setpoint, &status}) {
            (void)line->write(*req);
            const auto r = line->read_some(buf, line->now() + 50ms);
            received += r.bytes;
            line->advance(20ms);
            line->discard_input();
        }
        line->clear_wire_log();
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(received > 0);
    CHECK((*bus)[0].drive().control_word() == 0x0025);
}
