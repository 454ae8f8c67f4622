// sim::drive (code table, write rules, speed model, trips) and sim::bus: several drives on
// one mock_serial line, driven with raw requests from lecom::encode (lecom.md §1, §2, §4).
#include <catch2/catch.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/lecom/constants.hpp"
#include "ferrule/lecom/frame.hpp"
#include "ferrule/lecom/sim/bus.hpp"
#include "ferrule/lecom/sim/drive.hpp"
#include "ferrule/lecom/value.hpp"

using namespace ferrule;
using namespace ferrule::lecom;
using namespace std::chrono_literals;
namespace cn = ferrule::lecom::sim::code_number;
namespace bits = ferrule::lecom::sim::state_bits;

namespace {

using byte_vector = std::vector<std::uint8_t>;

time_point at(duration d) {
    return time_point{} + d;
}

value vd(std::string_view text) {
    return *parse_value(text);
}
std::int32_t fix(std::int32_t whole) {
    return whole * value::scale;
}

sim::drive make_drive(sim::drive_family f) {
    sim::drive_config cfg;
    cfg.family = f;
    return sim::drive(cfg);
}

frame read_on(sim::drive& d, std::uint16_t c, time_point t = at(0ms)) {
    return d.handle(read_request(1, code(c)), t);
}
frame_kind write_on(sim::drive& d, std::uint16_t c, const value& v, time_point t = at(0ms)) {
    return d.handle(write_request(1, code(c), v), t).kind;
}
std::int32_t fixed_of(sim::drive& d, std::uint16_t c, time_point t) {
    const frame f = read_on(d, c, t);
    REQUIRE(f.kind == frame_kind::data);
    REQUIRE(f.value.format == value_format::decimal);
    return f.value.fixed;
}

byte_vector encoded(const frame& f) {
    std::array<std::uint8_t, max_frame_length> buf{};
    const std::size_t n = *encode(f, buf);
    return {buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n)};
}

// Writes `request` and reads one reply telegram; empty after response_timeout of silence.
byte_vector transact(mock_serial& line, const byte_vector& request) {
    line.clear_wire_log();
    REQUIRE(line.write(request).bytes == request.size());
    frame_decoder decoder;
    const time_point deadline = line.now() + response_timeout;
    std::array<std::uint8_t, 64> buf{};
    for (;;) {
        const io_result r = line.read_some(buf, deadline);
        if (r.bytes == 0) return {};
        std::span<const std::uint8_t> in(buf.data(), r.bytes);
        while (!in.empty()) {
            const auto step = decoder.feed(in);
            in = in.subspan(step.consumed);
            if (step.what == frame_decoder::status::frame)
                return {decoder.frame().begin(), decoder.frame().end()};
        }
    }
}
byte_vector transact(mock_serial& line, const frame& request) {
    return transact(line, encoded(request));
}

// From the end of the request's last byte to the start of the reply's first.
duration reply_gap(const mock_serial& line) {
    time_point request_end{};
    for (const wire_byte& b : line.wire()) {
        if (b.origin == wire_byte::from::session) request_end = b.end;
        if (b.origin == wire_byte::from::peer && b.start >= request_end)
            return b.start - request_end;
    }
    return duration::max();
}

frame reply_of(const byte_vector& b) {
    const auto f = parse_reply(b);
    REQUIRE(f);
    return *f;
}

slave_config unit(std::uint8_t address, bool bare = false) {
    slave_config cfg;
    cfg.address = address;
    cfg.bare_replies = bare;
    return cfg;
}

} // namespace

// --- the drive alone -------------------------------------------------------------------------

