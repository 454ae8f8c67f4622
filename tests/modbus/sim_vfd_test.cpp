// modbus::sim::vfd: the register map, range checks, the paper's start command (seeds/002:
// 0x0025 to 0xC800) and the speed model in simulated time.
#include <catch2/catch.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <span>

#include <vector>

#include "ferrule/core/bytes.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/client.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/data_model.hpp"
#include "ferrule/modbus/error.hpp"
#include "ferrule/modbus/pdu.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/sim/bus.hpp"
#include "ferrule/modbus/sim/vfd.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace ferrule;
using namespace ferrule::modbus;
using namespace std::chrono_literals;
namespace reg = ferrule::modbus::sim::vfd_register;
namespace st = ferrule::modbus::sim::status;
namespace ctl = ferrule::modbus::sim::control;

namespace {

constexpr std::uint8_t illegal_address = code_of(exception_code::illegal_data_address);
constexpr std::uint8_t illegal_value = code_of(exception_code::illegal_data_value);

time_point at(duration d) {
    return time_point{} + d;
}

std::uint8_t write(sim::vfd& d, std::uint16_t address, std::uint16_t v) {
    std::array<std::uint8_t, 2> b{};
    store_be16(b.data(), v);
    return d.write_registers(address, 1, b);
}

using byte_vector = std::vector<std::uint8_t>;

byte_vector rtu(std::uint8_t unit, const byte_vector& pdu) {
    byte_vector out(max_rtu_adu);
    out.resize(*encode_rtu(unit, pdu, out));
    return out;
}

// Writes `request` and reads one response frame; empty after 100 ms of silence.
byte_vector transact(mock_serial& line, const byte_vector& request) {
    REQUIRE(line.write(request).bytes == request.size());
    rtu_decoder decoder;
    const time_point deadline = line.now() + 100ms;
    std::array<std::uint8_t, 64> buf{};
    for (;;) {
        const io_result r = line.read_some(buf, deadline);
        if (r.bytes == 0) return {};
        std::span<const std::uint8_t> in(buf.data(), r.bytes);
        for (;;) {
            const auto step = decoder.feed(in);
            in = in.subspan(step.consumed);
            if (step.what == rtu_decoder::status::frame)
                return {decoder.adu().begin(), decoder.adu().end()};
            if (step.what == rtu_decoder::status::need_more) break;
        }
    }
}

std::uint16_t read(const sim::vfd& d, std::uint16_t address) {
    std::array<std::uint8_t, 2> b{};
    REQUIRE(d.read_registers(function::read_holding_registers, address, 1, b) == 0);
    return load_be16(b.data());
}

} // namespace

TEST_CASE("modbus sim vfd: factory values and the register map", "[modbus][sim]") {
    sim::vfd d;
    CHECK(read(d, reg::control_word) == 0);
    CHECK(read(d, reg::frequency_setpoint) == 0);
    CHECK(read(d, reg::status_word) == 0);
    CHECK(read(d, reg::output_frequency) == 0);
    CHECK(read(d, reg::fault_code) == 0);
    CHECK(read(d, reg::max_frequency) == 5000);
    CHECK(read(d, reg::acceleration_time) == 50);
    CHECK(read(d, reg::deceleration_time) == 50);
    CHECK(read(d, reg::baud_select) == 0);

    std::array<std::uint8_t, 10> five{};
    REQUIRE(d.read_registers(function::read_input_registers, reg::control_word, 5, five) == 0);
    std::array<std::uint8_t, 12> six{};
    CHECK(d.read_registers(function::read_holding_registers, reg::control_word, 6, six) ==
          illegal_address); // 0xC805 is not in the map
    CHECK(d.read_registers(function::read_holding_registers, 0xC7FF, 1, six) == illegal_address);
    CHECK(d.read_registers(function::read_holding_registers, 0xFFFF, 1, six) == illegal_address);
    CHECK(d.device_id(1) == "sim-vfd");
    CHECK(d.device_id(7).empty());
}

