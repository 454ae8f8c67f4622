#include <catch2/catch.hpp>

#include <array>
#include <system_error>

#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using ferrule::mock_serial;
using ferrule::time_point;

namespace {
const ferrule::serial_format f8e1{9600, 8, ferrule::parity::even, 1};
}

TEST_CASE("mock_serial writes take wire time and are logged", "[core][mock_serial]") {
    mock_serial line(f8e1);
    const std::array<std::uint8_t, 3> out{1, 2, 3};
    const auto r = line.write(out);
    CHECK(r.bytes == 3);
    CHECK_FALSE(r.ec);
    CHECK(line.now() == time_point{} + f8e1.chars_time(3));
    REQUIRE(line.wire().size() == 3);
    CHECK(line.wire()[1].start == time_point{} + f8e1.chars_time(1));
    CHECK(line.wire()[2].end == line.now());
    CHECK(line.wire()[0].origin == ferrule::wire_byte::from::session);
}

TEST_CASE("mock_serial read_some waits in virtual time and times out at the deadline",
          "[core][mock_serial]") {
    mock_serial line(f8e1);
    std::array<std::uint8_t, 8> in{};
    const auto t0 = line.now();
    auto r = line.read_some(in, t0 + 5s);
    CHECK(r.bytes == 0);
    CHECK(r.ec == ferrule::errc::timeout);
    CHECK(line.now() == t0 + 5s);

    const std::array<std::uint8_t, 2> reply{0xAB, 0xCD};
    line.inject(reply, line.now() + 10ms);
    r = line.read_some(in, line.now() + 1s);
    REQUIRE(r.bytes == 1); // one byte has arrived when the clock reaches its end
    CHECK(in[0] == 0xAB);
    CHECK(line.now() == t0 + 5s + 10ms + f8e1.char_time());
    r = line.read_some(in, line.now() + 1s);
    REQUIRE(r.bytes == 1);
    CHECK(in[0] == 0xCD);
    CHECK(line.now() == t0 + 5s + 10ms + f8e1.chars_time(2));
}

TEST_CASE("mock_serial delivers what has arrived in one read and honours read_size",
          "[core][mock_serial]") {
    mock_serial line(f8e1);
    const std::array<std::uint8_t, 4> bytes{1, 2, 3, 4};
    line.inject(bytes, line.now());
    line.advance(1s);
    line.set_read_size(3);
    std::array<std::uint8_t, 8> in{};
    auto r = line.read_some(in, line.now());
    CHECK(r.bytes == 3);
    r = line.read_some(in, line.now());
    CHECK(r.bytes == 1);
    CHECK(in[0] == 4);
}

TEST_CASE("mock_serial discard_input drops only bytes that have arrived", "[core][mock_serial]") {
    mock_serial line(f8e1);
    const std::array<std::uint8_t, 2> stale{0x55, 0x66};
    line.inject(stale, line.now());
    line.advance(f8e1.char_time()); // first byte has arrived, second is still on the wire
    line.discard_input();
    CHECK(line.discarded() == 1);
    CHECK(line.pending() == 1);
}

TEST_CASE("mock_serial fails the n-th I/O operation once, writes and reads alike",
          "[core][mock_serial]") {
    const ferrule::error injected =
        ferrule::from_error_code(std::make_error_code(std::errc::io_error));
    mock_serial line(f8e1);
    const std::array<std::uint8_t, 1> out{1};
    std::array<std::uint8_t, 4> in{};
    line.fail_at(3, injected);
    CHECK_FALSE(line.write(out).ec);                                          // 1
    CHECK(line.read_some(in, line.now() + 1ms).ec == ferrule::errc::timeout); // 2
    const auto t = line.now();
    const auto failed = line.write(out); // 3
    CHECK(failed.ec == injected);
    CHECK(failed.bytes == 0);
    CHECK(line.now() == t);         // a failed write takes no wire time ...
    CHECK(line.wire().size() == 1); // ... and puts nothing on the line
    CHECK(line.writes() == 1);
    CHECK_FALSE(line.write(out).ec); // 4: once only
    CHECK(line.io_operations() == 4);
}

TEST_CASE("mock_serial: a failed read takes no byte and moves no clock", "[core][mock_serial]") {
    mock_serial line(f8e1);
    const std::array<std::uint8_t, 2> bytes{0x11, 0x22};
    line.inject(bytes, line.now());
    line.advance(1s);
    line.fail_at(1);
    std::array<std::uint8_t, 4> in{};
    const auto t = line.now();
    const auto failed = line.read_some(in, t + 1s);
    CHECK(failed.ec == ferrule::errc::transport); // the default error
    CHECK(failed.bytes == 0);
    CHECK(line.now() == t);
    CHECK(line.pending() == 2);
    const auto r = line.read_some(in, t + 1s);
    REQUIRE(r.bytes == 2);
    CHECK(in[0] == 0x11);
}