TEST_CASE("lecom sim: the code table of both families", "[lecom][sim]") {
    sim::drive dc = make_drive(sim::drive_family::lenze_4900);
    sim::drive fc = make_drive(sim::drive_family::lenze_8200);
    CHECK(dc.codes().size() == sim::drive::code_count);

    const frame id = read_on(dc, cn::c0200_software_id);
    REQUIRE(id.kind == frame_kind::data);
    CHECK(id.value.format == value_format::string);
    CHECK(id.value.text() == "4902 DC sim");
    CHECK(read_on(fc, cn::c0200_software_id).value.text() == "82EV sim");

    CHECK(fixed_of(dc, cn::c0009_unit_address, at(0ms)) == fix(1));
    CHECK(fixed_of(dc, cn::c0011_max_speed, at(0ms)) == fix(3000));
    CHECK(fixed_of(fc, cn::c0011_max_speed, at(0ms)) == fix(50));
    CHECK(fixed_of(fc, cn::c0012_accel_time, at(0ms)) == fix(5));
    CHECK(fixed_of(fc, cn::c0040_controller_enable, at(0ms)) == fix(1));
    CHECK(fixed_of(fc, cn::c0067_fault, at(0ms)) == 0);
    CHECK(fixed_of(fc, cn::c0125_baud, at(0ms)) == 0);

    // C0068 in VH with four digits (S1 p.8-22 shows H0900): enabled, at rest = setpoint.
    const frame state = read_on(fc, cn::c0068_operating_state);
    CHECK(state.value.format == value_format::hex);
    CHECK(state.value.digits == 4);
    CHECK(state.value.hex == (bits::enabled | bits::at_setpoint));
    CHECK(encoded(state) ==
          byte_vector{0x02, 0x36, 0x38, 0x48, 0x34, 0x31, 0x30, 0x30, 0x03, 0x40}); // H4100

    // Ramp times are written with two decimals: C0012 = 5.00.
    CHECK(encoded(read_on(fc, cn::c0012_accel_time)) ==
          byte_vector{0x02, 0x31, 0x32, 0x35, 0x2E, 0x30, 0x30, 0x03, 0x1B});

    CHECK(fc.value_of(cn::c0046_speed_setpoint)->fixed == 0);
    CHECK(fc.value_of(1).error() == errc::invalid_argument);
}

TEST_CASE("lecom sim: codes that do not exist", "[lecom][sim]") {
    sim::drive d;
    const frame r = read_on(d, 1);
    CHECK(r.kind == frame_kind::no_code);
    CHECK(r.code == code(1));
    CHECK(write_on(d, 1, *decimal(1)) == frame_kind::nak);
    // 82XX drives have no subcodes (lecom.md §3).
    CHECK(d.handle(read_request(1, extended_code(cn::c0046_speed_setpoint, 1)), at(0ms)).kind ==
          frame_kind::no_code);
    const frame ext =
        d.handle(read_request(1, extended_code(cn::c0046_speed_setpoint, 0)), at(0ms));
    CHECK(ext.kind == frame_kind::data);
    CHECK(ext.code == extended_code(cn::c0046_speed_setpoint, 0));
}

TEST_CASE("lecom sim: writes that the drive refuses with NAK (S1 p.8-20)", "[lecom][sim]") {
    sim::drive d = make_drive(sim::drive_family::lenze_8200);
    SECTION("read-only codes") {
        CHECK(write_on(d, cn::c0050_actual_speed, *decimal(10)) == frame_kind::nak);
        CHECK(write_on(d, cn::c0067_fault, *decimal(0)) == frame_kind::nak);
        CHECK(write_on(d, cn::c0068_operating_state, *hex(0)) == frame_kind::nak);
        CHECK(write_on(d, cn::c0200_software_id, *string("x")) == frame_kind::nak);
    }
    SECTION("out of range") {
        CHECK(write_on(d, cn::c0040_controller_enable, *decimal(2)) == frame_kind::nak);
        CHECK(write_on(d, cn::c0040_controller_enable, vd("0.5")) == frame_kind::nak);
        CHECK(write_on(d, cn::c0011_max_speed, vd("480.1")) == frame_kind::nak);
        CHECK(write_on(d, cn::c0011_max_speed, vd("7.4")) == frame_kind::nak);
        CHECK(write_on(d, cn::c0046_speed_setpoint, vd("-480.0001")) == frame_kind::nak);
        CHECK(write_on(d, cn::c0125_baud, *decimal(5)) == frame_kind::nak);
        CHECK(write_on(d, cn::c0012_accel_time, vd("-1")) == frame_kind::nak);
    }
    SECTION("the wrong format") {
        CHECK(write_on(d, cn::c0040_controller_enable, *hex(1, 2)) == frame_kind::nak);
    }
    SECTION("00 and x0 are no unit addresses (S1 p.6-3)") {
        CHECK(write_on(d, cn::c0009_unit_address, *decimal(0)) == frame_kind::nak);
        CHECK(write_on(d, cn::c0009_unit_address, *decimal(10)) == frame_kind::nak);
        CHECK(write_on(d, cn::c0009_unit_address, *decimal(100)) == frame_kind::nak);
        CHECK(d.address() == 1);
    }
    CHECK(fixed_of(d, cn::c0011_max_speed, at(0ms)) == fix(50));
    CHECK(fixed_of(d, cn::c0040_controller_enable, at(0ms)) == fix(1));
}