TEST_CASE("modbus sim vfd: the paper's start command 0x0025 to 0xC800 runs the drive",
          "[modbus][sim]") {
    sim::vfd d;
    d.advance(at(0s));
    REQUIRE(write(d, reg::frequency_setpoint, 2500) == 0); // 25.00 Hz
    REQUIRE(write(d, reg::control_word, 0x0025) == 0);
    CHECK(ctl::start == 0x0025);
    CHECK(read(d, reg::status_word) == (st::ready | st::running));

    // 5.0 s from 0 to 50 Hz: 25 Hz after 2.5 s.
    d.advance(at(1s));
    CHECK(read(d, reg::output_frequency) == 1000);
    d.advance(at(2500ms));
    CHECK(read(d, reg::output_frequency) == 2500);
    CHECK(read(d, reg::status_word) == (st::ready | st::running | st::at_speed));

    // Stop: run off ramps down with the deceleration time.
    REQUIRE(write(d, reg::control_word, ctl::enable | ctl::setpoint_enable) == 0);
    d.advance(at(3500ms));
    CHECK(read(d, reg::output_frequency) == 1500);
    CHECK(read(d, reg::status_word) == (st::ready | st::running));
    d.advance(at(10s));
    CHECK(read(d, reg::output_frequency) == 0);
    CHECK(read(d, reg::status_word) == st::ready);
}

TEST_CASE("modbus sim vfd: reversing falls to 0 first, enable off stops at once", "[modbus][sim]") {
    sim::vfd d;
    d.advance(at(0s));
    REQUIRE(write(d, reg::acceleration_time, 10) == 0); // 1 s to 50 Hz
    REQUIRE(write(d, reg::deceleration_time, 20) == 0); // 2 s from 50 Hz
    REQUIRE(write(d, reg::frequency_setpoint, 5000) == 0);
    REQUIRE(write(d, reg::control_word, ctl::start) == 0);
    d.advance(at(1s));
    REQUIRE(d.output() == 5000);
    REQUIRE(write(d, reg::control_word, ctl::start | ctl::reverse) == 0);
    d.advance(at(2s)); // half way down
    CHECK(d.output() == 2500);
    CHECK_FALSE(read(d, reg::status_word) & st::reverse);
    d.advance(at(3500ms)); // 0 after 2 s, then 0.5 s up in reverse
    CHECK(d.output() == -2500);
    CHECK(read(d, reg::output_frequency) == 2500);
    CHECK(read(d, reg::status_word) & st::reverse);

    REQUIRE(write(d, reg::control_word, ctl::run | ctl::setpoint_enable) == 0);
    CHECK(d.output() == 0);
    CHECK(read(d, reg::status_word) == 0);
}

TEST_CASE("modbus sim vfd: values out of range are illegal data value and change nothing",
          "[modbus][sim]") {
    sim::vfd d;
    CHECK(write(d, reg::frequency_setpoint, 5001) == illegal_value);
    CHECK(write(d, reg::frequency_setpoint, 5000) == 0);
    CHECK(write(d, reg::max_frequency, 999) == illegal_value);
    CHECK(write(d, reg::max_frequency, 40001) == illegal_value);
    CHECK(write(d, reg::acceleration_time, 6001) == illegal_value);
    CHECK(write(d, reg::baud_select, 4) == illegal_value);
    CHECK(write(d, reg::baud_select, 3) == 0);
    CHECK(write(d, reg::control_word, 0x0010) == illegal_value); // reserved bit 4
    CHECK(write(d, reg::control_word, 0x8025) == illegal_value);
    CHECK(read(d, reg::control_word) == 0);
    // Read-only and unmapped registers.
    CHECK(write(d, reg::status_word, 0) == illegal_address);
    CHECK(write(d, reg::output_frequency, 0) == illegal_address);
    CHECK(write(d, 0xC805, 0) == illegal_address);

    // A multi-register write is checked whole: the bad second value leaves the first alone.
    const std::array<std::uint8_t, 4> both{0x00, 0x25, 0x13, 0x89}; // start, 50.01 Hz
    CHECK(d.write_registers(reg::control_word, 2, both) == illegal_value);
    CHECK(read(d, reg::control_word) == 0);
    CHECK(read(d, reg::frequency_setpoint) == 5000);
    // Control word + setpoint in one FC 16, the usual drive mapping (modbus_profibus.md §E).
    const std::array<std::uint8_t, 4> ok{0x00, 0x25, 0x09, 0xC4}; // start, 25.00 Hz
    CHECK(d.write_registers(reg::control_word, 2, ok) == 0);
    CHECK(read(d, reg::frequency_setpoint) == 2500);
    // A lower max frequency written with a setpoint above it is refused as a whole.
    const std::array<std::uint8_t, 2> max_low{0x03, 0xE8};
    CHECK(write(d, reg::frequency_setpoint, 4000) == 0);
    CHECK(d.write_registers(reg::max_frequency, 1, max_low) == 0); // setpoint is limited
    CHECK(write(d, reg::frequency_setpoint, 1001) == illegal_value);
}

