// modbus::server over RTU and TCP: function codes, exceptions, broadcast, addressing, the
// diagnostic counters and reply timing (Modbus Application Protocol V1.1b3 §6, §7; Modbus
// over Serial Line V1.02 §2; Modbus Messaging on TCP/IP Implementation Guide V1.0b §3),
// with raw requests built by hand and with the codec, and the paper's start command
// (seeds/002) to the simulated VFD.
#include <catch2/catch.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "ferrule/core/session.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/data_model.hpp"
#include "ferrule/modbus/memory_model.hpp"
#include "ferrule/modbus/pdu.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/server.hpp"
#include "ferrule/modbus/sim/vfd.hpp"
#include "ferrule/modbus/tcp.hpp"

using namespace ferrule;
using namespace ferrule::modbus;
using namespace std::chrono_literals;

namespace {

using byte_vector = std::vector<std::uint8_t>;
using model = memory_model<32, 16, 32, 8>;

time_point at(duration d) {
    return time_point{} + d;
}

byte_vector rtu(std::uint8_t unit, const byte_vector& pdu) {
    byte_vector out(max_rtu_adu);
    out.resize(*encode_rtu(unit, pdu, out));
    return out;
}

byte_vector tcp(std::uint16_t transaction, std::uint8_t unit, const byte_vector& pdu) {
    byte_vector out(max_tcp_adu);
    out.resize(*encode_tcp(transaction, unit, pdu, out));
    return out;
}

byte_vector pdu_of(const request& r) {
    byte_vector out(max_pdu);
    out.resize(*encode_request(r, out));
    return out;
}

server_config rtu_config(unit_set units = {1}) {
    server_config cfg;
    cfg.units = units;
    return cfg;
}

server_config tcp_config() {
    server_config cfg;
    cfg.transport = transport::tcp;
    return cfg;
}

// The reply the server puts on the line once it is due.
template <class S>
byte_vector sent(S& s) {
    const session_action a = s.next(s.reply_at());
    REQUIRE(a.what == session_action::kind::send);
    return {a.bytes.begin(), a.bytes.end()};
}

// Request in, reply out (RTU frames end at 10 ms).
template <class S>
byte_vector ask(S& s, const byte_vector& request) {
    s.on_receive(request, at(10ms));
    return sent(s);
}

byte_vector exception_reply(std::uint8_t unit, std::uint8_t fc, exception_code e) {
    return rtu(unit, {static_cast<std::uint8_t>(fc | 0x80), static_cast<std::uint8_t>(e)});
}

// Every operation fails as a device would whose hardware is gone.
struct failing_model {
    std::uint8_t read_bits(function, std::uint16_t, std::uint16_t, std::span<std::uint8_t>) {
        return code_of(exception_code::server_device_failure);
    }
    std::uint8_t read_registers(function, std::uint16_t, std::uint16_t, std::span<std::uint8_t>) {
        return code_of(exception_code::server_device_busy);
    }
    std::uint8_t write_coils(std::uint16_t, std::uint16_t, std::span<const std::uint8_t>) {
        return code_of(exception_code::server_device_failure);
    }
    std::uint8_t write_registers(std::uint16_t, std::uint16_t, std::span<const std::uint8_t>) {
        return code_of(exception_code::negative_acknowledge);
    }
    std::string_view device_id(std::uint8_t) { return {}; }
};

} // namespace

