// sim::movitrac_b (parameter channel, handshake, process data, motor model), sim::bus on a
// mock_serial line, and the master driving it end to end (movilink.md §2-§4).
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <span>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/movilink/cyclic.hpp"
#include "ferrule/movilink/error.hpp"
#include "ferrule/movilink/frame.hpp"
#include "ferrule/movilink/master.hpp"
#include "ferrule/movilink/process_data.hpp"
#include "ferrule/movilink/sim/bus.hpp"
#include "ferrule/movilink/sim/movitrac_b.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace ferrule;
using namespace ferrule::movilink;
using namespace std::chrono_literals;
namespace ix = ferrule::movilink::sim::parameter_index;

namespace {

using byte_vector = std::vector<std::uint8_t>;
using words = std::array<std::uint16_t, 3>;

// Golden vectors, movilink.md §4.
const byte_vector m1{0x02, 0x01, 0x05, 0x00, 0x06, 0x3A, 0x98, 0x01, 0xF4, 0x57};
const byte_vector m2_req{0x02, 0x01, 0x85, 0x00, 0x06, 0x20, 0x00, 0x0B, 0xB8, 0x13};
const byte_vector m2_rsp{0x1D, 0x01, 0x85, 0x02, 0x06, 0x00, 0x00, 0x06, 0x06, 0x9D};
const byte_vector d2{0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x7E, 0x00, 0x00, 0x00, 0x00, 0xEA};
const byte_vector d3{0x1D, 0x01, 0x86, 0x31, 0x00, 0x20, 0x87, 0x00, 0x00, 0x00, 0x14, 0x18};
const byte_vector d4{0x1D, 0x01, 0x86, 0xB1, 0x00, 0x20, 0x7E, 0x08, 0x00, 0x00, 0x10, 0x6D};
const byte_vector d5{0x02, 0x01, 0x86, 0x33, 0x00, 0x20, 0x71, 0x00, 0x00, 0x00, 0x01, 0xE6};
const byte_vector d6{0x02, 0x01, 0x04, 0x71, 0x00, 0x20, 0x7E, 0x00, 0x00,
                     0x00, 0x00, 0x00, 0x06, 0x07, 0xD0, 0x00, 0x00, 0xF9};
const byte_vector d7{0x02, 0xFF, 0x03, 0x00, 0x06, 0x10, 0x00, 0xE8};
const byte_vector d8{0x02, 0x65, 0x85, 0x00, 0x06, 0x20, 0x00, 0x0B, 0xB8, 0x77};
const byte_vector d9{0x02, 0x03, 0x01, 0x00, 0x00, 0x00};
const byte_vector d10{0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x76, 0x00, 0x00, 0x00, 0x00, 0xE2};

time_point at(duration d) {
    return time_point{} + d;
}
double seconds(duration d) {
    return std::chrono::duration<double>(d).count();
}

byte_vector encoded(const telegram& t) {
    std::array<std::uint8_t, max_telegram_size> buf{};
    const std::size_t n = *encode(t, buf);
    return {buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n)};
}
telegram parsed(const byte_vector& b) {
    return *parse(b);
}

telegram pd3(words po, pdu_type type = pdu_type::pd3, std::uint8_t adr = 1) {
    return {direction::request, adr, type, {}, po};
}
words po_words(control_word cw, double rpm, std::chrono::milliseconds ramp) {
    return {cw.value, rpm_to_digits(rpm), ramp_to_digits(ramp)};
}

// One acyclic parameter service (TYP 0x86); returns the reply's parameter channel.
param_channel service_on(sim::movitrac_b& d, param_channel p, time_point t = {}) {
    return d.handle({direction::request, 1, pdu_type::param_acyclic, p, {}}, t).param;
}
param_channel read_on(sim::movitrac_b& d, std::uint16_t index, time_point t = {}) {
    return service_on(d, param_channel::make(service::read, index), t);
}
std::int32_t value_on(sim::movitrac_b& d, std::uint16_t index, time_point t = {}) {
    return static_cast<std::int32_t>(read_on(d, index, t).data);
}
std::uint16_t additional_of(const param_channel& p) {
    REQUIRE(p.is_error());
    return p.additional_code();
}

// Everything the peer puts on the line until `deadline`.
byte_vector read_all(mock_serial& line, time_point deadline) {
    byte_vector out;
    std::array<std::uint8_t, 64> buf{};
    for (;;) {
        const io_result r = line.read_some(buf, deadline);
        if (r.bytes == 0) return out;
        out.insert(out.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(r.bytes));
    }
}

// Gap between the end of the last byte the session wrote and the first reply byte.
duration reply_gap(const mock_serial& line) {
    time_point request_end{};
    for (const wire_byte& b : line.wire()) {
        if (b.origin == wire_byte::from::session) request_end = b.end;
        if (b.origin == wire_byte::from::peer && b.start > request_end)
            return b.start - request_end;
    }
    return duration::max();
}

} // namespace

// --- the drive alone -------------------------------------------------------------------------

