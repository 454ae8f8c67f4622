// movilink::slave: framing by start pause, receiver rules, addressing and reply timing
// (movilink.md §1.4, §1.6, §1.7), with the golden vectors of §4.
#include <catch2/catch.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <span>
#include <vector>

#include "ferrule/movilink/frame.hpp"
#include "ferrule/movilink/slave.hpp"

using namespace ferrule;
using namespace ferrule::movilink;
using namespace std::chrono_literals;

namespace {

using byte_vector = std::vector<std::uint8_t>;

// Golden vectors, movilink.md §4.
const byte_vector m1{0x02, 0x01, 0x05, 0x00, 0x06, 0x3A, 0x98, 0x01, 0xF4, 0x57};
const byte_vector m2_req{0x02, 0x01, 0x85, 0x00, 0x06, 0x20, 0x00, 0x0B, 0xB8, 0x13};
const byte_vector m2_rsp{0x1D, 0x01, 0x85, 0x02, 0x06, 0x00, 0x00, 0x06, 0x06, 0x9D};
const byte_vector d2{0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x7E, 0x00, 0x00, 0x00, 0x00, 0xEA};
const byte_vector d4{0x1D, 0x01, 0x86, 0xB1, 0x00, 0x20, 0x7E, 0x08, 0x00, 0x00, 0x10, 0x6D};
const byte_vector d6{0x02, 0x01, 0x04, 0x71, 0x00, 0x20, 0x7E, 0x00, 0x00,
                     0x00, 0x00, 0x00, 0x06, 0x07, 0xD0, 0x00, 0x00, 0xF9};
const byte_vector d7{0x02, 0xFF, 0x03, 0x00, 0x06, 0x10, 0x00, 0xE8};
const byte_vector d8{0x02, 0x65, 0x85, 0x00, 0x06, 0x20, 0x00, 0x0B, 0xB8, 0x77};
const byte_vector d9{0x02, 0x03, 0x01, 0x00, 0x00, 0x00};

constexpr serial_format fmt = default_format;

time_point at(duration d) {
    return time_point{} + d;
}

// Delivers `bytes` back to back from `start`; returns when the last one ended.
time_point feed(slave& s, std::span<const std::uint8_t> bytes, time_point start) {
    const time_point end = start + fmt.chars_time(bytes.size());
    s.on_receive(bytes, end);
    return end;
}

// One byte per on_receive(), `gap` of silence between bytes.
time_point feed_bytewise(slave& s, std::span<const std::uint8_t> bytes, time_point start,
                         duration gap = {}) {
    time_point t = start;
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        if (i > 0) t += gap;
        t += fmt.char_time();
        s.on_receive(bytes.subspan(i, 1), t);
    }
    return t;
}

telegram parsed(const byte_vector& b) {
    return *parse(b);
}

telegram reply_to(const telegram& req, std::array<std::uint16_t, 3> pi = {}) {
    telegram r{direction::response, req.address, req.type, req.param, pi};
    return r;
}

byte_vector bytes_of(const session_action& a) {
    return {a.bytes.begin(), a.bytes.end()};
}

} // namespace

TEST_CASE("slave: M1 is a request for address 1, the reply waits for the start pause",
          "[movilink][slave]") {
    slave s;
    CHECK(s.next(at(0ms)).what == session_action::kind::idle);
    const time_point end = feed(s, m1, at(10ms));
    REQUIRE(s.has_request());
    const telegram& req = s.request();
    CHECK(req.address == 1);
    CHECK(req.type == pdu_type::pd3);
    CHECK(req.pd == std::array<std::uint16_t, 3>{0x0006, 0x3A98, 0x01F4});
    CHECK(s.request_end() == end);
    CHECK(s.response_expected());
    CHECK(s.next(end).what == session_action::kind::done);

    REQUIRE_FALSE(s.respond(reply_to(req, {0x0407, 0, 0x02BC})));
    CHECK_FALSE(s.has_request());
    CHECK(s.wake_at() == end + start_pause);
    const auto wait = s.next(end);
    CHECK(wait.what == session_action::kind::wait);
    CHECK(wait.deadline == end + start_pause); // SC01 p.19: >= 3.44 ms idle before SD2
    CHECK(s.next(end + start_pause - 1ns).what == session_action::kind::wait);

    const auto send = s.next(end + start_pause);
    REQUIRE(send.what == session_action::kind::send);
    CHECK_FALSE(send.discard_input);
    CHECK(bytes_of(send) ==
          byte_vector{0x1D, 0x01, 0x05, 0x04, 0x07, 0x00, 0x00, 0x02, 0xBC, 0xA4});
    CHECK(s.next(end + start_pause).what == session_action::kind::idle);
    CHECK(s.wake_at() == never);
    CHECK(s.stats().requests == 1);
    CHECK(s.stats().replies == 1);
}

