// memobus::server_session, one channel of the controller's side as a station: TCP bytes
// framed into messages however they come (in pieces, several at once, behind garbage), each
// answered by the channel's server in order; UDP datagrams one message each.
#include <catch2/catch.hpp>

#include <chrono>
#include <cstdint>
#include <span>
#include <vector>

#include "ferrule/core/session.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/register_image.hpp"
#include "ferrule/memobus/server.hpp"
#include "ferrule/memobus/server_session.hpp"

using namespace ferrule;
using namespace ferrule::memobus;
using namespace std::chrono_literals;
using octets = std::vector<std::uint8_t>;
using image_type = register_image<256, 64>;

namespace {

time_point at(duration d) {
    return time_point{} + d;
}

// A command of SFC `f` with serial number `serial`.
octets command(sfc f, std::uint16_t address, std::uint16_t count, std::uint8_t serial,
               std::uint16_t value = 0) {
    const request r{.function = f, .cpu = 0x21, .address = address, .count = count, .value = value};
    octets out(max_message);
    const auto n = encode_command(r, serial, out);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

// SFC 03: read `count` hold registers from MW`address`.
octets read_mw(std::uint16_t address, std::uint16_t count, std::uint8_t serial) {
    return command(sfc::read_holding_registers, address, count, serial);
}

// What memobus::server alone answers to `message` on `image`.
octets answer_of(const octets& message, image_type image) {
    server s;
    octets out(max_message);
    out.resize(s.handle(message, image, out));
    REQUIRE_FALSE(out.empty());
    return out;
}

// The replies the session hands out at `now`, in order.
std::vector<octets> replies(server_session& s, time_point now) {
    std::vector<octets> out;
    for (;;) {
        const session_action a = s.next(now);
        if (a.what != session_action::kind::send) {
            CHECK(a.what == session_action::kind::idle);
            return out;
        }
        out.emplace_back(a.bytes.begin(), a.bytes.end());
    }
}

octets concat(const octets& a, const octets& b) {
    octets out = a;
    out.insert(out.end(), b.begin(), b.end());
    return out;
}

} // namespace

TEST_CASE("memobus server_session: a message in pieces is answered once its last byte came",
          "[memobus][server_session]") {
    image_type image;
    image.set_mw(10, 0x1234);
    server_session s(image);
    const octets message = read_mw(10, 1, 5);
    const auto bytes = std::span<const std::uint8_t>(message);

    s.on_receive(bytes.first(5), at(1ms)); // part of the header
    CHECK(s.in_message());
    CHECK(s.wake_at() == never);
    CHECK(replies(s, at(1ms)).empty());
    s.on_receive(bytes.subspan(5, 10), at(2ms)); // the header and a part of the body
    CHECK(s.in_message());
    CHECK(replies(s, at(2ms)).empty());
    s.on_receive(bytes.subspan(15), at(3ms));
    CHECK_FALSE(s.in_message());
    CHECK(s.wake_at() == at(3ms));
    CHECK(replies(s, at(3ms)) == std::vector<octets>{answer_of(message, image)});
    CHECK(s.wake_at() == never);
    CHECK(s.stats().messages == 1);
    CHECK(s.handler().stats().requests == 1);
}

TEST_CASE("memobus server_session: two messages in one chunk are answered in order",
          "[memobus][server_session]") {
    image_type image;
    image.set_mw(0, 0x0A0A);
    image.set_mw(1, 0x0B0B);
    server_session s(image);
    const octets first = read_mw(0, 1, 1);
    const octets second = read_mw(1, 1, 2);

    s.on_receive(concat(first, second), at(4ms));
    // The second waits behind the first's reply, whose time has come.
    CHECK(s.wake_at() == at(4ms));
    CHECK(s.stats().messages == 1);
    const auto out = replies(s, at(5ms));
    REQUIRE(out.size() == 2);
    CHECK(out[0] == answer_of(first, image));
    CHECK(out[1] == answer_of(second, image));
    CHECK(s.stats().messages == 2);
    CHECK(s.wake_at() == never);
    CHECK(s.stats().overflowed == 0);
}

TEST_CASE("memobus server_session: bytes that start no message are one malformed run, the "
          "message behind them is answered",
          "[memobus][server_session]") {
    image_type image;
    server_session s(image);
    // Type 0x55 is no 218 message type (§2): a header no message starts with.
    const octets garbage{0x55, 0x00, 0x00, 0x00, 0x00, 0x00, 0x16, 0x00};
    const octets message = read_mw(3, 2, 9);

    s.on_receive(garbage, at(1ms));
    CHECK(s.stats().malformed == 1);
    CHECK(s.in_message()); // bytes that form no message are timed as a request
    CHECK(replies(s, at(1ms)).empty());
    s.on_receive(message, at(2ms));
    CHECK(s.stats().malformed == 1);
    CHECK(replies(s, at(2ms)) == std::vector<octets>{answer_of(message, image)});
    CHECK_FALSE(s.in_message());
    CHECK(s.handler().stats().ignored == 0);
}

TEST_CASE("memobus server_session: over UDP a datagram is one message",
          "[memobus][server_session]") {
    image_type image;
    server_session s(image, {}, transport::udp);
    const octets message = read_mw(0, 4, 3);

    // A datagram cut short is no message: not answered, counted by the server as ignored.
    s.on_receive(std::span<const std::uint8_t>(message).first(message.size() - 1), at(1ms));
    CHECK(replies(s, at(1ms)).empty());
    CHECK(s.handler().stats().ignored == 1);
    CHECK_FALSE(s.in_message());

    s.on_receive(message, at(2ms));
    CHECK(replies(s, at(2ms)) == std::vector<octets>{answer_of(message, image)});
    // Two messages in one datagram are not one message either.
    s.on_receive(concat(message, message), at(3ms));
    CHECK(replies(s, at(3ms)).empty());
    CHECK(s.handler().stats().ignored == 2);
}

TEST_CASE("memobus server_session: writes reach the image the session was given",
          "[memobus][server_session]") {
    image_type image;
    server_session s(image);
    const octets message = command(sfc::write_holding_register, 20, 1, 1, 0xBEEF);
    s.on_receive(message, at(1ms));
    CHECK(replies(s, at(1ms)).size() == 1);
    CHECK(image.mw(20) == 0xBEEF);
}