TEST_CASE("sim: golden parameter reads D2, D3, D10", "[movilink][sim]") {
    sim::movitrac_b d;
    SECTION("D2: P000 speed of a drive at rest") {
        CHECK(encoded(d.handle(parsed(d2), at(0ms))) ==
              byte_vector{0x1D, 0x01, 0x86, 0x31, 0x00, 0x20, 0x7E, 0x00, 0x00, 0x00, 0x00, 0xF5});
    }
    SECTION("D3: P014 heat sink temperature 20 degC is the manual's response") {
        const telegram req{direction::request,
                           1,
                           pdu_type::param_acyclic,
                           param_channel::make(service::read, ix::p014_heat_sink_temperature),
                           {}};
        CHECK(encoded(req) ==
              byte_vector{0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x87, 0x00, 0x00, 0x00, 0x00, 0x13});
        CHECK(encoded(d.handle(req, at(0ms))) == d3);
    }
    SECTION("D10: P010 inverter status = status word 1 (ready, PO data enabled, no enable)") {
        CHECK(encoded(d.handle(parsed(d10), at(0ms))) ==
              byte_vector{0x1D, 0x01, 0x86, 0x31, 0x00, 0x20, 0x76, 0x00, 0x00, 0x02, 0x06, 0xF9});
    }
}

TEST_CASE("sim: D5 write volatile P871, then P876 must be switched on again", "[movilink][sim]") {
    sim::movitrac_b d;
    CHECK(encoded(d.handle(parsed(d5), at(0ms))) ==
          byte_vector{0x1D, 0x01, 0x86, 0x33, 0x00, 0x20, 0x71, 0x00, 0x00, 0x00, 0x01, 0xF9});
    CHECK(d.find(ix::p876_po_data_enable)->value == 0); // MTB 5947017867
    CHECK(d.eeprom_writes() == 0);
    CHECK_FALSE(d.status().po_data_enabled());

    // PO data disabled: the last valid PO stay in effect.
    d.handle(pd3(po_words(control_word::enable(), 1500, 1000ms)), at(10ms));
    CHECK(d.setpoint_rpm() == 0);
    CHECK(d.control() == control_word{});
    CHECK(service_on(d, param_channel::make(service::write_volatile, ix::p876_po_data_enable, 1))
              .data == 1);
    d.handle(pd3(po_words(control_word::enable(), 1500, 1000ms)), at(20ms));
    CHECK(d.setpoint_rpm() == Approx(1500));
    CHECK(d.status().po_data_enabled());
}

TEST_CASE("sim: M1, D6 and M2 process data replies", "[movilink][sim]") {
    sim::movitrac_b d;
    SECTION("M1: enable, 3000 rpm, 500 ms ramp") {
        const telegram rsp = d.handle(parsed(m1), at(0ms));
        // PI1 0x0407 output stage on / ready / PO data enabled / unit status 4 "enable",
        // PI2 speed 0 (just enabled), PI3 70 % I_N (magnetising + accelerating).
        CHECK(encoded(rsp) ==
              byte_vector{0x1D, 0x01, 0x05, 0x04, 0x07, 0x00, 0x00, 0x02, 0xBC, 0xA4});
        // 1500 rpm per 500 ms: 750 rpm after 250 ms.
        CHECK(d.handle(parsed(m1), at(250ms)).pd[1] == rpm_to_digits(750));
        CHECK(d.handle(parsed(m1), at(2s)).pd[1] == rpm_to_digits(3000));
    }
    SECTION("D6: cyclic PARAM+3PD, read P000 with handshake 1, enable 400 rpm") {
        CHECK(encoded(d.handle(parsed(d6), at(0ms))) ==
              byte_vector{0x1D, 0x01, 0x04, 0x71, 0x00, 0x20, 0x7E, 0x00, 0x00, 0x00, 0x00, 0x04,
                          0x07, 0x00, 0x00, 0x02, 0xBC, 0x8A});
        // PO3 = 0 ms is raised to the 100 ms minimum ramp: 400 rpm after 26.7 ms.
        CHECK(d.ramp() == 100ms);
        const telegram again = d.handle(parsed(d6), at(50ms));
        CHECK(again.pd[1] == 0x07D0);
        // Same handshake bit: no new service, the stored result (speed 0) comes back.
        CHECK(again.param.data == 0);
        CHECK(d.services_executed() == 1);
        telegram toggled = parsed(d6);
        toggled.param.set_handshake(false);
        const telegram fresh = d.handle(toggled, at(60ms));
        CHECK(fresh.param.management == 0x31);
        CHECK(fresh.param.data == 400000); // 400 rpm, conversion index -3
        CHECK(d.services_executed() == 2);
    }
    SECTION("M2 without hardware enable: PI1 0x0206 and PI2 0 as in M2-rsp") {
        d.set_terminal_enable(false);
        const telegram rsp = d.handle(parsed(m2_req), at(0ms));
        const telegram manual = parsed(m2_rsp);
        CHECK(rsp.type == manual.type);
        CHECK(rsp.pd[0] == manual.pd[0]);
        CHECK(rsp.pd[1] == manual.pd[1]);
        // PI3 differs: MOVIMOT maps status word 2 there, MOVITRAC B the output current.
        CHECK(rsp.pd[2] == 0);
        CHECK(d.speed_rpm() == 0);
        d.set_terminal_enable(true);
        d.advance(at(1s));
        CHECK(d.speed_rpm() > 0);
    }
}

