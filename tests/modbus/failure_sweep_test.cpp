// Modbus client (RTU and TCP) and server (the simulated VFD's station, RTU and TCP) through
// every failure point of a transaction (tests/core/failure_sweep.hpp), a silent server and the
// end of the stream.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <vector>

#include "../core/failure_sweep.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/sim/bus.hpp"
#include "ferrule/modbus/tcp.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule::modbus;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::test::injected;
namespace reg = ferrule::modbus::sim::vfd_register;

namespace {

using registers = std::array<std::uint16_t, 3>;
// Max frequency 50.00 Hz, acceleration and deceleration time 5.0 s: the VFD's defaults.
constexpr registers ramp{5000, 50, 50};
constexpr registers untouched{0xDEAD, 0xDEAD, 0xDEAD};

client_config client_cfg(bool rtu) {
    client_config cfg;
    cfg.rtu = rtu;
    cfg.retries = 2;
    cfg.response_timeout = 100ms;
    return cfg;
}

server_config server_cfg(bool rtu) {
    server_config cfg;
    cfg.transport = rtu ? transport::rtu : transport::tcp;
    return cfg;
}

template <bool Rtu>
struct client_rig {
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    client c{client_cfg(Rtu)};
    registers out = untouched;
    client_rig() { bus.add(server_cfg(Rtu)); }
};

template <class Rig>
std::error_code read_ramp(Rig& r) {
    r.out = untouched;
    return read_holding_registers(r.line, r.c, 1, reg::max_frequency, r.out);
}

template <class Rig>
void read_the_ramp(Rig& r, std::error_code ec) {
    CHECK_FALSE(ec);
    CHECK(r.out == ramp);
}

template <class Rig>
void nothing_read(const Rig& r, std::error_code ec, std::error_code expected) {
    CHECK(ec == expected);
    CHECK(r.out == untouched);
    ferrule::test::failed_once(r.c, expected);
}

template <bool Rtu>
void sweep_client() {
    using rig = client_rig<Rtu>;
    ferrule::test::failure_sweep<rig>(
        read_ramp<rig>,
        [](rig& r, std::error_code ec, std::size_t k) {
            ferrule::test::ended_at_failure(r.line, r.c, k);
            nothing_read(r, ec, injected);
            CHECK(r.c.attempts() == 1); // not resent
        },
        read_the_ramp<rig>);
}

template <bool Rtu>
void silent_then_closed() {
    client_rig<Rtu> r;
    r.bus.drop_replies(3); // the first attempt and the 2 resends
    nothing_read(r, read_ramp(r), errc::timeout);
    CHECK(r.c.attempts() == 3);
    CHECK(r.c.stats().timeouts == 3);
    CHECK(r.c.stats().resends == 2);
    read_the_ramp(r, read_ramp(r));

    client_rig<Rtu> closed;
    closed.line.end_of_stream();
    nothing_read(closed, read_ramp(closed), errc::transport);
    CHECK(closed.c.attempts() == 1);
    closed.line.end_of_stream(false);
    read_the_ramp(closed, read_ramp(closed));
}

} // namespace

TEST_CASE("modbus RTU client failure sweep", "[modbus][client][sweep]") {
    sweep_client<true>();
}

TEST_CASE("modbus TCP client failure sweep", "[modbus][client][tcp][sweep]") {
    sweep_client<false>();
}

TEST_CASE("modbus RTU client: a silent server, then the end of the stream",
          "[modbus][client][sweep]") {
    silent_then_closed<true>();
}

TEST_CASE("modbus TCP client: a silent server, then the end of the stream",
          "[modbus][client][tcp][sweep]") {
    silent_then_closed<false>();
}