TEST_CASE("modbus server rtu: read holding registers, reply t3.5 after the request",
          "[modbus][server]") {
    server<model> s(rtu_config());
    s.model().holding_registers()[0] = 0x1234;
    s.model().holding_registers()[9] = 0xABCD;
    CHECK(s.next(at(0ms)).what == session_action::kind::idle);
    CHECK(s.reply_at() == never);

    // modbus_profibus.md §A.2: read 10 holding registers from 0, unit 1.
    const byte_vector req{0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD};
    s.on_receive(req, at(10ms));
    const time_point due = at(10ms) + t35(default_format);
    CHECK(s.reply_at() == due);
    const auto wait = s.next(at(10ms));
    CHECK(wait.what == session_action::kind::wait);
    CHECK(wait.deadline == due);
    byte_vector pdu{0x03, 20, 0x12, 0x34};
    pdu.resize(20);
    pdu.insert(pdu.end(), {0xAB, 0xCD});
    CHECK(sent(s) == rtu(1, pdu));
    CHECK(s.next(due).what == session_action::kind::idle);
    CHECK(s.stats().requests == 1);
    CHECK(s.stats().replies == 1);
}

TEST_CASE("modbus server rtu: processing_time delays the reply further", "[modbus][server]") {
    server_config cfg = rtu_config();
    cfg.format = {9600, 8, parity::even, 1};
    cfg.processing_time = 5ms;
    server<model> s(cfg);
    s.on_receive(rtu(1, {0x04, 0x00, 0x00, 0x00, 0x01}), at(1s));
    CHECK(s.reply_at() == at(1s) + t35(cfg.format) + 5ms);
    CHECK(s.next(at(1s) + 5ms).what == session_action::kind::wait);
    CHECK(sent(s) == rtu(1, {0x04, 0x02, 0x00, 0x00}));
}

TEST_CASE("modbus server rtu: the paper's start command to the simulated VFD is echoed",
          "[modbus][server][sim]") {
    server<sim::vfd> s(rtu_config());
    // seeds/002: 01 06 C8 00 00 25 76 71, and the drive echoes it.
    const byte_vector start{0x01, 0x06, 0xC8, 0x00, 0x00, 0x25, 0x76, 0x71};
    CHECK(ask(s, start) == start);
    CHECK(s.model().control_word() == sim::control::start);
    CHECK(s.model().status_word() & sim::status::running);
}

TEST_CASE("modbus server rtu: bits, single and multiple writes, FC 23", "[modbus][server]") {
    server<model> s(rtu_config({17}));
    s.model().set_discrete_input(3, true);
    // modbus_profibus.md §A.2: write coil 0xAC on, unit 17 -- outside this model's 32 coils.
    CHECK(ask(s, {0x11, 0x05, 0x00, 0xAC, 0xFF, 0x00, 0x4E, 0x8B}) ==
          exception_reply(17, 5, exception_code::illegal_data_address));
    CHECK(ask(s, rtu(17, {0x05, 0x00, 0x03, 0xFF, 0x00})) ==
          rtu(17, {0x05, 0x00, 0x03, 0xFF, 0x00}));
    CHECK(s.model().coil(3));
    // Write 10 coils from 0x13 - 19: CD 01 (AP §6.11 example); then read them back.
    CHECK(ask(s, rtu(17, {0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01})) ==
          rtu(17, {0x0F, 0x00, 0x13, 0x00, 0x0A}));
    CHECK(ask(s, rtu(17, {0x01, 0x00, 0x13, 0x00, 0x0A})) == rtu(17, {0x01, 0x02, 0xCD, 0x01}));
    CHECK(ask(s, rtu(17, {0x01, 0x00, 0x00, 0x00, 0x05})) == rtu(17, {0x01, 0x01, 0x08}));
    CHECK(ask(s, rtu(17, {0x02, 0x00, 0x00, 0x00, 0x10})) == rtu(17, {0x02, 0x02, 0x08, 0x00}));
    // FC 6 and FC 16 (§A.2 vectors, unit 17).
    CHECK(ask(s, {0x11, 0x06, 0x00, 0x01, 0x00, 0x03, 0x9A, 0x9B}) ==
          byte_vector{0x11, 0x06, 0x00, 0x01, 0x00, 0x03, 0x9A, 0x9B});
    CHECK(ask(s, {0x11, 0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02, 0xC6, 0xF0}) ==
          rtu(17, {0x10, 0x00, 0x01, 0x00, 0x02}));
    CHECK(s.model().holding_registers()[1] == 0x000A);
    CHECK(s.model().holding_registers()[2] == 0x0102);
    // FC 23: write 1 register at 3, then read 3 from 1: the write comes first (AP §6.17).
    const std::array<std::uint8_t, 2> v{0xBE, 0xEF};
    request rw;
    rw.function = function::read_write_multiple_registers;
    rw.address = 1;
    rw.quantity = 3;
    rw.write_address = 3;
    rw.write_quantity = 1;
    rw.data = v;
    CHECK(ask(s, rtu(17, pdu_of(rw))) == rtu(17, {0x17, 0x06, 0x00, 0x0A, 0x01, 0x02, 0xBE, 0xEF}));
    // A read range outside the model: nothing is written.
    rw.address = 31;
    rw.quantity = 2;
    rw.write_address = 4;
    CHECK(ask(s, rtu(17, pdu_of(rw))) ==
          exception_reply(17, 23, exception_code::illegal_data_address));
    CHECK(s.model().holding_registers()[4] == 0);
}

