#include <catch2/catch.hpp>

#include <array>

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

TEST_CASE("mock_serial injects write failures", "[core][mock_serial]") {
    mock_serial line(f8e1);
    line.fail_next_writes(1);
    const std::array<std::uint8_t, 1> out{1};
    CHECK(line.write(out).ec == ferrule::errc::transport);
    CHECK_FALSE(line.write(out).ec);
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