TEST_CASE("modbus sim vfd: a fault stops the drive until a fault reset edge", "[modbus][sim]") {
    sim::vfd d;
    d.advance(at(0s));
    REQUIRE(write(d, reg::frequency_setpoint, 1000) == 0);
    REQUIRE(write(d, reg::control_word, ctl::start) == 0);
    d.advance(at(5s));
    REQUIRE(d.output() == 1000);
    d.trip(0x2310);
    CHECK(d.output() == 0);
    CHECK(read(d, reg::fault_code) == 0x2310);
    CHECK(read(d, reg::status_word) == st::fault);
    // Writing the start again does not clear it; the reset bit's rising edge does.
    REQUIRE(write(d, reg::control_word, ctl::start) == 0);
    CHECK(read(d, reg::fault_code) == 0x2310);
    REQUIRE(write(d, reg::control_word, ctl::start | ctl::fault_reset) == 0);
    CHECK(read(d, reg::fault_code) == 0);
    CHECK(read(d, reg::status_word) == (st::ready | st::running));
    REQUIRE(write(d, reg::control_word, ctl::start | ctl::fault_reset) == 0);
    d.trip(1);
    REQUIRE(write(d, reg::control_word, ctl::start | ctl::fault_reset) == 0); // no edge
    CHECK(d.fault_code() == 1);
}

TEST_CASE("modbus sim vfd: coils are the control word, discrete inputs the status word",
          "[modbus][sim]") {
    sim::vfd d;
    REQUIRE(write(d, reg::frequency_setpoint, 1000) == 0);
    const std::array<std::uint8_t, 1> on{0x01};
    REQUIRE(d.write_coils(2, 1, on) == 0); // enable
    REQUIRE(d.write_coils(5, 1, on) == 0); // setpoint enable
    REQUIRE(d.write_coils(0, 1, on) == 0); // run
    CHECK(d.control_word() == 0x0025);
    std::array<std::uint8_t, 2> bits{};
    REQUIRE(d.read_bits(function::read_coils, 0, 16, bits) == 0);
    CHECK(bits == std::array<std::uint8_t, 2>{0x25, 0x00});
    std::array<std::uint8_t, 1> s{};
    REQUIRE(d.read_bits(function::read_discrete_inputs, 0, 5, s) == 0);
    CHECK(s[0] == (st::ready | st::running));
    CHECK(d.write_coils(4, 1, on) == illegal_value); // reserved
    CHECK(d.write_coils(15, 2, on) == illegal_address);
    CHECK(d.read_bits(function::read_coils, 16, 1, s) == illegal_address);
}