TEST_CASE("modbus server rtu: exceptions 01, 02, 03 and the model's own", "[modbus][server]") {
    server<model> s(rtu_config());
    // 01: a function code framed by length (FC 7) and one that is not (0x41: by silence).
    CHECK(ask(s, rtu(1, {0x07})) == exception_reply(1, 0x07, exception_code::illegal_function));
    s.on_receive(rtu(1, {0x41, 0x01, 0x02}), at(10ms));
    CHECK(s.reply_at() == never);
    const auto w = s.next(at(10ms));
    REQUIRE(w.what == session_action::kind::wait);
    CHECK(w.deadline == at(10ms) + t35(default_format));
    // The silence ends the frame, and the reply is due at once.
    const auto reply = s.next(w.deadline);
    REQUIRE(reply.what == session_action::kind::send);
    CHECK(byte_vector(reply.bytes.begin(), reply.bytes.end()) ==
          exception_reply(1, 0x41, exception_code::illegal_function));
    // FC 43 with another MEI type, FC 8 with a sub-function not supported (02: diagnostic
    // register).
    CHECK(ask(s, rtu(1, {0x2B, 0x0D, 0x01, 0x00})) ==
          exception_reply(1, 0x2B, exception_code::illegal_function));
    CHECK(ask(s, rtu(1, {0x08, 0x00, 0x02, 0x00, 0x00})) ==
          exception_reply(1, 0x08, exception_code::illegal_function));
    // 03: quantity 0 and beyond the limit, a coil value other than FF00 / 0000, byte count.
    CHECK(ask(s, rtu(1, {0x03, 0x00, 0x00, 0x00, 0x00})) ==
          exception_reply(1, 3, exception_code::illegal_data_value));
    CHECK(ask(s, rtu(1, {0x01, 0x00, 0x00, 0x07, 0xD1})) ==
          exception_reply(1, 1, exception_code::illegal_data_value));
    CHECK(ask(s, rtu(1, {0x05, 0x00, 0x01, 0x12, 0x34})) ==
          exception_reply(1, 5, exception_code::illegal_data_value));
    CHECK(ask(s, rtu(1, {0x10, 0x00, 0x00, 0x00, 0x02, 0x02, 0x00, 0x01})) ==
          exception_reply(1, 16, exception_code::illegal_data_value));
    CHECK(ask(s, rtu(1, {0x2B, 0x0E, 0x05, 0x00})) ==
          exception_reply(1, 0x2B, exception_code::illegal_data_value));
    // 02: address + quantity beyond 65536, and beyond the model's tables.
    CHECK(ask(s, rtu(1, {0x03, 0xFF, 0xFF, 0x00, 0x02})) ==
          exception_reply(1, 3, exception_code::illegal_data_address));
    CHECK(ask(s, rtu(1, {0x04, 0x00, 0x07, 0x00, 0x02})) ==
          exception_reply(1, 4, exception_code::illegal_data_address));
    CHECK(s.counters().bus_exception == 11);
    CHECK(s.stats().exceptions == 11);

    server<failing_model> f(rtu_config());
    CHECK(ask(f, rtu(1, {0x01, 0x00, 0x00, 0x00, 0x01})) ==
          exception_reply(1, 1, exception_code::server_device_failure));
    CHECK(ask(f, rtu(1, {0x03, 0x00, 0x00, 0x00, 0x01})) ==
          exception_reply(1, 3, exception_code::server_device_busy));
    CHECK(ask(f, rtu(1, {0x06, 0x00, 0x00, 0x00, 0x01})) ==
          exception_reply(1, 6, exception_code::negative_acknowledge));
    CHECK(f.counters().server_busy == 1);
    CHECK(f.counters().server_nak == 1);
    CHECK(f.counters().bus_exception == 3);
}