TEST_CASE("sim: the speed follows the ramps", "[movilink][sim]") {
    sim::movitrac_b d;
    const auto send = [&d](control_word cw, double rpm, std::chrono::milliseconds ramp,
                           time_point t) { return d.handle(pd3(po_words(cw, rpm, ramp)), t); };

    send(control_word::enable(), 1500, 1000ms, at(0ms));
    d.advance(at(400ms));
    CHECK(d.speed_rpm() == Approx(600));
    CHECK(d.output_current_percent() == Approx(70));
    CHECK(send(control_word::enable(), 1500, 1000ms, at(500ms)).pd[1] == rpm_to_digits(750));
    d.advance(at(2s));
    CHECK(d.speed_rpm() == 1500);
    CHECK(d.output_current_percent() == Approx(30));

    SECTION("stop ramps down with the PO ramp") {
        telegram rsp = send(control_word::stop(), 1500, 1000ms, at(2s));
        CHECK(status_word{rsp.pd[0]}.output_stage_enabled());
        CHECK(status_word{rsp.pd[0]}.unit_status() == status_word::unit_status_no_enable);
        d.advance(at(2200ms));
        CHECK(d.speed_rpm() == Approx(1200));
        rsp = send(control_word::stop(), 1500, 1000ms, at(4s));
        CHECK(rsp.pd[1] == 0);
        CHECK(rsp.pd[0] == 0x0206); // output stage off at standstill
    }
    SECTION("rapid stop uses the short ramp") {
        send(control_word::rapid_stop(), 1500, 1000ms, at(2s));
        d.advance(at(2100ms));
        CHECK(d.speed_rpm() == Approx(750)); // 1500 rpm per 200 ms
        d.advance(at(2200ms));
        CHECK(d.speed_rpm() == 0);
    }
    SECTION("controller inhibit holds 0 at once") {
        const telegram rsp = send(control_word::inhibit(), 1500, 1000ms, at(2s));
        CHECK(d.speed_rpm() == 0);
        CHECK(rsp.pd[0] == 0x0106); // unit status 1 "controller inhibit"
        d.advance(at(3s));
        CHECK(d.speed_rpm() == 0);
    }
    SECTION("reversing passes through 0 on the PO ramp") {
        send(control_word::enable(), -1500, 1000ms, at(2s));
        d.advance(at(3s));
        CHECK(d.speed_rpm() == Approx(0).margin(1e-9));
        CHECK(send(control_word::enable(), -1500, 1000ms, at(3500ms)).pd[1] == rpm_to_digits(-750));
    }
    SECTION("setpoints are limited to the maximum speed") {
        send(control_word::enable(), 5000, 1000ms, at(2s));
        CHECK(d.setpoint_rpm() == 3000);
    }
}

TEST_CASE("sim: injected fault, cleared by a reset edge", "[movilink][sim]") {
    sim::movitrac_b d;
    d.handle(pd3(po_words(control_word::enable(), 1500, 1000ms)), at(0ms));
    d.advance(at(2s));
    d.inject_fault(7);
    CHECK(d.speed_rpm() == 0);
    telegram rsp = d.handle(pd3(po_words(control_word::enable(), 1500, 1000ms)), at(2100ms));
    const status_word sw{rsp.pd[0]};
    CHECK(sw.fault());
    CHECK(sw.fault_number() == 7);
    CHECK_FALSE(sw.ready());
    CHECK_FALSE(sw.output_stage_enabled());
    CHECK(rsp.pd[0] == 0x0724);
    CHECK(rsp.pd[1] == 0);

    const words reset = po_words(control_word::enable().with_reset(), 1500, 1000ms);
    rsp = d.handle(pd3(reset), at(2200ms));
    CHECK(rsp.pd[0] == 0x0407);
    CHECK(d.fault_number() == 0);

    // A reset bit held high does not clear the next fault: it takes a 0 -> 1 edge.
    d.inject_fault(9);
    CHECK(d.handle(pd3(reset), at(2300ms)).pd[0] == 0x0924);
    d.handle(pd3(po_words(control_word::enable(), 1500, 1000ms)), at(2400ms));
    CHECK(d.handle(pd3(reset), at(2500ms)).pd[0] == 0x0407);
}

TEST_CASE("sim: an injected warning keeps the drive ready and running", "[movilink][sim]") {
    sim::movitrac_b d;
    const words enable = po_words(control_word::enable(), 1500, 1000ms);
    d.handle(pd3(enable), at(0ms));
    d.inject_warning(5);
    telegram rsp = d.handle(pd3(enable), at(2s));
    const status_word sw{rsp.pd[0]};
    CHECK(sw.state() == status_word::condition::warning);
    CHECK(sw.warning_number() == 5);
    CHECK_FALSE(sw.fault());
    CHECK(sw.output_stage_enabled());
    CHECK(rsp.pd[0] == 0x0527);
    CHECK(rsp.pd[1] == rpm_to_digits(1500));

    // A fault takes precedence; the reset edge clears both.
    d.inject_fault(7);
    CHECK(d.handle(pd3(enable), at(2100ms)).pd[0] == 0x0724);
    rsp = d.handle(pd3(po_words(control_word::enable().with_reset(), 1500, 1000ms)), at(2200ms));
    CHECK(rsp.pd[0] == 0x0407);
    CHECK(d.warning_number() == 0);
}