TEST_CASE("lecom sim: accepted writes", "[lecom][sim]") {
    sim::drive d = make_drive(sim::drive_family::lenze_8200);
    CHECK(write_on(d, cn::c0011_max_speed, vd("95.2")) == frame_kind::ack); // vector 7
    CHECK(fixed_of(d, cn::c0011_max_speed, at(0ms)) == 952'000);
    CHECK(write_on(d, cn::c0125_baud, *decimal(4)) == frame_kind::ack);
    CHECK(write_on(d, cn::c0009_unit_address, *decimal(12)) == frame_kind::ack);
    CHECK(d.address() == 12);
    CHECK(fixed_of(d, cn::c0009_unit_address, at(0ms)) == fix(12));
    CHECK(d.preset(cn::c0046_speed_setpoint, fix(20)));
    CHECK_FALSE(d.preset(cn::c0050_actual_speed, fix(20)));
    CHECK_FALSE(d.preset(1, 0));
}

TEST_CASE("lecom sim: the speed follows the setpoint with the ramps in virtual time",
          "[lecom][sim]") {
    SECTION("8200: C0011 50 Hz, C0012 / C0013 5 s") {
        sim::drive d = make_drive(sim::drive_family::lenze_8200);
        CHECK(write_on(d, cn::c0046_speed_setpoint, *decimal(25), at(0ms)) == frame_kind::ack);
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(0ms)) == 0);
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(1s)) == fix(10)); // 50 Hz per 5 s
        CHECK(read_on(d, cn::c0068_operating_state, at(1s)).value.hex ==
              (bits::enabled | bits::running));
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(2500ms)) == fix(25));
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(10s)) == fix(25));
        CHECK(read_on(d, cn::c0068_operating_state, at(10s)).value.hex ==
              (bits::enabled | bits::running | bits::at_setpoint));

        // Reversing: down to 0 with C0013, then up with C0012.
        CHECK(write_on(d, cn::c0046_speed_setpoint, *decimal(-25), at(10s)) == frame_kind::ack);
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(11s)) == fix(15));
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(12500ms)) == 0);
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(13500ms)) == fix(-10));
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(20s)) == fix(-25));

        // Beyond C0011 the speed stops at C0011.
        CHECK(write_on(d, cn::c0046_speed_setpoint, *decimal(100), at(20s)) == frame_kind::ack);
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(40s)) == fix(50));

        // Controller inhibit (the broadcast example's C40 = 0): 0 at once.
        CHECK(write_on(d, cn::c0040_controller_enable, *decimal(0), at(40s)) == frame_kind::ack);
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(40s)) == 0);
        CHECK(read_on(d, cn::c0068_operating_state, at(40s)).value.hex == 0);
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(50s)) == 0);
        CHECK(write_on(d, cn::c0040_controller_enable, *decimal(1), at(50s)) == frame_kind::ack);
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(51s)) == fix(10));
    }
    SECTION("4900: C0011 3000 rpm, ramps 2 s, a changed ramp takes effect") {
        sim::drive d = make_drive(sim::drive_family::lenze_4900);
        CHECK(write_on(d, cn::c0046_speed_setpoint, *decimal(1500), at(0ms)) == frame_kind::ack);
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(500ms)) == fix(750));
        CHECK(write_on(d, cn::c0012_accel_time, vd("0.5"), at(500ms)) == frame_kind::ack);
        CHECK(fixed_of(d, cn::c0050_actual_speed, at(550ms)) == fix(1050));
        CHECK(d.speed() == fix(1050));
        CHECK(write_on(d, cn::c0012_accel_time, *decimal(0), at(550ms)) == frame_kind::ack);
        CHECK(d.speed() == fix(1500));
    }
    SECTION("time running backwards is ignored") {
        sim::drive d;
        CHECK(write_on(d, cn::c0046_speed_setpoint, *decimal(1500), at(1s)) == frame_kind::ack);
        d.advance(at(2s));
        d.advance(at(1s));
        CHECK(d.speed() == fix(1500));
    }
}