TEST_CASE("modbus server rtu: broadcast is executed and never answered", "[modbus][server]") {
    server<model> s(rtu_config());
    s.on_receive(rtu(0, {0x06, 0x00, 0x05, 0x00, 0x2A}), at(10ms));
    CHECK(s.reply_at() == never);
    CHECK(s.next(at(1s)).what == session_action::kind::idle);
    CHECK(s.model().holding_registers()[5] == 42);
    // A read broadcast: nothing to do and nothing to say, an exception neither.
    s.on_receive(rtu(0, {0x03, 0x00, 0x00, 0x00, 0x01}), at(20ms));
    s.on_receive(rtu(0, {0x03, 0x00, 0x00, 0x00, 0x00}), at(30ms));
    CHECK(s.next(at(1s)).what == session_action::kind::idle);
    CHECK(s.stats().broadcasts == 3);
    CHECK(s.counters().server_message == 3);
    CHECK(s.counters().server_no_response == 3);
    CHECK(s.counters().bus_exception == 0);
}

TEST_CASE("modbus server rtu: other units are ignored, several units on one port",
          "[modbus][server]") {
    server<model> s(rtu_config({1, 5}));
    s.on_receive(rtu(2, {0x03, 0x00, 0x00, 0x00, 0x01}), at(10ms));
    CHECK(s.reply_at() == never);
    CHECK(s.stats().other_unit == 1);
    CHECK(ask(s, rtu(5, {0x03, 0x00, 0x00, 0x00, 0x01})) == rtu(5, {0x03, 0x02, 0x00, 0x00}));
    s.units().remove(5);
    s.on_receive(rtu(5, {0x03, 0x00, 0x00, 0x00, 0x01}), at(1s));
    CHECK(s.reply_at() == never);
    CHECK(s.counters().bus_message == 3);
    CHECK(s.counters().server_message == 1);
    unit_set u;
    CHECK_FALSE(u.add(0));
    CHECK_FALSE(u.add(248));
    CHECK(u.add(247));
    CHECK(u.contains(247));
}

TEST_CASE("modbus server rtu: a CRC error is counted and not answered", "[modbus][server]") {
    server<model> s(rtu_config());
    byte_vector bad = rtu(1, {0x03, 0x00, 0x00, 0x00, 0x01});
    bad.back() ^= 0x01;
    s.on_receive(bad, at(10ms));
    CHECK(s.reply_at() == never);
    CHECK(s.next(at(1s)).what == session_action::kind::idle); // leftovers dropped by silence
    CHECK(s.stats().bad_crc == 1);
    CHECK(s.counters().bus_comm_error == 1);
    // The next request after a silence is answered.
    CHECK(ask(s, rtu(1, {0x03, 0x00, 0x00, 0x00, 0x01})) == rtu(1, {0x03, 0x02, 0x00, 0x00}));
    // A request split into chunks is one frame.
    const byte_vector req = rtu(1, {0x03, 0x00, 0x01, 0x00, 0x01});
    s.on_receive(std::span(req).first(3), at(2s));
    CHECK(s.next(at(2s)).what == session_action::kind::wait);
    s.on_receive(std::span(req).subspan(3), at(2s) + 1ms);
    CHECK(sent(s) == rtu(1, {0x03, 0x02, 0x00, 0x00}));
}

