// lecom::slave: framing, addressing (own, other, 00, x0), the NAK to a bad BCC, reply forms
// and reply timing (lecom.md §1.3-§1.13), with the vectors of lecom.md §4.
#include <catch2/catch.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <span>
#include <vector>

#include "ferrule/lecom/frame.hpp"
#include "ferrule/lecom/slave.hpp"
#include "ferrule/lecom/value.hpp"

using namespace ferrule;
using namespace ferrule::lecom;
using namespace std::chrono_literals;

namespace {

using byte_vector = std::vector<std::uint8_t>;

// lecom.md §4.1 and §4.2.
const byte_vector read_c46_at_01{0x04, 0x30, 0x31, 0x34, 0x36, 0x05};                   // #1
const byte_vector reply_c46_35_4{0x02, 0x34, 0x36, 0x33, 0x35, 0x2E, 0x34, 0x03, 0x1D}; // #2
const byte_vector fault_c46{0x02, 0x34, 0x36, 0x3F, 0x03, 0x3E};                        // #3
const byte_vector no_code_c46{0x02, 0x34, 0x36, 0x04};                                  // #4
const byte_vector read_c68_at_25{0x04, 0x32, 0x35, 0x36, 0x38, 0x05};                   // #5
const byte_vector reply_c68_h0900{0x02, 0x36, 0x38, 0x48, 0x30, 0x39, 0x30, 0x30, 0x03, 0x4C};
const byte_vector write_c11_at_34{0x04, 0x33, 0x34, 0x02, 0x31, 0x31,
                                  0x39, 0x35, 0x2E, 0x32, 0x03, 0x13};                   // #7
const byte_vector broadcast_c40_0{0x04, 0x30, 0x30, 0x02, 0x34, 0x30, 0x30, 0x03, 0x37}; // #8
const byte_vector read_c1002_ext{0x04, 0x30, 0x31, 0x21, 0x30, 0x33, 0x45, 0x41, 0x30, 0x30, 0x05};

time_point at(duration d) {
    return time_point{} + d;
}

slave at_address(std::uint8_t a, bool bare = false) {
    slave_config cfg;
    cfg.address = a;
    cfg.bare_replies = bare;
    return slave(cfg);
}

byte_vector bytes_of(const session_action& a) {
    return {a.bytes.begin(), a.bytes.end()};
}

value parsed_value(const char* text) {
    return *parse_value(std::string_view(text));
}

// The reply the slave puts on the line once it is due.
byte_vector sent(slave& s) {
    const session_action a = s.next(s.wake_at());
    REQUIRE(a.what == session_action::kind::send);
    return bytes_of(a);
}

} // namespace

TEST_CASE("lecom slave: a RECEIVE for this drive is answered processing_time after it ended",
          "[lecom][slave]") {
    slave s;
    CHECK(s.next(at(0ms)).what == session_action::kind::idle);
    CHECK(s.wake_at() == never);
    s.on_receive(read_c46_at_01, at(10ms));
    REQUIRE(s.has_request());
    CHECK(s.request().kind == frame_kind::receive);
    CHECK(s.request().address == 1);
    CHECK(s.request().code == code(46));
    CHECK(s.request_end() == at(10ms));
    CHECK(s.response_expected());
    CHECK(s.next(at(10ms)).what == session_action::kind::done);

    REQUIRE_FALSE(s.respond({frame_kind::data, 0, code(46), parsed_value("35.4")}));
    CHECK_FALSE(s.has_request());
    CHECK(s.wake_at() == at(30ms)); // S3: t3 = 20 ms
    const auto wait = s.next(at(10ms));
    CHECK(wait.what == session_action::kind::wait);
    CHECK(wait.deadline == at(30ms));
    CHECK(s.next(at(30ms) - 1ns).what == session_action::kind::wait);

    const auto send = s.next(at(30ms));
    REQUIRE(send.what == session_action::kind::send);
    CHECK_FALSE(send.discard_input);
    CHECK(bytes_of(send) == reply_c46_35_4);
    CHECK(s.next(at(30ms)).what == session_action::kind::idle);
    CHECK(s.wake_at() == never);
    CHECK(s.stats().requests == 1);
    CHECK(s.stats().replies == 1);
}