TEST_CASE("slave: the M2 reply goes out byte for byte as in the manual", "[movilink][slave]") {
    slave s;
    const time_point end = feed(s, m2_req, at(0ms));
    REQUIRE(s.has_request());
    CHECK(s.request().type == pdu_type::pd3_acyclic);
    CHECK(s.request().pd == std::array<std::uint16_t, 3>{0x0006, 0x2000, 0x0BB8});
    REQUIRE_FALSE(s.respond(parsed(m2_rsp)));
    const auto a = s.next(end + 10ms); // respond()ed late: send at once
    REQUIRE(a.what == session_action::kind::send);
    CHECK(bytes_of(a) == m2_rsp);
}

TEST_CASE("slave: D4 error reply to the D2 read", "[movilink][slave]") {
    slave s;
    const time_point end = feed(s, d2, at(0ms));
    REQUIRE(s.has_request());
    CHECK(s.request().param == param_channel::make(service::read, 0x207E));
    REQUIRE_FALSE(s.respond(parsed(d4)));
    const auto a = s.next(end + start_pause);
    REQUIRE(a.what == session_action::kind::send);
    CHECK(bytes_of(a) == d4);
}

TEST_CASE("slave: processing time adds to the start pause", "[movilink][slave]") {
    slave_config cfg;
    cfg.processing_time = 5ms;
    slave s(cfg);
    const time_point end = feed(s, d6, at(0ms));
    REQUIRE(s.has_request());
    CHECK(s.request().param.handshake());
    REQUIRE_FALSE(s.respond(reply_to(s.request())));
    CHECK(s.next(end).deadline == end + start_pause + 5ms);
    CHECK(s.next(end + start_pause).what == session_action::kind::wait);
    CHECK(s.next(end + start_pause + 5ms).what == session_action::kind::send);
}

TEST_CASE("slave: group and broadcast requests are processed but never answered",
          "[movilink][slave]") {
    slave_config cfg;
    cfg.group = 101;
    slave s(cfg);

    SECTION("D8: group 101") {
        feed(s, d8, at(0ms));
        REQUIRE(s.has_request());
        CHECK(s.request().address == 101);
    }
    SECTION("D7: broadcast") {
        feed(s, d7, at(0ms));
        REQUIRE(s.has_request());
        CHECK(s.request().pd[1] == 0x1000);
    }
    CHECK_FALSE(s.response_expected());
    CHECK(s.respond(reply_to(s.request())) == errc::no_response_expected);
    CHECK(s.has_request());
    s.consume();
    CHECK_FALSE(s.has_request());
    CHECK(s.next(at(1s)).what == session_action::kind::idle);
    CHECK(s.stats().requests == 1);
    CHECK(s.stats().no_reply_requests == 1);
    CHECK(s.stats().replies == 0);
}

TEST_CASE("slave: addressing", "[movilink][slave]") {
    SECTION("another unit's address is ignored (D9 is for address 3)") {
        slave s;
        feed(s, d9, at(0ms));
        CHECK_FALSE(s.has_request());
        CHECK(s.stats().ignored_other_address == 1);
        CHECK(s.stats().skipped_bytes == 0);
    }
    SECTION("D9 for address 3: BCC 0x00 is a valid checksum") {
        slave_config cfg;
        cfg.address = 3;
        slave s(cfg);
        feed(s, d9, at(0ms));
        REQUIRE(s.has_request());
        CHECK(s.request().type == pdu_type::pd1);
        CHECK(s.request().pd[0] == 0);
    }
    SECTION("group 100 means no group") {
        slave s; // group = 100
        CHECK_FALSE(s.addressed(100));
        CHECK_FALSE(s.addressed(101));
        CHECK(s.addressed(1));
        CHECK(s.addressed(254));
        CHECK(s.addressed(255));
        CHECK_FALSE(s.addressed(253));
        feed(s, d8, at(0ms));
        CHECK_FALSE(s.has_request());
        CHECK(s.stats().ignored_other_address == 1);
    }
    SECTION("point-to-point 254: the reply may carry 254 or the unit's own address") {
        slave_config cfg;
        cfg.address = 7;
        slave s(cfg);
        telegram req{direction::request, address_point_to_point, pdu_type::pd1, {}, {0x0006}};
        std::array<std::uint8_t, max_telegram_size> buf{};
        const std::size_t n = *encode(req, buf);
        feed(s, std::span<const std::uint8_t>(buf.data(), n), at(0ms));
        REQUIRE(s.has_request());
        CHECK(s.response_expected());
        telegram reply = reply_to(s.request());
        reply.address = 8;
        CHECK(s.respond(reply) == errc::invalid_argument);
        reply.address = 7;
        CHECK_FALSE(s.respond(reply));
    }
}

TEST_CASE("slave: respond() checks the reply", "[movilink][slave]") {
    slave s;
    CHECK(s.respond(parsed(m2_rsp)) == errc::invalid_argument); // nothing to answer
    feed(s, m1, at(0ms));
    REQUIRE(s.has_request());
    telegram r = reply_to(s.request());
    r.type = pdu_type::pd3_acyclic; // TYP must match the request (SC01 p.24)
    CHECK(s.respond(r) == errc::invalid_argument);
    r = reply_to(s.request());
    r.dir = direction::request;
    CHECK(s.respond(r) == errc::invalid_argument);
    r = reply_to(s.request());
    r.address = 2;
    CHECK(s.respond(r) == errc::invalid_argument);
    CHECK(s.has_request());
}