TEST_CASE("modbus server rtu: a silence of t3.5 ends a broken frame", "[modbus][server]") {
    server<model> s(rtu_config());
    const byte_vector req = rtu(1, {0x03, 0x00, 0x00, 0x00, 0x01});
    // Half a request, then silence: wake_at() asks for a call at t3.5 after its last byte.
    s.on_receive(std::span(req).first(4), at(10ms));
    CHECK(s.wake_at() == at(10ms) + t35(default_format));
    // The whole request after more than t3.5: the half is dropped, the request is served.
    s.on_receive(req, at(10ms) + t35(default_format) + default_format.chars_time(req.size()));
    CHECK(s.stats().malformed == 1);
    CHECK(sent(s) == rtu(1, {0x03, 0x02, 0x00, 0x00}));
    CHECK(s.wake_at() == never);
}

TEST_CASE("modbus server rtu: a new request before the reply drops it", "[modbus][server]") {
    server<model> s(rtu_config());
    s.on_receive(rtu(1, {0x03, 0x00, 0x00, 0x00, 0x01}), at(10ms));
    s.on_receive(rtu(1, {0x03, 0x00, 0x01, 0x00, 0x02}), at(11ms));
    CHECK(s.stats().abandoned == 1);
    CHECK(s.counters().server_no_response == 1);
    CHECK(sent(s) == rtu(1, {0x03, 0x04, 0x00, 0x00, 0x00, 0x00}));
    // A broadcast and a request read at once: both served.
    byte_vector two = rtu(0, {0x06, 0x00, 0x00, 0x00, 0x07});
    const byte_vector second = rtu(1, {0x03, 0x00, 0x00, 0x00, 0x01});
    two.insert(two.end(), second.begin(), second.end());
    s.on_receive(two, at(1s));
    CHECK(sent(s) == rtu(1, {0x03, 0x02, 0x00, 0x07}));
}

TEST_CASE("modbus server rtu: diagnostics echo and the counters", "[modbus][server]") {
    server<model> s(rtu_config());
    // modbus_profibus.md §A.2: 01 08 00 00 12 34 ED 7C, the response is the request.
    const byte_vector echo{0x01, 0x08, 0x00, 0x00, 0x12, 0x34, 0xED, 0x7C};
    CHECK(ask(s, echo) == echo);
    byte_vector bad = rtu(1, {0x03, 0x00, 0x00, 0x00, 0x01});
    bad[3] ^= 0x10;
    s.on_receive(bad, at(20ms));
    (void)s.next(at(1s));
    s.on_receive(rtu(9, {0x03, 0x00, 0x00, 0x00, 0x01}), at(2s));      // other unit
    s.on_receive(rtu(0, {0x06, 0x00, 0x00, 0x00, 0x01}), at(3s));      // broadcast
    CHECK(ask(s, rtu(1, {0x03, 0x00, 0x00, 0x00, 0x00})).size() == 5); // exception
    s.on_overrun();

    const auto counter = [&](std::uint8_t sub) {
        const byte_vector r = ask(s, rtu(1, {0x08, 0x00, sub, 0x00, 0x00}));
        REQUIRE(r.size() == 8);
        REQUIRE(r[1] == 0x08);
        REQUIRE(r[3] == sub);
        return static_cast<unsigned>(r[4] << 8 | r[5]);
    };
    CHECK(counter(11) == 5); // echo, the others' frame, broadcast, exception, this query
    CHECK(counter(12) == 1);
    CHECK(counter(13) == 1);
    CHECK(counter(14) == 7); // echo, broadcast, exception, and 4 queries
    CHECK(counter(15) == 1);
    CHECK(counter(16) == 0);
    CHECK(counter(17) == 0);
    CHECK(counter(18) == 1);
    // Counter queries need data 0000.
    CHECK(ask(s, rtu(1, {0x08, 0x00, 0x0B, 0x00, 0x01})) ==
          exception_reply(1, 8, exception_code::illegal_data_value));
    // Clear counters (sub 10) answers with an echo, then everything is 0.
    CHECK(ask(s, rtu(1, {0x08, 0x00, 0x0A, 0x00, 0x00})) == rtu(1, {0x08, 0x00, 0x0A, 0x00, 0x00}));
    CHECK(s.counters().bus_message == 0);
    CHECK(counter(14) == 1);
    // Restart communications (sub 1): data 0000 or FF00, echoed; the counters are cleared.
    CHECK(ask(s, rtu(1, {0x08, 0x00, 0x01, 0xFF, 0x00})) == rtu(1, {0x08, 0x00, 0x01, 0xFF, 0x00}));
    CHECK(s.counters().server_message == 0);
    CHECK(ask(s, rtu(1, {0x08, 0x00, 0x01, 0x12, 0x00})) ==
          exception_reply(1, 8, exception_code::illegal_data_value));
}