TEST_CASE("sim: parameter services and return codes", "[movilink][sim]") {
    sim::movitrac_b d;
    SECTION("read minimum / maximum / default") {
        CHECK(
            service_on(d, param_channel::make(service::read_minimum, ix::p812_rs485_timeout_delay))
                .data == 0);
        CHECK(
            service_on(d, param_channel::make(service::read_maximum, ix::p812_rs485_timeout_delay))
                .data == 650000);
        CHECK(
            service_on(d, param_channel::make(service::read_default, ix::p811_rs485_group_address))
                .data == 100);
    }
    SECTION("read scale: byte 6 quantity index, byte 7 conversion index") {
        // P812: time in s (quantity 4), 10^-3, like the manual's P131 example.
        CHECK(service_on(d, param_channel::make(service::read_scale, ix::p812_rs485_timeout_delay))
                  .data == 0x000004FD);
        // P000: conversion -3, quantity not specified (0xFF).
        CHECK(service_on(d, param_channel::make(service::read_scale, ix::p000_speed)).data ==
              0x0000FFFD);
    }
    SECTION("read attribute: next index and access attributes") {
        CHECK(service_on(d, param_channel::make(service::read_attribute, ix::p810_rs485_address))
                  .data == ((std::uint32_t{ix::p811_rs485_group_address} << 16) | 0x23));
        CHECK(service_on(d, param_channel::make(service::read_attribute, ix::p000_speed)).data ==
              (std::uint32_t{ix::p002_frequency} << 16));
        CHECK(service_on(d, param_channel::make(service::read_attribute, ix::p876_po_data_enable))
                  .data == 0x23);
    }
    SECTION("class 8 code 0 return codes") {
        const param_channel bad = read_on(d, 0x2000);
        CHECK(bad.management == 0xB1);
        CHECK(bad.error_class() == 8);
        CHECK(bad.error_code() == 0);
        CHECK(additional_of(bad) == 0x10);
        CHECK(additional_of(
                  service_on(d, param_channel::make(service::write, ix::p000_speed, 1))) == 0x12);
        CHECK(additional_of(service_on(
                  d, param_channel::make(service::write_volatile, ix::p810_rs485_address, 100))) ==
              0x15);
        CHECK(additional_of(service_on(d, param_channel::make(service::write_volatile,
                                                              ix::p811_rs485_group_address, 99))) ==
              0x16);
        CHECK(additional_of(service_on(
                  d, param_channel::make(service::write_volatile, ix::p812_rs485_timeout_delay,
                                         static_cast<std::uint32_t>(-1)))) == 0x16);
        // Same layout as the manual's D4, for index 0x2000.
        CHECK(encoded(d.handle(parsed(byte_vector{0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x00, 0x00,
                                                  0x00, 0x00, 0x00, 0x94}),
                               at(0ms))) ==
              byte_vector{0x1D, 0x01, 0x86, 0xB1, 0x00, 0x20, 0x00, 0x08, 0x00, 0x00, 0x10, 0x13});
        // The manual's D4 carries the same management byte and data word.
        CHECK(parsed(d4).param.management == bad.management);
        CHECK(parsed(d4).param.data == bad.data);
    }
    SECTION("illegal service: class 5 code 5; write with data length != 4: class 6 code 8") {
        const param_channel illegal = service_on(d, {0x39, 0, ix::p000_speed, 0});
        CHECK(illegal.is_error());
        CHECK(illegal.data == error_data(5, 5, 0));
        const param_channel short_write = service_on(d, {0x02, 0, ix::p810_rs485_address, 5});
        CHECK(short_write.is_error());
        CHECK(short_write.data == error_data(6, 8, 0));
        CHECK(d.find(ix::p810_rs485_address)->value == 0);
        // Reads ignore the data length (SC01 p.32): 0x01 works like 0x31.
        const param_channel short_read = service_on(d, {0x01, 0, ix::p811_rs485_group_address, 0});
        CHECK_FALSE(short_read.is_error());
        CHECK(short_read.management == 0x31);
        CHECK(short_read.data == 100);
    }
    SECTION("no service: echoed, nothing executed") {
        const param_channel none = service_on(d, {0x00, 0, 0, 0});
        CHECK_FALSE(none.is_error());
        CHECK(d.services_executed() == 0);
    }
}