TEST_CASE("lecom sim: a trip shows in C0067 and C0068 and stops the drive", "[lecom][sim]") {
    sim::drive d = make_drive(sim::drive_family::lenze_8200);
    CHECK(write_on(d, cn::c0046_speed_setpoint, *decimal(25), at(0ms)) == frame_kind::ack);
    d.advance(at(3s));
    CHECK(d.speed() == fix(25));
    d.trip(11);
    CHECK(d.fault() == 11);
    CHECK(d.speed() == 0);
    CHECK(fixed_of(d, cn::c0067_fault, at(3s)) == fix(11));
    CHECK(fixed_of(d, cn::c0043_trip_reset, at(3s)) == fix(1));
    CHECK(read_on(d, cn::c0068_operating_state, at(3s)).value.hex == bits::fault);
    CHECK(fixed_of(d, cn::c0050_actual_speed, at(5s)) == 0);
    // Settings may still be written; the drive stays at 0 until the fault is reset.
    CHECK(write_on(d, cn::c0046_speed_setpoint, *decimal(10), at(5s)) == frame_kind::ack);
    CHECK(fixed_of(d, cn::c0050_actual_speed, at(6s)) == 0);

    SECTION("reset over LECOM: C0043 = 0") {
        CHECK(write_on(d, cn::c0043_trip_reset, *decimal(1), at(6s)) == frame_kind::nak);
        CHECK(write_on(d, cn::c0043_trip_reset, *decimal(0), at(6s)) == frame_kind::ack);
    }
    SECTION("reset_trip()") {
        d.reset_trip();
    }
    CHECK(fixed_of(d, cn::c0067_fault, at(6s)) == 0);
    CHECK(fixed_of(d, cn::c0043_trip_reset, at(6s)) == 0);
    CHECK(fixed_of(d, cn::c0050_actual_speed, at(7s)) == fix(10));
}

// --- several drives on one line ---------------------------------------------------------------

TEST_CASE("lecom sim::bus: six 4900 drives polled in turn every 50 ms (LECOM paper)",
          "[lecom][sim][bus]") {
    sim::bus<6> bus;
    for (std::uint8_t a = 1; a <= 6; ++a) REQUIRE(bus.add(unit(a)) != nullptr);
    CHECK(bus.add(unit(7)) == nullptr);
    mock_serial line(lenze_4900.format, &bus);

    for (std::uint8_t a = 1; a <= 6; ++a)
        bus[a - 1].drive.preset(cn::c0046_speed_setpoint, fix(a * 100));
    bus.advance(at(0ms));
    for (int k = 0; k < 12; ++k) {
        line.sleep_until(at(std::chrono::milliseconds(50 * k) + 10s));
        const auto a = static_cast<std::uint8_t>(k % 6 + 1);
        const byte_vector reply = transact(line, read_request(a, code(cn::c0050_actual_speed)));
        // S3: the drive answers t3 = 20 ms after the request, exactly so in the sim.
        CHECK(reply_gap(line) == processing_time);
        const frame f = reply_of(reply);
        CHECK(f.kind == frame_kind::data);
        CHECK(f.code == code(cn::c0050_actual_speed));
        CHECK(f.value.fixed == fix(a * 100)); // at speed after 10 s
        // A request of 6 and a reply of 8 characters at 9600 8E1 fit into 50 ms.
        CHECK(line.now() < at(std::chrono::milliseconds(50 * k + 50) + 10s));
    }
    for (std::size_t i = 0; i < 6; ++i) {
        CHECK(bus[i].session.stats().requests == 2);
        CHECK(bus[i].session.stats().replies == 2);
        CHECK(bus[i].session.stats().ignored_other_address == 10);
    }
    CHECK(bus.replies_sent() == 12);
}