TEST_CASE("modbus server rtu: listen only mode until a restart", "[modbus][server]") {
    server<model> s(rtu_config());
    s.on_receive(rtu(1, {0x08, 0x00, 0x04, 0x00, 0x00}), at(10ms));
    CHECK(s.reply_at() == never);
    CHECK(s.listen_only());
    // Monitored, not acted upon: no write, no reply.
    s.on_receive(rtu(1, {0x06, 0x00, 0x00, 0x00, 0x07}), at(1s));
    s.on_receive(rtu(0, {0x06, 0x00, 0x00, 0x00, 0x07}), at(2s));
    CHECK(s.reply_at() == never);
    CHECK(s.model().holding_registers()[0] == 0);
    CHECK(s.counters().server_message == 3);
    CHECK(s.counters().server_no_response == 3);
    // Restart communications ends it, unanswered; the counters start again.
    s.on_receive(rtu(1, {0x08, 0x00, 0x01, 0x00, 0x00}), at(3s));
    CHECK(s.reply_at() == never);
    CHECK_FALSE(s.listen_only());
    CHECK(s.counters().server_message == 0);
    CHECK(ask(s, rtu(1, {0x06, 0x00, 0x00, 0x00, 0x07})) == rtu(1, {0x06, 0x00, 0x00, 0x00, 0x07}));
    // Sub-function 04 needs data 0000; TCP has no FC 8 at all.
    CHECK(ask(s, rtu(1, {0x08, 0x00, 0x04, 0x00, 0x01})) ==
          exception_reply(1, 8, exception_code::illegal_data_value));
    CHECK_FALSE(s.listen_only());
}

TEST_CASE("modbus server rtu: read device identification, stream and individual",
          "[modbus][server]") {
    server<model> s(rtu_config(), model({}, {"ACME", "PX-1", "2.3"}));
    const byte_vector basic{0x2B, 0x0E, 0x01, 0x81, 0x00, 0x00, 0x03, 0x00, 0x04, 'A', 'C', 'M',
                            'E',  0x01, 0x04, 'P',  'X',  '-',  '1',  0x02, 0x03, '2', '.', '3'};
    CHECK(ask(s, rtu(1, {0x2B, 0x0E, 0x01, 0x00})) == rtu(1, basic));
    // An object id beyond the basic ones in a stream starts from object 0 (AP §6.21).
    CHECK(ask(s, rtu(1, {0x2B, 0x0E, 0x01, 0x07})) == rtu(1, basic));
    // From object 1; regular and extended answered at the basic level.
    CHECK(ask(s, rtu(1, {0x2B, 0x0E, 0x02, 0x01})) ==
          rtu(1, {0x2B, 0x0E, 0x02, 0x81, 0x00, 0x00, 0x02, 0x01, 0x04, 'P', 'X', '-', '1', 0x02,
                  0x03, '2', '.', '3'}));
    CHECK(ask(s, rtu(1, {0x2B, 0x0E, 0x04, 0x02})) ==
          rtu(1, {0x2B, 0x0E, 0x04, 0x81, 0x00, 0x00, 0x01, 0x02, 0x03, '2', '.', '3'}));
    CHECK(ask(s, rtu(1, {0x2B, 0x0E, 0x04, 0x03})) ==
          exception_reply(1, 0x2B, exception_code::illegal_data_address));

    // The codec's client side reads it back.
    request r;
    r.function = function::encapsulated_interface;
    r.read_device_id_code = 1;
    const byte_vector reply = ask(s, rtu(1, pdu_of(r)));
    const auto parsed =
        parse_response(r, std::span<const std::uint8_t>(reply).subspan(1, reply.size() - 3));
    REQUIRE(parsed);
    CHECK(parsed->quantity == 3);
    CHECK(parsed->conformity == 0x81);
    CHECK_FALSE(parsed->more_follows);
}