TEST_CASE("sim: display values in the manual's units", "[movilink][sim]") {
    sim::movitrac_b d;
    const words po{0x0006, rpm_to_digits(1500), ramp_to_digits(1000ms)};
    const telegram rsp = d.handle(pd3(po), at(0ms));
    d.advance(at(500ms)); // 750 rpm, ramping
    CHECK(value_on(d, ix::p000_speed, at(500ms)) == 750000);
    CHECK(value_on(d, ix::p002_frequency, at(500ms)) == 25000); // 2 pole pairs
    CHECK(value_on(d, ix::p004_output_current, at(500ms)) == 70000);
    CHECK(value_on(d, ix::p009_output_current_a, at(500ms)) == 2800);
    CHECK(value_on(d, ix::p008_dc_link_voltage, at(500ms)) == 565000);
    CHECK(value_on(d, ix::p010_inverter_status, at(500ms)) == 0x0407);
    // P094-P096: the PO words received; P097-P099: the PI words sent.
    CHECK(value_on(d, ix::p094_po1_setpoint) == po[0]);
    CHECK(value_on(d, ix::p095_po2_setpoint) == po[1]);
    CHECK(value_on(d, ix::p096_po3_setpoint) == po[2]);
    CHECK(value_on(d, ix::p097_pi1_actual_value) == rsp.pd[0]);
    CHECK(value_on(d, ix::p098_pi2_actual_value) == rsp.pd[1]);
    CHECK(value_on(d, ix::p099_pi3_actual_value) == rsp.pd[2]);
    CHECK(read_on(d, ix::p070_unit_type).data == 0x07B00015);
}

TEST_CASE("sim: PO/PI descriptions P870-P875", "[movilink][sim]") {
    sim::movitrac_b d;
    const auto write = [&d](std::uint16_t index, std::uint32_t v) {
        return service_on(d, param_channel::make(service::write_volatile, index, v));
    };
    SECTION("PO2 as speed [%] (0x4000 = max speed)") {
        write(ix::p871_po2_description, static_cast<std::uint8_t>(sim::po_function::speed_percent));
        write(ix::p876_po_data_enable, 1);
        d.handle(pd3({0x0006, percent_to_digits(50), 1000}), at(0ms));
        CHECK(d.setpoint_rpm() == Approx(1500));
    }
    SECTION("control word not described: the drive assumes ENABLE (MTB special case)") {
        write(ix::p870_po1_description, 0);
        write(ix::p876_po_data_enable, 1);
        const telegram rsp = d.handle(pd3({0x0000, rpm_to_digits(600), 1000}), at(0ms));
        CHECK(status_word{rsp.pd[0]}.unit_status() == status_word::unit_status_enable);
        d.advance(at(1s));
        CHECK(d.speed_rpm() == Approx(600));
    }
    SECTION("the same function twice: the first PO word wins") {
        write(ix::p872_po3_description, static_cast<std::uint8_t>(sim::po_function::speed));
        write(ix::p876_po_data_enable, 1);
        d.handle(pd3({0x0006, rpm_to_digits(600), rpm_to_digits(900)}), at(0ms));
        CHECK(d.setpoint_rpm() == Approx(600));
        CHECK(d.ramp() == d.config().default_ramp);
    }
    SECTION("PI3 as status word 1, PI2 as speed [%]") {
        write(ix::p874_pi2_description, static_cast<std::uint8_t>(sim::pi_function::speed_percent));
        write(ix::p875_pi3_description, static_cast<std::uint8_t>(sim::pi_function::status_word_1));
        write(ix::p876_po_data_enable, 1);
        d.handle(pd3({0x0006, rpm_to_digits(1500), 1000}), at(0ms));
        const telegram rsp = d.handle(pd3({0x0006, rpm_to_digits(1500), 1000}), at(2s));
        CHECK(rsp.pd[1] == 0x2000); // 1500 of 3000 rpm = 50 %
        CHECK(rsp.pd[2] == rsp.pd[0]);
    }
    SECTION("description values are range checked") {
        CHECK(additional_of(write(ix::p870_po1_description, 13)) == 0x15);
        CHECK(additional_of(write(ix::p873_pi1_description, 12)) == 0x15);
    }
}

TEST_CASE("sim: cyclic handshake with a service latency", "[movilink][sim]") {
    sim::movitrac_b d;
    d.set_param_latency(2);
    const auto cyclic = [&d](bool hs, std::uint16_t index, time_point t) {
        telegram r{direction::request,
                   1,
                   pdu_type::param_3pd,
                   param_channel::make(service::read, index),
                   {0x0006, 0, 0}};
        r.param.set_handshake(hs);
        return d.handle(r, t).param;
    };
    // Toggled to 1: two requests still get the previous result (handshake 0, no service).
    CHECK(cyclic(true, ix::p811_rs485_group_address, at(0ms)).management == 0x00);
    CHECK(cyclic(true, ix::p811_rs485_group_address, at(10ms)).management == 0x00);
    param_channel done = cyclic(true, ix::p811_rs485_group_address, at(20ms));
    CHECK(done.management == 0x71);
    CHECK(done.data == 100);
    CHECK(cyclic(true, ix::p811_rs485_group_address, at(30ms)) == done);
    CHECK(d.services_executed() == 1);

    // Toggled back to 0 for P810: the P811 result keeps coming until it is done.
    CHECK(cyclic(false, ix::p810_rs485_address, at(40ms)) == done);
    CHECK(cyclic(false, ix::p810_rs485_address, at(50ms)) == done);
    done = cyclic(false, ix::p810_rs485_address, at(60ms));
    CHECK(done.management == 0x31);
    CHECK(done.index == ix::p810_rs485_address);
    CHECK(d.services_executed() == 2);

    // Acyclic types execute every request at once.
    CHECK(read_on(d, ix::p811_rs485_group_address).data == 100);
    CHECK(d.services_executed() == 3);
}