TEST_CASE("lecom slave: vectors 5 to 7, C68 at 25 and a SEND of C11 at 34", "[lecom][slave]") {
    SECTION("C68 = H0900") {
        slave s = at_address(25);
        s.on_receive(read_c68_at_25, at(0ms));
        REQUIRE(s.has_request());
        CHECK(s.request().code == code(68));
        REQUIRE_FALSE(s.respond({frame_kind::data, 0, code(68), *hex(0x0900)}));
        CHECK(sent(s) == reply_c68_h0900);
    }
    SECTION("C11 = 95.2, ACK") {
        slave s = at_address(34);
        s.on_receive(write_c11_at_34, at(0ms));
        REQUIRE(s.has_request());
        CHECK(s.request().kind == frame_kind::send);
        CHECK(s.request().code == code(11));
        CHECK(s.request().value.fixed == 952'000);
        REQUIRE_FALSE(s.respond(frame{frame_kind::ack}));
        CHECK(sent(s) == byte_vector{ack});
    }
}

TEST_CASE("lecom slave: processing time is configurable, a late respond() sends at once",
          "[lecom][slave]") {
    slave_config cfg;
    cfg.processing_time = 5ms;
    slave s(cfg);
    s.on_receive(read_c46_at_01, at(0ms));
    REQUIRE(s.has_request());
    REQUIRE_FALSE(s.respond({frame_kind::no_code, 0, code(46), {}}));
    CHECK(s.wake_at() == at(5ms));
    const auto a = s.next(at(50ms));
    REQUIRE(a.what == session_action::kind::send);
    CHECK(bytes_of(a) == no_code_c46);
}

TEST_CASE("lecom slave: addressing", "[lecom][slave]") {
    SECTION("another drive's telegram is ignored") {
        slave s = at_address(1);
        s.on_receive(write_c11_at_34, at(0ms));
        s.on_receive(read_c68_at_25, at(20ms));
        CHECK_FALSE(s.has_request());
        CHECK(s.next(at(1s)).what == session_action::kind::idle);
        CHECK(s.stats().ignored_other_address == 2);
        CHECK(s.stats().requests == 0);
    }
    SECTION("00 reaches every drive and is never answered (vector 8)") {
        for (std::uint8_t a : {1, 34, 99}) {
            slave s = at_address(a);
            s.on_receive(broadcast_c40_0, at(0ms));
            REQUIRE(s.has_request());
            CHECK(s.request().code == code(40));
            CHECK(s.request().value.fixed == 0);
            CHECK_FALSE(s.response_expected());
            CHECK(s.respond(frame{frame_kind::ack}) == errc::no_response_expected);
            CHECK(s.has_request());
            s.consume();
            CHECK_FALSE(s.has_request());
            CHECK(s.next(at(1s)).what == session_action::kind::idle);
            CHECK(s.stats().no_reply_requests == 1);
            CHECK(s.stats().replies == 0);
        }
    }
    SECTION("x0 reaches x1 to x9 only") {
        std::array<std::uint8_t, max_request_length> buf{};
        const auto n = *encode(write_request(10, code(46), *decimal(12)), buf);
        const std::span<const std::uint8_t> group(buf.data(), n);
        slave s13 = at_address(13);
        s13.on_receive(group, at(0ms));
        REQUIRE(s13.has_request());
        CHECK(s13.request().address == 10);
        CHECK_FALSE(s13.response_expected());
        slave s23 = at_address(23);
        s23.on_receive(group, at(0ms));
        CHECK_FALSE(s23.has_request());
        CHECK(s23.stats().ignored_other_address == 1);
    }
    SECTION("a RECEIVE to a group address is taken but gets no reply") {
        // encode() refuses it, a master on the line may still send it (lecom.md §1.11).
        const byte_vector read_c46_at_10{0x04, 0x31, 0x30, 0x34, 0x36, 0x05};
        slave s = at_address(17);
        s.on_receive(read_c46_at_10, at(0ms));
        REQUIRE(s.has_request());
        CHECK(s.request().kind == frame_kind::receive);
        CHECK_FALSE(s.response_expected());
        CHECK(s.respond({frame_kind::data, 0, code(46), *decimal(1)}) ==
              errc::no_response_expected);
        s.consume();
        CHECK(s.next(at(1s)).what == session_action::kind::idle);
    }
    SECTION("set_address() moves the drive, 00 and x0 are no unit addresses") {
        slave s = at_address(1);
        CHECK(s.addressed(1));
        CHECK(s.addressed(0));
        CHECK_FALSE(s.addressed(10)); // 10 reaches 11-19
        CHECK_FALSE(s.addressed(2));
        s.set_address(34);
        CHECK(s.address() == 34);
        s.set_address(30);
        s.set_address(0);
        CHECK(s.address() == 34);
        s.on_receive(read_c46_at_01, at(0ms));
        CHECK_FALSE(s.has_request());
        s.on_receive(write_c11_at_34, at(20ms));
        CHECK(s.has_request());
    }
}

TEST_CASE("lecom slave: a SEND with a bad BCC is answered NAK by the session", "[lecom][slave]") {
    byte_vector bad = write_c11_at_34;
    bad.back() ^= 0x40;
    SECTION("own address: NAK after the processing time (S1 p.8-20)") {
        slave s = at_address(34);
        s.on_receive(bad, at(0ms));
        CHECK_FALSE(s.has_request());
        CHECK(s.wake_at() == at(20ms));
        CHECK(s.next(at(0ms)).what == session_action::kind::wait);
        CHECK(sent(s) == byte_vector{nak});
        CHECK(s.stats().bad_checksum == 1);
        CHECK(s.stats().requests == 0);
        CHECK(s.stats().replies == 1);
    }
    SECTION("another drive: ignored") {
        slave s = at_address(35);
        s.on_receive(bad, at(0ms));
        CHECK(s.wake_at() == never);
        CHECK(s.stats().ignored_other_address == 1);
        CHECK(s.stats().bad_checksum == 0);
    }
    SECTION("00: no NAK either") {
        byte_vector bad_broadcast = broadcast_c40_0;
        bad_broadcast.back() ^= 0x01;
        slave s = at_address(34);
        s.on_receive(bad_broadcast, at(0ms));
        CHECK_FALSE(s.has_request());
        CHECK(s.wake_at() == never);
        CHECK(s.stats().bad_checksum == 1);
    }
}

TEST_CASE("lecom slave: what cannot be decoded stays unanswered", "[lecom][slave]") {
    slave s;
    SECTION("a code field beyond the 790 rule") {
        s.on_receive(byte_vector{0x04, 0x30, 0x31, 0x7F, 0x7F, 0x05}, at(0ms));
        CHECK(s.stats().malformed == 1);
    }
    SECTION("a value that is no VD / VH / VS") {
        // EOT 01 STX "46" "1.2.3" ETX BCC
        byte_vector t{0x04, 0x30, 0x31, 0x02, 0x34, 0x36, 0x31, 0x2E, 0x32, 0x2E, 0x33, 0x03};
        std::uint8_t bcc = 0;
        for (std::size_t i = 4; i < t.size(); ++i) bcc ^= t[i];
        t.push_back(bcc);
        s.on_receive(t, at(0ms));
        CHECK(s.stats().malformed == 1);
        CHECK(s.stats().bad_checksum == 0);
    }
    SECTION("a RECEIVE cut short by the next telegram, which is served") {
        byte_vector t{0x04, 0x30, 0x31, 0x34};
        t.insert(t.end(), read_c46_at_01.begin(), read_c46_at_01.end());
        s.on_receive(t, at(0ms));
        CHECK(s.stats().malformed == 1);
        CHECK(s.has_request());
    }
    SECTION("garbage before a request") {
        s.on_receive(byte_vector{0x41, 0x42, 0x02, 0x03}, at(0ms));
        CHECK(s.stats().malformed == 1);
        s.on_receive(read_c46_at_01, at(10ms));
        CHECK(s.has_request());
    }
    CHECK(s.wake_at() == never);
}

TEST_CASE("lecom slave: a request in pieces ends with its last character", "[lecom][slave]") {
    slave s;
    for (std::size_t i = 0; i < read_c46_at_01.size(); ++i) {
        CHECK_FALSE(s.has_request());
        s.on_receive(std::span<const std::uint8_t>(&read_c46_at_01[i], 1),
                     at(std::chrono::milliseconds(i + 1)));
    }
    REQUIRE(s.has_request());
    CHECK(s.request_end() == at(6ms));
}

TEST_CASE("lecom slave: respond() checks the reply against the request", "[lecom][slave]") {
    slave s;
    CHECK(s.respond(frame{frame_kind::ack}) == errc::invalid_argument); // nothing to answer
    SECTION("RECEIVE") {
        s.on_receive(read_c46_at_01, at(0ms));
        REQUIRE(s.has_request());
        CHECK(s.respond({frame_kind::data, 0, code(47), *decimal(1)}) == errc::invalid_argument);
        CHECK(s.respond({frame_kind::fault, 0, extended_code(46, 0), {}}) ==
              errc::invalid_argument);
        CHECK(s.respond(frame{frame_kind::ack}) == errc::invalid_argument);
        CHECK(s.respond(read_request(1, code(46))) == errc::invalid_argument);
        CHECK(s.has_request());
        CHECK_FALSE(s.respond(frame{frame_kind::eot}));
    }
    SECTION("SEND") {
        slave s34 = at_address(34);
        s34.on_receive(write_c11_at_34, at(0ms));
        REQUIRE(s34.has_request());
        CHECK(s34.respond({frame_kind::data, 0, code(11), *decimal(1)}) == errc::invalid_argument);
        CHECK(s34.respond(frame{frame_kind::eot}) == errc::invalid_argument);
        CHECK_FALSE(s34.respond(frame{frame_kind::nak}));
        CHECK(sent(s34) == byte_vector{nak});
    }
}

TEST_CASE("lecom slave: reply forms of the 2102 manual and of the 4900", "[lecom][slave]") {
    const frame no_code_reply{frame_kind::no_code, 0, code(46), {}};
    const frame fault_reply{frame_kind::fault, 0, code(46), {}};
    SECTION("default: STX C1 C2 EOT and STX C1 C2 ? ETX BCC (S1 p.8-21)") {
        slave s;
        s.on_receive(read_c46_at_01, at(0ms));
        REQUIRE_FALSE(s.respond(no_code_reply));
        CHECK(sent(s) == no_code_c46);
        s.on_receive(read_c46_at_01, at(100ms));
        REQUIRE_FALSE(s.respond(fault_reply));
        CHECK(sent(s) == fault_c46);
    }
    SECTION("bare_replies: EOT and NAK (LECOM paper, lecom.md §1.4)") {
        slave s = at_address(1, true);
        s.on_receive(read_c46_at_01, at(0ms));
        REQUIRE_FALSE(s.respond(no_code_reply));
        CHECK(sent(s) == byte_vector{eot});
        s.on_receive(read_c46_at_01, at(100ms));
        REQUIRE_FALSE(s.respond(fault_reply));
        CHECK(sent(s) == byte_vector{nak});
        s.on_receive(read_c46_at_01, at(200ms));
        REQUIRE_FALSE(s.respond({frame_kind::data, 0, code(46), parsed_value("35.4")}));
        CHECK(sent(s) == reply_c46_35_4);
    }
}

TEST_CASE("lecom slave: extended addressing is echoed in the reply", "[lecom][slave]") {
    slave s;
    s.on_receive(read_c1002_ext, at(0ms));
    REQUIRE(s.has_request());
    CHECK(s.request().code == extended_code(1002, 0));
    CHECK(s.respond({frame_kind::data, 0, code(1002), *decimal(7)}) == errc::invalid_argument);
    REQUIRE_FALSE(s.respond({frame_kind::data, 0, extended_code(1002, 0), *decimal(7)}));
    // STX ! 0 3 E A 0 0 7 ETX BCC
    const byte_vector reply = sent(s);
    CHECK(byte_vector(reply.begin(), reply.end() - 1) ==
          byte_vector{0x02, 0x21, 0x30, 0x33, 0x45, 0x41, 0x30, 0x30, 0x37, 0x03});
}

TEST_CASE("lecom slave: telegrams read at once are served one after the other", "[lecom][slave]") {
    byte_vector both = broadcast_c40_0;
    both.insert(both.end(), read_c46_at_01.begin(), read_c46_at_01.end());
    slave s;
    s.on_receive(both, at(0ms));
    REQUIRE(s.has_request());
    CHECK(s.request().address == 0);
    s.consume();
    REQUIRE(s.has_request());
    CHECK(s.request().address == 1);
    CHECK(s.request().kind == frame_kind::receive);
    CHECK(s.request_end() == at(0ms));
    REQUIRE_FALSE(s.respond({frame_kind::data, 0, code(46), parsed_value("35.4")}));
    CHECK(sent(s) == reply_c46_35_4);

    SECTION("bytes that arrive while a request waits are kept for later") {
        s.on_receive(read_c46_at_01, at(100ms));
        REQUIRE(s.has_request());
        s.on_receive(read_c68_at_25, at(110ms));
        s.on_receive(read_c46_at_01, at(120ms));
        REQUIRE_FALSE(s.respond({frame_kind::data, 0, code(46), *decimal(1)}));
        // The next request came before the reply went out: the master has moved on.
        CHECK(s.stats().abandoned == 1);
        REQUIRE(s.has_request());
        CHECK(s.request_end() == at(120ms));
        CHECK(s.stats().ignored_other_address == 1);
    }
}

TEST_CASE("lecom slave: a new telegram before the reply went out drops it", "[lecom][slave]") {
    slave s;
    s.on_receive(read_c46_at_01, at(0ms));
    REQUIRE_FALSE(s.respond({frame_kind::data, 0, code(46), *decimal(1)}));
    SECTION("the start of a telegram") {
        s.on_receive(byte_vector{eot}, at(5ms));
        CHECK(s.wake_at() == never);
        CHECK(s.next(at(20ms)).what == session_action::kind::idle);
        CHECK(s.stats().abandoned == 1);
    }
    SECTION("garbage is no telegram") {
        s.on_receive(byte_vector{0x41}, at(5ms));
        CHECK(s.wake_at() == at(20ms));
        CHECK(s.stats().abandoned == 0);
    }
}