TEST_CASE("modbus server rtu: long identification objects continue in the next request",
          "[modbus][server]") {
    struct long_names : model {
        std::string_view device_id(std::uint8_t id) const noexcept {
            static constexpr char text[300] = {};
            return id < 3 ? std::string_view(text, 120) : std::string_view{};
        }
    };
    server<long_names> s(rtu_config());
    const byte_vector first = ask(s, rtu(1, {0x2B, 0x0E, 0x01, 0x00}));
    REQUIRE(first.size() == 1 + 7 + 2 * 122 + 2);
    CHECK(first[5] == 0xFF); // more follows
    CHECK(first[6] == 2);    // next object id
    CHECK(first[7] == 2);    // objects in this response
    const byte_vector rest = ask(s, rtu(1, {0x2B, 0x0E, 0x01, 0x02}));
    CHECK(rest.size() == 1 + 7 + 122 + 2);
    CHECK(rest[5] == 0x00);
}

TEST_CASE("modbus server tcp: MBAP echo, every unit, pipelined requests in order",
          "[modbus][server]") {
    server<model> s(tcp_config());
    s.model().input_registers()[0] = 0x0102;
    s.on_receive(tcp(0x1234, 0xFF, {0x04, 0x00, 0x00, 0x00, 0x01}), at(5ms));
    CHECK(s.reply_at() == at(5ms));
    CHECK(sent(s) == tcp(0x1234, 0xFF, {0x04, 0x02, 0x01, 0x02}));

    // Two requests in one segment: the second waits for the first's reply.
    byte_vector two = tcp(7, 0, {0x06, 0x00, 0x01, 0x00, 0x09});
    const byte_vector second = tcp(8, 3, {0x03, 0x00, 0x01, 0x00, 0x01});
    two.insert(two.end(), second.begin(), second.end());
    s.on_receive(two, at(10ms));
    CHECK(sent(s) == tcp(7, 0, {0x06, 0x00, 0x01, 0x00, 0x09}));
    CHECK(s.wake_at() == at(10ms));
    CHECK(sent(s) == tcp(8, 3, {0x03, 0x02, 0x00, 0x09}));
    CHECK(s.next(at(1s)).what == session_action::kind::idle);

    // FC 8 is serial line only.
    s.on_receive(tcp(9, 1, {0x08, 0x00, 0x00, 0x12, 0x34}), at(2s));
    CHECK(sent(s) == tcp(9, 1, {0x88, 0x01}));
    // A bad header is skipped; the request after it is served.
    byte_vector junk{0x00, 0x01, 0x00, 0x05, 0x00, 0x06};
    const byte_vector good = tcp(10, 1, {0x03, 0x00, 0x01, 0x00, 0x01});
    junk.insert(junk.end(), good.begin(), good.end());
    s.on_receive(junk, at(3s));
    CHECK(sent(s) == tcp(10, 1, {0x03, 0x02, 0x00, 0x09}));
    CHECK(s.stats().malformed == 1);
}