TEST_CASE("sim: RS-485 timeout P812 watches cyclic telegrams", "[movilink][sim]") {
    sim::movitrac_b d;
    const words run = po_words(control_word::enable(), 1500, 1000ms);
    CHECK_FALSE(service_on(d, param_channel::make(service::write_volatile,
                                                  ix::p812_rs485_timeout_delay, 1000))
                    .is_error());
    d.handle(pd3(run), at(0ms));
    d.advance(at(1000ms));
    CHECK(d.fault_number() == 0);
    d.advance(at(1001ms));
    CHECK(d.fault_number() == d.config().rs485_timeout_fault);
    CHECK(d.speed_rpm() == 0);

    // Reset with a cyclic telegram; acyclic ones do not feed the watchdog.
    d.handle(pd3(po_words(control_word::enable().with_reset(), 1500, 1000ms)), at(1500ms));
    CHECK(d.fault_number() == 0);
    d.handle(pd3(run, pdu_type::pd3_acyclic), at(2400ms));
    CHECK(d.fault_number() == 0);
    const telegram rsp = d.handle(pd3(run, pdu_type::pd3_acyclic), at(2600ms));
    CHECK(status_word{rsp.pd[0]}.fault_number() == 43);
}

TEST_CASE("sim: write goes to EEPROM, write volatile does not", "[movilink][sim]") {
    sim::movitrac_b d;
    CHECK_FALSE(
        service_on(d, param_channel::make(service::write, ix::p812_rs485_timeout_delay, 2000))
            .is_error());
    CHECK_FALSE(service_on(d, param_channel::make(service::write_volatile,
                                                  ix::p811_rs485_group_address, 150))
                    .is_error());
    CHECK(d.eeprom_writes() == 1);
    d.handle(pd3(po_words(control_word::enable(), 1500, 1000ms)), at(0ms));
    d.advance(at(2s));
    d.power_cycle();
    CHECK(d.find(ix::p812_rs485_timeout_delay)->value == 2000);
    CHECK(d.find(ix::p811_rs485_group_address)->value == 100);
    CHECK(d.speed_rpm() == 0);
    CHECK(d.control() == control_word{});
    CHECK(d.eeprom_writes() == 1);
}

// --- the bus on a mock_serial line -----------------------------------------------------------

TEST_CASE("sim bus: only the addressed drive answers, after the start pause", "[movilink][sim]") {
    sim::bus<2> bus;
    mock_serial line(default_format, &bus);
    auto* first = bus.add({.address = 1, .group = 101});
    auto* third = bus.add({.address = 3, .group = 101});
    REQUIRE(first);
    REQUIRE(third);
    CHECK(first->drive.find(ix::p810_rs485_address)->value == 1);
    CHECK(third->drive.find(ix::p811_rs485_group_address)->value == 101);

    SECTION("D2 for address 1") {
        line.write(d2);
        CHECK(read_all(line, line.now() + 100ms) ==
              byte_vector{0x1D, 0x01, 0x86, 0x31, 0x00, 0x20, 0x7E, 0x00, 0x00, 0x00, 0x00, 0xF5});
        CHECK(reply_gap(line) == start_pause);
        CHECK(first->session.stats().replies == 1);
        CHECK(third->session.stats().ignored_other_address == 1);
    }
    SECTION("D9 for address 3") {
        line.write(d9);
        CHECK(read_all(line, line.now() + 100ms) ==
              byte_vector{0x1D, 0x03, 0x01, 0x02, 0x06, 0x1B});
        CHECK(first->session.stats().ignored_other_address == 1);
    }
    SECTION("D7 broadcast and D8 group 101: both drives act, neither answers") {
        line.write(d7);
        CHECK(read_all(line, line.now() + broadcast_spacing).empty());
        CHECK(first->drive.setpoint_rpm() == Approx(digits_to_rpm(0x1000)));
        CHECK(third->drive.setpoint_rpm() == Approx(digits_to_rpm(0x1000)));
        line.write(d8);
        CHECK(read_all(line, line.now() + 100ms).empty());
        CHECK(first->drive.ramp() == 3000ms);
        CHECK(third->drive.ramp() == 3000ms);
        CHECK(first->session.stats().no_reply_requests == 2);
        CHECK(bus.replies_sent() == 0);
        CHECK(line.pending() == 0);
    }
    SECTION("the motor models run in line time") {
        line.write(m1);
        read_all(line, line.now() + 100ms);
        line.advance(1s);
        bus.advance(line.now());
        CHECK(first->drive.speed_rpm() == 3000);
        CHECK(third->drive.speed_rpm() == 0);
    }
}