TEST_CASE("slave: faulty requests get no answer", "[movilink][slave]") {
    slave s;
    SECTION("bad BCC") {
        byte_vector bad = m1;
        bad.back() ^= 0x01;
        feed(s, bad, at(0ms));
        CHECK(s.stats().bad_checksum == 1);
        CHECK(s.stats().skipped_bytes == m1.size());
    }
    SECTION("undocumented TYP") {
        const byte_vector bad{0x02, 0x01, 0x07, 0x00, 0x00, 0x04};
        feed(s, bad, at(0ms));
        CHECK(s.stats().malformed == 1);
        CHECK(s.stats().skipped_bytes == bad.size());
    }
    SECTION("a response telegram (another unit's reply) is no request") {
        feed(s, m2_rsp, at(0ms));
        CHECK(s.stats().malformed == 1);
    }
    CHECK_FALSE(s.has_request());
    CHECK(s.next(at(1s)).what == session_action::kind::idle);
    // After a start pause the next good request is taken.
    feed(s, m1, at(1s));
    CHECK(s.has_request());
    CHECK(s.stats().requests == 1);
}

TEST_CASE("slave: character delay and start pause frame the telegram", "[movilink][slave]") {
    slave s;
    const std::span<const std::uint8_t> whole(m1);
    const auto head = whole.first(4);
    const auto tail = whole.subspan(4);

    SECTION("a pause just under max_char_delay keeps the telegram") {
        const time_point t = feed(s, head, at(0ms));
        feed(s, tail, t + max_char_delay);
        CHECK(s.has_request());
        CHECK(s.stats().gap_errors == 0);
    }
    SECTION("a pause over max_char_delay breaks it; the rest is skipped") {
        const time_point t = feed(s, head, at(0ms));
        feed(s, tail, t + max_char_delay + 1us);
        CHECK_FALSE(s.has_request());
        CHECK(s.stats().gap_errors == 1);
        CHECK(s.stats().skipped_bytes == m1.size());
        CHECK(s.stats().malformed == 0);
    }
    SECTION("a start pause inside it: the rest starts with a byte that is no SD1") {
        const time_point t = feed(s, head, at(0ms));
        feed(s, tail, t + start_pause);
        CHECK_FALSE(s.has_request());
        CHECK(s.stats().gap_errors == 1);
        CHECK(s.stats().malformed == 1);
        CHECK(s.stats().skipped_bytes == m1.size());
    }
    SECTION("byte by byte, each at its wire time") {
        const time_point end = feed_bytewise(s, m1, at(0ms));
        REQUIRE(s.has_request());
        CHECK(s.request_end() == end);
    }
    SECTION("byte by byte with 3 ms between the characters") {
        feed_bytewise(s, m1, at(0ms), 3ms);
        CHECK(s.has_request());
    }
}

TEST_CASE("slave: a telegram needs the start pause before its SD1", "[movilink][slave]") {
    slave s;
    // D9 (for address 3) and M1 1 ms later: M1 has no start pause, it is not a telegram.
    const time_point t = feed(s, d9, at(0ms));
    feed(s, m1, t + 1ms);
    CHECK_FALSE(s.has_request());
    CHECK(s.stats().ignored_other_address == 1);
    CHECK(s.stats().malformed == 1);
    CHECK(s.stats().skipped_bytes == m1.size());
    // The same bytes after a start pause are.
    feed(s, m1, t + 1ms + fmt.chars_time(m1.size()) + start_pause);
    CHECK(s.has_request());
}

TEST_CASE("slave: bus activity before the reply drops the request", "[movilink][slave]") {
    slave s;
    SECTION("bytes right behind the request: the line was not clean") {
        byte_vector both = m1;
        both.push_back(0x00);
        feed(s, both, at(0ms));
        CHECK_FALSE(s.has_request());
        CHECK(s.stats().requests == 1);
        CHECK(s.stats().malformed == 1);
        CHECK(s.stats().abandoned == 0);
    }
    SECTION("a new request after a start pause: the master has moved on") {
        const time_point end = feed(s, m1, at(0ms));
        REQUIRE_FALSE(s.respond(reply_to(s.request())));
        feed(s, d2, end + start_pause); // before the slave's reply went out
        CHECK(s.stats().abandoned == 1);
        REQUIRE(s.has_request());
        CHECK(s.request().type == pdu_type::param_acyclic);
        CHECK(s.wake_at() == never);
    }
    SECTION("traffic for another unit while the application still decides") {
        const time_point end = feed(s, m1, at(0ms));
        feed(s, d9, end + 10ms);
        CHECK_FALSE(s.has_request());
        CHECK(s.stats().abandoned == 1);
    }
}