namespace {

// FC 3, 3 registers from 0xC900 (max frequency), and the VFD's answer.
constexpr std::array<std::uint8_t, 5> read_pdu{0x03, 0xC9, 0x00, 0x00, 0x03};
constexpr std::array<std::uint8_t, 8> ramp_pdu{0x03, 0x06, 0x13, 0x88, 0x00, 0x32, 0x00, 0x32};

std::vector<std::uint8_t> adu(bool rtu, std::span<const std::uint8_t> pdu) {
    std::vector<std::uint8_t> out(max_tcp_adu);
    out.resize(rtu ? *encode_rtu(1, pdu, out) : *encode_tcp(7, 1, pdu, out));
    return out;
}

template <bool Rtu>
struct station_rig {
    mock_serial line{default_format};
    sim::station st{server_cfg(Rtu)};
};

template <bool Rtu>
ferrule::test::served serve_read(station_rig<Rtu>& r) {
    return ferrule::test::serve_request(r.line, r.st, adu(Rtu, read_pdu), 100ms);
}

template <bool Rtu>
void answered_ramp(station_rig<Rtu>&, const ferrule::test::served& s) {
    CHECK(s.errors == 0);
    CHECK(s.sent == adu(Rtu, ramp_pdu));
}

} // namespace

TEST_CASE("modbus RTU server failure sweep", "[modbus][server][sweep]") {
    ferrule::test::station_sweep<station_rig<true>>(serve_read<true>, answered_ramp<true>);
}

TEST_CASE("modbus TCP server failure sweep", "[modbus][server][tcp][sweep]") {
    ferrule::test::station_sweep<station_rig<false>>(serve_read<false>, answered_ramp<false>);
}

TEST_CASE("modbus client: fault_threshold failed attempts in a row latch the fault",
          "[modbus][client][latch]") {
    client_rig<true> r;
    client_config cfg = client_cfg(true);
    cfg.fault_threshold = 4;
    r.c = client(cfg);
    r.bus.drop_replies(3); // the first read: 3 attempts, 3 failures in a row
    CHECK(read_ramp(r) == errc::timeout);
    CHECK(r.c.consecutive_failures() == 3);
    CHECK_FALSE(r.c.fault_latched());
    // An exception response is the 4th failure in a row: latched.
    std::array<std::uint16_t, 1> reserved{};
    CHECK(read_holding_registers(r.line, r.c, 1, 0x0001, reserved) ==
          device_errc::illegal_data_address);
    CHECK(r.c.fault_latched());
    const std::size_t writes = r.line.writes();
    CHECK(read_ramp(r) == errc::fault_latched);
    CHECK(r.out == untouched);
    CHECK(r.line.writes() == writes); // refused before anything was sent
    r.c.reset_fault();
    CHECK(r.c.consecutive_failures() == 0);
    read_the_ramp(r, read_ramp(r));

    r.bus.drop_replies(2); // a success clears the count: 2 + 3 failures latch nothing
    read_the_ramp(r, read_ramp(r));
    CHECK(r.c.consecutive_failures() == 0);
    r.bus.drop_replies(3);
    CHECK(read_ramp(r) == errc::timeout);
    CHECK(r.c.consecutive_failures() == 3);
    CHECK_FALSE(r.c.fault_latched());
}

TEST_CASE("modbus client without a fault latch: failures never latch", "[modbus][client][latch]") {
    sim::bus<1> bus;
    bus.add(server_cfg(true));
    mock_serial line{default_format, &bus};
    client_config cfg = client_cfg(true);
    cfg.fault_threshold = 1;
    basic_client<link_mode::rtu, all_functions, ferrule::no_fault_latch> c{cfg};
    bus.drop_replies(6);
    registers out = untouched;
    for (int i = 0; i < 2; ++i)
        CHECK(read_holding_registers(line, c, 1, reg::max_frequency, out) == errc::timeout);
    CHECK(c.attempts() == 3); // resent while retries are left, as with the latch
    CHECK_FALSE(c.fault_latched());
    REQUIRE_FALSE(read_holding_registers(line, c, 1, reg::max_frequency, out));
    CHECK(out == ramp);
}