TEST_CASE("sim bus: processing time and fault knobs", "[movilink][sim]") {
    sim::bus<1> bus;
    mock_serial line(default_format, &bus);
    bus.add({.address = 1, .processing_time = 2ms});
    CHECK(bus.add() == nullptr); // one place only

    SECTION("processing time") {
        line.write(m1);
        CHECK(read_all(line, line.now() + 100ms).size() == 10);
        CHECK(reply_gap(line) == start_pause + 2ms);
    }
    SECTION("drop the next reply") {
        bus.drop_replies(1);
        line.write(m1);
        CHECK(read_all(line, line.now() + 100ms).empty());
        CHECK(bus.replies_dropped() == 1);
        line.advance(10ms);
        line.write(m1);
        CHECK(read_all(line, line.now() + 100ms).size() == 10);
    }
    SECTION("corrupt a byte of the next two replies") {
        bus.corrupt_replies(2, 9, 0x01);
        for (int i = 0; i < 3; ++i) {
            line.write(m1);
            const byte_vector reply = read_all(line, line.now() + 100ms);
            REQUIRE(reply.size() == 10);
            const bool bcc_ok = parse(reply).has_value();
            CHECK(bcc_ok == (i == 2));
            line.advance(10ms);
        }
    }
    SECTION("delay the next reply") {
        bus.delay_replies(1, 20ms);
        line.write(m1);
        read_all(line, line.now() + 100ms);
        CHECK(reply_gap(line) == start_pause + 22ms);
    }
}

// --- end to end: master + run() + mock_serial + sim::bus -------------------------------------

TEST_CASE("end to end: cyclic 3PD runs the drive up the ramp to 1500 rpm", "[movilink][sim][e2e]") {
    sim::bus<1> bus;
    mock_serial line(default_format, &bus);
    auto* st = bus.add();
    master m;
    const words enable = po_words(control_word::enable(), 1500, 1000ms);

    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3, enable));
    REQUIRE_FALSE(run(line, m));
    CHECK(m.reply().pd == words{0x0407, 0x0000, 0x02BC});
    const time_point t0 = st->session.request_end();

    // One cycle: start pause, 10-byte request, start pause, 10-byte reply.
    const duration cycle = 2 * (start_pause + default_format.chars_time(10));
    time_point previous = t0;
    std::uint16_t last_speed = 0;
    int cycles = 0;
    while (m.reply().pd[1] != rpm_to_digits(1500) && cycles < 100) {
        REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3, enable));
        REQUIRE_FALSE(run(line, m));
        ++cycles;
        const time_point t = st->session.request_end();
        CHECK(t - previous == cycle);
        previous = t;
        // 1500 rpm per 1000 ms, sampled when the request arrived.
        const double expected = std::min(1500.0, 1500.0 * seconds(t - t0));
        CHECK(digits_to_rpm(m.reply().pd[1]) == Approx(expected).margin(0.2));
        CHECK(m.reply().pd[1] >= last_speed);
        last_speed = m.reply().pd[1];
        CHECK(m.reply().pd[0] == 0x0407);
        CHECK(m.reply().pd[2] == (expected < 1500 ? 700 : 300));
    }
    // 1 s of ramp at one sample per cycle.
    CHECK(cycles == static_cast<int>(1s / cycle) + 1);
    CHECK(m.stats().failed == 0);

    // Stop: down the same ramp while the line is quiet for 250 ms.
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3, po_words(control_word::stop(), 1500, 1000ms)));
    REQUIRE_FALSE(run(line, m));
    const time_point stop_at = st->session.request_end();
    line.advance(250ms);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3, po_words(control_word::stop(), 1500, 1000ms)));
    REQUIRE_FALSE(run(line, m));
    const double expected = 1500.0 - 1500.0 * seconds(st->session.request_end() - stop_at);
    CHECK(digits_to_rpm(m.reply().pd[1]) == Approx(expected).margin(0.2));
    CHECK(status_word{m.reply().pd[0]}.unit_status() == status_word::unit_status_no_enable);
}

TEST_CASE("end to end: parameters by index, device errors, retries and the fault latch",
          "[movilink][sim][e2e]") {
    sim::bus<1> bus;
    mock_serial line(default_format, &bus);
    auto* st = bus.add();
    master_config no_retries;
    no_retries.retries = 0;
    master m(no_retries);

    const auto acyclic = [&](master& mm, param_channel p) {
        REQUIRE_FALSE(mm.start_parameter(1, pdu_type::param_acyclic, p));
        return run(line, mm);
    };
    const auto exchange = [&](words po) {
        REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3, po));
        REQUIRE_FALSE(run(line, m));
        return m.reply();
    };

    exchange(po_words(control_word::enable(), 1500, 1000ms));
    line.advance(2s);

    // Read P000 speed by index: 1500 rpm in 0.001 rpm.
    CHECK_FALSE(acyclic(m, param_channel::make(service::read, ix::p000_speed)));
    CHECK(m.reply().param.data == 1500000);
    CHECK(m.reply().param.management == 0x31);

    // Write P812 volatile and read it back.
    exchange(po_words(control_word::enable(), 1500, 1000ms));
    CHECK_FALSE(acyclic(
        m, param_channel::make(service::write_volatile, ix::p812_rs485_timeout_delay, 1000)));
    CHECK_FALSE(acyclic(m, param_channel::make(service::read, ix::p812_rs485_timeout_delay)));
    CHECK(m.reply().param.data == 1000);
    CHECK(st->drive.eeprom_writes() == 0);

    SECTION("P812 expires without cyclic telegrams: fault 43 in PI1, reset clears it") {
        line.advance(1500ms);
        telegram rsp = exchange(po_words(control_word::enable(), 1500, 1000ms));
        CHECK(status_word{rsp.pd[0]}.fault_number() == 43);
        CHECK(rsp.pd[1] == 0);
        rsp = exchange(po_words(control_word::enable().with_reset(), 1500, 1000ms));
        CHECK(rsp.pd[0] == 0x0407);
    }
    SECTION("bad index, no retries: one request, class 8 / 0x0010") {
        const std::size_t before = bus.replies_sent();
        const std::error_code ec = acyclic(m, param_channel::make(service::read, 0x2000));
        REQUIRE(ec.category() == device_category());
        const device_error_fields f = fields_of(ec.value());
        CHECK(f.error_class == 8);
        CHECK(f.code == 0);
        CHECK(f.additional == 0x0010);
        CHECK(m.error() == ec);
        CHECK(m.attempts() == 1);
        CHECK(bus.replies_sent() - before == 1);
        CHECK_FALSE(m.fault_latched());
    }
    SECTION("bad index, default master: 4 retries, then the fault latches") {
        master dflt;
        const std::size_t before = bus.replies_sent();
        const std::error_code ec = acyclic(dflt, param_channel::make(service::read, 0x2000));
        CHECK(fields_of(ec.value()).additional == 0x0010);
        CHECK(dflt.attempts() == 5);
        CHECK(bus.replies_sent() - before == 5);
        CHECK(dflt.fault_latched());
        CHECK(dflt.start_parameter(1, pdu_type::param_acyclic,
                                   param_channel::make(service::read, ix::p000_speed)) ==
              errc::fault_latched);
        dflt.reset_fault();
        CHECK_FALSE(acyclic(dflt, param_channel::make(service::read, ix::p000_speed)));
        CHECK(dflt.reply().param.data == 1500000);
    }
}