TEST_CASE("modbus sim bus: two drives on one line, started by the paper's command",
          "[modbus][sim]") {
    sim::bus<4> bus;
    server_config cfg;
    REQUIRE(bus.add(cfg));
    cfg.units = {2};
    cfg.processing_time = 5ms;
    REQUIRE(bus.add(cfg));
    mock_serial line(default_format, &bus);

    // seeds/002: 01 06 C8 00 00 25 76 71, echoed by drive 1.
    const byte_vector start{0x01, 0x06, 0xC8, 0x00, 0x00, 0x25, 0x76, 0x71};
    const time_point sent_at = line.now();
    CHECK(transact(line, start) == start);
    // The reply starts t3.5 after the request and takes 8 characters.
    const duration eight = default_format.chars_time(8);
    CHECK(line.now() == sent_at + eight + t35(default_format) + eight);
    CHECK(bus[0].drive().control_word() == sim::control::start);
    CHECK(bus[1].drive().control_word() == 0);

    // Drive 2: setpoint + start in one FC 16, then the status and output frequency with FC 3.
    CHECK(transact(line, rtu(2, {0x10, 0xC8, 0x00, 0x00, 0x02, 0x04, 0x00, 0x25, 0x13, 0x88})) ==
          rtu(2, {0x10, 0xC8, 0x00, 0x00, 0x02}));
    line.advance(2500ms); // half of the 5 s ramp to 50 Hz
    const byte_vector status = transact(line, rtu(2, {0x03, 0xC8, 0x02, 0x00, 0x02}));
    REQUIRE(status.size() == 9);
    CHECK(load_be16(&status[3]) == (sim::status::ready | sim::status::running));
    const auto f = load_be16(&status[5]);
    // 0.01 Hz per ms: the ramp began when the FC 16 arrived, the read is done when its
    // request has arrived, some 20 ms of wire time and turnaround on either side.
    CHECK(f >= 2500);
    CHECK(f <= 2520);

    // A broadcast stops both; nobody answers.
    CHECK(transact(line, rtu(0, {0x06, 0xC8, 0x00, 0x00, 0x04})).empty());
    CHECK(bus[0].drive().control_word() == sim::control::enable);
    CHECK(bus[1].drive().control_word() == sim::control::enable);
    // An out-of-range setpoint: exception 03 from drive 2.
    CHECK(transact(line, rtu(2, {0x06, 0xC8, 0x01, 0x13, 0x89})) == rtu(2, {0x86, 0x03}));
    // Unit 3 is not on the line.
    CHECK(transact(line, rtu(3, {0x03, 0xC8, 0x02, 0x00, 0x01})).empty());
}

TEST_CASE("modbus sim bus: fault knobs and a request ended by silence", "[modbus][sim]") {
    sim::bus<1> bus;
    REQUIRE(bus.add());
    REQUIRE(bus.add() == nullptr);
    mock_serial line(default_format, &bus);
    const byte_vector read_status = rtu(1, {0x03, 0xC8, 0x02, 0x00, 0x01});
    bus.drop_replies(1);
    CHECK(transact(line, read_status).empty());
    bus.corrupt_replies(1, 3);
    const byte_vector corrupted = transact(line, read_status);
    CHECK(corrupted.empty()); // the response decoder drops it: CRC error
    CHECK(transact(line, read_status) == rtu(1, {0x03, 0x02, 0x00, 0x00}));
    // FC 0x41 cannot be framed by length: the station answers 01 after t3.5 of silence.
    CHECK(transact(line, rtu(1, {0x41, 0x00})) == rtu(1, {0xC1, 0x01}));
    CHECK(bus.replies_sent() == 3);
    CHECK(bus.replies_dropped() == 1);
}

TEST_CASE("modbus sim bus: the codec's client runs the paper's four command classes",
          "[modbus][sim]") {
    sim::bus<1> bus;
    REQUIRE(bus.add());
    mock_serial line(default_format, &bus);
    client c;
    // Write parameters: 1 s ramps, 40 Hz; start (the paper's command); read status and the
    // output frequency; read a parameter back.
    REQUIRE_FALSE(write_register(line, c, 1, reg::acceleration_time, 10));
    REQUIRE_FALSE(write_register(line, c, 1, reg::frequency_setpoint, 4000));
    REQUIRE_FALSE(write_register(line, c, 1, reg::control_word, 0x0025));
    line.advance(2s);
    std::array<std::uint16_t, 2> state{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, reg::status_word, state));
    CHECK(state[0] == (st::ready | st::running | st::at_speed));
    CHECK(state[1] == 4000);
    std::array<std::uint16_t, 1> ramp{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, reg::acceleration_time, ramp));
    CHECK(ramp[0] == 10);
    // Refusals come back as the device's exception codes.
    CHECK(write_register(line, c, 1, reg::frequency_setpoint, 6000) ==
          ferrule::error(device_errc::illegal_data_value));
    CHECK(write_register(line, c, 1, reg::output_frequency, 0) ==
          ferrule::error(device_errc::illegal_data_address));
    // Stop, and the diagnostic counters of the station's server.
    REQUIRE_FALSE(write_register(line, c, 1, reg::control_word, ctl::enable));
    const auto messages = diagnostics(line, c, 1, diag_sub::server_message_count);
    REQUIRE(messages);
    CHECK(*messages == 9);
    const auto exceptions = diagnostics(line, c, 1, diag_sub::bus_exception_count);
    REQUIRE(exceptions);
    CHECK(*exceptions == 2);
}