TEST_CASE("lecom sim::bus: vectors 7 and 8, a write and a broadcast", "[lecom][sim][bus]") {
    sim::bus<3> bus;
    bus.add(unit(34));
    bus.add(unit(35));
    bus.add(unit(41));
    mock_serial line(lenze_8200.format, &bus);

    const byte_vector write_c11_at_34{0x04, 0x33, 0x34, 0x02, 0x31, 0x31,
                                      0x39, 0x35, 0x2E, 0x32, 0x03, 0x13};
    CHECK(transact(line, write_c11_at_34) == byte_vector{ack});
    CHECK(reply_gap(line) == processing_time);
    CHECK(bus[0].drive.value_of(cn::c0011_max_speed)->fixed == 952'000);
    CHECK(bus[1].drive.value_of(cn::c0011_max_speed)->fixed == fix(3000));

    // Stop all drives: C40 = 0 to 00, no reply (S1 p.8-24).
    const byte_vector broadcast_c40_0{0x04, 0x30, 0x30, 0x02, 0x34, 0x30, 0x30, 0x03, 0x37};
    CHECK(transact(line, broadcast_c40_0).empty());
    for (std::size_t i = 0; i < 3; ++i) CHECK_FALSE(bus[i].drive.enabled());

    // 30 reaches 31-39: a group SEND, no reply; the drive at 41 keeps its value.
    CHECK(
        transact(line, write_request(30, code(cn::c0040_controller_enable), *decimal(1))).empty());
    CHECK(bus[0].drive.enabled());
    CHECK(bus[1].drive.enabled());
    CHECK_FALSE(bus[2].drive.enabled());
    // A RECEIVE to a group gets no reply from anyone.
    CHECK(transact(line, byte_vector{0x04, 0x33, 0x30, 0x34, 0x30, 0x05}).empty());
    CHECK(bus.replies_sent() == 1);
}

TEST_CASE("lecom sim::bus: a write of C0009 moves the drive", "[lecom][sim][bus]") {
    sim::bus<2> bus;
    bus.add(unit(1));
    bus.add(unit(2));
    mock_serial line(lenze_4900.format, &bus);
    CHECK(transact(line, write_request(2, code(cn::c0009_unit_address), *decimal(7))) ==
          byte_vector{ack});
    CHECK(bus[1].session.address() == 7);
    CHECK(transact(line, read_request(2, code(cn::c0009_unit_address))).empty());
    const byte_vector reply = transact(line, read_request(7, code(cn::c0009_unit_address)));
    CHECK(reply_of(reply).value.fixed == fix(7));
    // x0 is refused and the drive stays where it is.
    CHECK(transact(line, write_request(7, code(cn::c0009_unit_address), *decimal(20))) ==
          byte_vector{nak});
    CHECK(bus[1].session.address() == 7);
}

TEST_CASE("lecom sim::bus: faults on the line", "[lecom][sim][bus]") {
    sim::bus<2> bus;
    bus.add(unit(1));
    bus.add(unit(2, true));
    mock_serial line(lenze_4900.format, &bus);
    const frame read_c46 = read_request(1, code(cn::c0046_speed_setpoint));

    SECTION("a SEND with a bad BCC is answered NAK by the addressed drive only") {
        byte_vector bad = encoded(write_request(2, code(cn::c0046_speed_setpoint), *decimal(5)));
        bad.back() ^= 0x20;
        CHECK(transact(line, bad) == byte_vector{nak});
        CHECK(reply_gap(line) == processing_time);
        CHECK(bus[1].drive.value_of(cn::c0046_speed_setpoint)->fixed == 0);
        CHECK(bus[1].session.stats().bad_checksum == 1);
        CHECK(bus[0].session.stats().bad_checksum == 0);
    }
    SECTION("unknown codes: STX C1 C2 EOT, or a bare EOT with bare_replies") {
        CHECK(transact(line, read_request(1, code(1))) == byte_vector{stx, 0x30, 0x31, eot});
        CHECK(transact(line, read_request(2, code(1))) == byte_vector{eot});
        CHECK(transact(line, write_request(2, code(1), *decimal(1))) == byte_vector{nak});
    }
    SECTION("a dropped reply is a timeout, the next one comes") {
        bus.drop_replies(1);
        const time_point start = line.now();
        CHECK(transact(line, read_c46).empty());
        CHECK(line.now() - start == lenze_4900.format.chars_time(6) + response_timeout);
        CHECK(reply_of(transact(line, read_c46)).kind == frame_kind::data);
        CHECK(bus.replies_dropped() == 1);
    }
    SECTION("a corrupted BCC") {
        bus.corrupt_replies(1, 5, 0x01); // STX '4' '6' '0' ETX BCC
        const byte_vector reply = transact(line, read_c46);
        REQUIRE(reply.size() == 6);
        CHECK(parse_reply(reply).error() == errc::bad_checksum);
        CHECK(reply_of(transact(line, read_c46)).value.fixed == 0);
    }
    SECTION("a delayed reply") {
        bus.delay_replies(1, 30ms);
        CHECK_FALSE(transact(line, read_c46).empty());
        CHECK(reply_gap(line) == processing_time + 30ms);
    }
}

TEST_CASE("lecom sim::bus: the speed model runs in virtual time on the line", "[lecom][sim][bus]") {
    sim::bus<1> bus;
    sim::drive_config cfg;
    cfg.family = sim::drive_family::lenze_8200;
    bus.add(unit(5), cfg);
    mock_serial line(lenze_8200.format, &bus);
    CHECK(transact(line, write_request(5, code(cn::c0046_speed_setpoint), vd("35.4"))) ==
          byte_vector{ack});
    const time_point written = line.now() - lenze_8200.format.chars_time(1) - processing_time;
    line.sleep_until(written + 2s);
    const byte_vector request = encoded(read_request(5, code(cn::c0050_actual_speed)));
    // The request is handled when its last character is in: 2 s + its wire time after the
    // write was handled, at 10 Hz/s.
    const duration ramped = 2s + lenze_8200.format.chars_time(request.size());
    const frame f = reply_of(transact(line, request));
    CHECK(f.value.fixed ==
          static_cast<std::int32_t>(std::chrono::duration<double>(ramped).count() * fix(10) + 0.5));
    line.sleep_until(line.now() + 5s);
    CHECK(reply_of(transact(line, request)).value.fixed == 354'000);
}