TEST_CASE("end to end: a drive's warning is a good cycle, not a failure towards the latch",
          "[movilink][sim][e2e]") {
    sim::bus<1> bus;
    mock_serial line(default_format, &bus);
    auto* st = bus.add();
    master_config latch_at_once;
    latch_at_once.fault_threshold = 1;
    master m(latch_at_once);
    cyclic c(m, 1);
    const words enable = po_words(control_word::enable(), 1500, 1000ms);
    for (std::size_t i = 0; i < enable.size(); ++i) c.set_po(i, enable[i]);
    st->drive.inject_warning(4);
    ferrule::poll_driver drv(line, c);
    while (c.cycles() < 5 && line.now() < at(1s)) {
        drv.step();
        line.advance(100us);
    }
    CHECK(c.cycles() == 5);
    CHECK(c.failed_cycles() == 0);
    CHECK_FALSE(c.error());
    CHECK(m.consecutive_failures() == 0);
    CHECK_FALSE(m.fault_latched());
    CHECK(m.stats().failed == 0);
    const status_word sw{c.pi(0)};
    CHECK(sw.warning());
    CHECK(sw.warning_number() == 4);
}

TEST_CASE("end to end: the master polls the handshake of a slow cyclic service",
          "[movilink][sim][e2e]") {
    sim::bus<1> bus;
    mock_serial line(default_format, &bus);
    auto* st = bus.add({}, {.param_latency = 2});
    master m;
    const words po = po_words(control_word::enable(), 300, 1000ms);
    REQUIRE_FALSE(
        m.start_parameter(1, pdu_type::param_3pd,
                          param_channel::make(service::read, ix::p811_rs485_group_address), po));
    REQUIRE_FALSE(run(line, m));
    CHECK(m.reply().param.data == 100);
    CHECK(m.reply().param.handshake());
    CHECK(m.stats().handshake_polls == 2);
    CHECK(st->drive.services_executed() == 1);
    CHECK(m.reply().pd[0] == 0x0407);

    // Process data on the same type between services: no new service runs.
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::param_3pd, po));
    REQUIRE_FALSE(run(line, m));
    CHECK(st->drive.services_executed() == 1);
}

TEST_CASE("end to end: the master recovers from lost and damaged replies", "[movilink][sim][e2e]") {
    sim::bus<1> bus;
    mock_serial line(default_format, &bus);
    bus.add();
    master m;
    const words po = po_words(control_word::enable(), 600, 1000ms);

    SECTION("a dropped reply: timeout, resend") {
        bus.drop_replies(1);
        REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3, po));
        CHECK_FALSE(run(line, m));
        CHECK(m.attempts() == 2);
        CHECK(m.stats().timeouts == 1);
    }
    SECTION("a corrupted BCC: invalid reply, resend") {
        bus.corrupt_replies(1, 9);
        REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3, po));
        CHECK_FALSE(run(line, m));
        CHECK(m.attempts() == 2);
        CHECK(m.stats().invalid_replies == 1);
    }
    SECTION("a late reply within the response timeout is fine") {
        bus.delay_replies(1, 40ms);
        REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3, po));
        CHECK_FALSE(run(line, m));
        CHECK(m.attempts() == 1);
        CHECK(reply_gap(line) == start_pause + 40ms);
    }
    SECTION("five lost replies in a row latch the fault") {
        bus.drop_replies(5);
        REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3, po));
        CHECK(run(line, m) == errc::timeout);
        CHECK(m.fault_latched());
        CHECK(bus.replies_dropped() == 5);
    }
}