TEST_CASE("mock_serial fail_at(0) fails nothing and a new count replaces the old",
          "[core][mock_serial]") {
    mock_serial line(f8e1);
    const std::array<std::uint8_t, 1> out{1};
    line.fail_at(2);
    line.fail_at(0);
    for (int i = 0; i < 4; ++i) CHECK_FALSE(line.write(out).ec);
    line.fail_at(5);
    line.fail_at(1);
    CHECK(line.write(out).ec == ferrule::errc::transport);
    for (int i = 0; i < 5; ++i) CHECK_FALSE(line.write(out).ec);
    CHECK(line.io_operations() == 10);
}

TEST_CASE("mock_serial end of stream: bytes on their way, then an error at once",
          "[core][mock_serial]") {
    const std::array<std::uint8_t, 1> req{0x10};
    const std::array<std::uint8_t, 2> rsp{0xA0, 0xA1};
    std::array<ferrule::script_step, 2> steps{};
    steps[0].reply = rsp;
    steps[1].reply = rsp;
    ferrule::script_peer peer(steps);
    mock_serial line(f8e1, &peer);
    line.write(req); // the reply is on its way when the far end closes
    line.end_of_stream();
    std::array<std::uint8_t, 4> in{};
    std::size_t got = 0;
    while (got < rsp.size()) {
        const auto r = line.read_some(in, line.now() + 1s);
        REQUIRE_FALSE(r.ec);
        got += r.bytes;
    }
    const auto t = line.now();
    auto r = line.read_some(in, t + 1s);
    CHECK(r.ec == ferrule::errc::transport);
    CHECK(r.bytes == 0);
    CHECK(line.now() == t); // no wait for the deadline
    CHECK_FALSE(line.write(req).ec);
    CHECK(peer.steps_done() == 1); // nobody heard the write
    line.end_of_stream(false);
    r = line.read_some(in, line.now() + 1s);
    CHECK(r.ec == ferrule::errc::timeout);
}

TEST_CASE("mock_serial: a silent peer hears the request and the read times out",
          "[core][mock_serial]") {
    const std::array<std::uint8_t, 2> req{0x10, 0x20};
    const std::array<ferrule::script_step, 1> steps{ferrule::script_step{req}};
    ferrule::script_peer peer(steps);
    mock_serial line(f8e1, &peer);
    REQUIRE_FALSE(line.write(req).ec);
    std::array<std::uint8_t, 4> in{};
    const auto t = line.now();
    const auto r = line.read_some(in, t + 100ms);
    CHECK(r.ec == ferrule::errc::timeout);
    CHECK(line.now() == t + 100ms);
    CHECK(peer.finished());
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("script_peer answers after its delay, in chunks, with faults", "[core][mock_serial]") {
    const std::array<std::uint8_t, 2> req{0x10, 0x20};
    const std::array<std::uint8_t, 4> rsp{0xA0, 0xA1, 0xA2, 0xA3};
    std::array<ferrule::script_step, 2> steps{};
    steps[0].expect = req;
    steps[0].reply = rsp;
    steps[0].delay = 4ms;
    steps[0].chunk = 2;
    steps[0].chunk_gap = 2ms;
    steps[1].reply = rsp;
    steps[1].drop_index = 1;
    steps[1].corrupt_index = 3;
    steps[1].corrupt_mask = 0x0F;
    ferrule::script_peer peer(steps);
    mock_serial line(f8e1, &peer);

    line.write(req);
    const auto end = line.now();
    std::array<std::uint8_t, 8> in{};
    std::array<std::uint8_t, 8> got{};
    std::size_t n = 0;
    while (n < 4) {
        const auto r = line.read_some(in, line.now() + 1s);
        REQUIRE(r.bytes > 0);
        for (std::size_t i = 0; i < r.bytes; ++i) got[n++] = in[i];
    }
    CHECK(std::equal(rsp.begin(), rsp.end(), got.begin()));
    // Two chunks: bytes 0-1 then 2 ms of silence, then bytes 2-3.
    CHECK(line.now() == end + 4ms + f8e1.chars_time(4) + 2ms);
    CHECK(peer.mismatches() == 0);

    line.write(req);
    n = 0;
    while (n < 3) {
        const auto r = line.read_some(in, line.now() + 1s);
        REQUIRE(r.bytes > 0);
        for (std::size_t i = 0; i < r.bytes; ++i) got[n++] = in[i];
    }
    CHECK(got[0] == 0xA0);
    CHECK(got[1] == 0xA2);
    CHECK(got[2] == (0xA3 ^ 0x0F));
    CHECK(peer.finished());
    line.write(req);
    CHECK(peer.unexpected_requests() == 1);
}