TEST_CASE("modbus server: execute() answers a PDU without a transport", "[modbus][server]") {
    server<sim::vfd> s;
    std::array<std::uint8_t, max_pdu> out{};
    const byte_vector read_status{0x03, 0xC8, 0x02, 0x00, 0x02};
    REQUIRE(s.execute(read_status, out) == 6);
    CHECK(out[0] == 0x03);
    CHECK(out[1] == 4);
    const byte_vector bad_setpoint{0x06, 0xC8, 0x01, 0xFF, 0xFF};
    REQUIRE(s.execute(bad_setpoint, out) == 2);
    CHECK(out[0] == 0x86);
    CHECK(out[1] == 0x03);
    CHECK(s.execute({}, out) == 0);
}

TEST_CASE("modbus server: a link fixed at compile time overrides the configured transport",
          "[modbus][server]") {
    const byte_vector read_one{0x03, 0x00, 0x00, 0x00, 0x01};
    const byte_vector reply{0x03, 0x02, 0x12, 0x34};

    // RTU firmware: configured for TCP, it still frames by CRC and answers in RTU.
    server<model, link_mode::rtu> r(tcp_config());
    CHECK(r.config().transport == transport::rtu);
    r.model().holding_registers()[0] = 0x1234;
    CHECK(ask(r, rtu(1, read_one)) == rtu(1, reply));
    CHECK(r.wake_at() == never);

    // A TCP server: configured for RTU, it answers MBAP requests with their transaction id.
    server<model, link_mode::tcp> t(rtu_config());
    CHECK(t.config().transport == transport::tcp);
    t.model().holding_registers()[0] = 0x1234;
    CHECK(ask(t, tcp(0x0102, 1, read_one)) == tcp(0x0102, 1, reply));
}

TEST_CASE("modbus server with a function set: others are illegal functions, FC 8 state too",
          "[modbus][server]") {
    constexpr function_set reads_and_single_writes =
        functions<function::read_holding_registers, function::write_single_register>;
    server<model, link_mode::rtu, reads_and_single_writes> s(rtu_config());
    s.model().holding_registers()[2] = 0xBEEF;
    CHECK(ask(s, rtu(1, {0x03, 0x00, 0x02, 0x00, 0x01})) == rtu(1, {0x03, 0x02, 0xBE, 0xEF}));
    CHECK(ask(s, rtu(1, {0x06, 0x00, 0x03, 0x12, 0x34})) == rtu(1, {0x06, 0x00, 0x03, 0x12, 0x34}));
    CHECK(s.model().holding_registers()[3] == 0x1234);
    // Valid requests of functions outside the set: exception 01, nothing written.
    CHECK(ask(s, rtu(1, {0x10, 0x00, 0x03, 0x00, 0x01, 0x02, 0x00, 0x07})) ==
          exception_reply(1, 0x10, exception_code::illegal_function));
    CHECK(ask(s, rtu(1, {0x04, 0x00, 0x00, 0x00, 0x01})) ==
          exception_reply(1, 0x04, exception_code::illegal_function));
    CHECK(s.model().holding_registers()[3] == 0x1234);
    // Without FC 8 there is no listen only mode and no counters to report.
    CHECK(ask(s, rtu(1, {0x08, 0x00, 0x04, 0x00, 0x00})) ==
          exception_reply(1, 0x08, exception_code::illegal_function));
    CHECK_FALSE(s.listen_only());
    CHECK(s.counters().bus_message == 0);
    CHECK(s.counters().server_message == 0);
    CHECK(s.stats().requests == 5);
    // The same request to a server with every function: counted.
    server<model, link_mode::rtu> all(rtu_config());
    CHECK(ask(all, rtu(1, {0x03, 0x00, 0x02, 0x00, 0x01})).size() == 7);
    CHECK(all.counters().bus_message == 1);
}
