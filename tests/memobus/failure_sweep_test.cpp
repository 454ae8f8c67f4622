// MEMOBUS master through every failure point of a transaction (tests/core/failure_sweep.hpp),
// a silent controller and the end of the stream, against memobus::server on one channel; and
// the controller's side, memobus::server_session, served as a station.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "../core/failure_sweep.hpp"
#include "ferrule/memobus/access.hpp"
#include "ferrule/memobus/register_image.hpp"
#include "ferrule/memobus/server.hpp"
#include "ferrule/memobus/server_session.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule::memobus;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::test::injected;

namespace {

// The byte stream is a TCP connection: the bytes' wire time does not matter here.
const ferrule::serial_format fast{4'000'000, 8, ferrule::parity::none, 1};

// A controller on the other end: each request, one whole message per write, is handled by
// the channel's server and answered 1 ms later; `drop` leaves the next replies out.
class controller final : public ferrule::mock_peer {
public:
    register_image<256, 16> image;
    unsigned drop = 0;

    void on_receive(mock_serial& line, std::span<const std::uint8_t> bytes,
                    ferrule::time_point end) override {
        std::array<std::uint8_t, max_message> out{};
        const std::size_t n = channel_.handle(bytes, image, out);
        if (n == 0) return;
        if (drop > 0) {
            --drop;
            return;
        }
        line.inject(std::span<const std::uint8_t>(out.data(), n), end + 1ms);
    }

private:
    server channel_;
};

using words = std::array<std::uint16_t, 3>;
constexpr words values{0x1234, 0xABCD, 7};
constexpr words untouched{0xDEAD, 0xDEAD, 0xDEAD};

master_config with_retries() {
    master_config c;
    c.retries = 2;
    c.response_timeout = 100ms;
    return c;
}

struct rig {
    controller plc;
    mock_serial line{fast, &plc};
    master m{with_retries()};
    words out = untouched;
    rig() { std::copy(values.begin(), values.end(), plc.image.mw().begin() + 100); }
};

std::error_code read_mw100(rig& r) {
    r.out = untouched;
    return read_words(r.line, r.m, {register_kind::mw, 100}, r.out);
}

void read_values(rig& r, std::error_code ec) {
    CHECK_FALSE(ec);
    CHECK(r.out == values);
}

void nothing_read(const rig& r, std::error_code ec, std::error_code expected) {
    CHECK(ec == expected);
    CHECK(r.out == untouched);
    ferrule::test::failed_once(r.m, expected);
}

// The controller's side: one TCP channel, served as firmware or ferrule-sim would.
struct station_rig {
    register_image<256, 16> image;
    mock_serial line{fast};
    server_session channel{image};
    station_rig() { std::copy(values.begin(), values.end(), image.mw().begin() + 100); }
};

// SFC 09 (read hold registers, extended), MW100 and 4 words, serial number 7.
std::vector<std::uint8_t> read_mw100_command() {
    std::vector<std::uint8_t> out(max_message);
    const request q{.address = 100, .count = static_cast<std::uint16_t>(values.size())};
    out.resize(*encode_command(q, 7, out));
    return out;
}

ferrule::test::served serve_read_mw100(station_rig& r) {
    return ferrule::test::serve_request(r.line, r.channel, read_mw100_command(), 10ms);
}

void answered_values(station_rig& r, const ferrule::test::served& s) {
    CHECK(s.errors == 0);
    std::array<std::uint8_t, max_message> expected{};
    server alone;
    const std::size_t n = alone.handle(read_mw100_command(), r.image, expected);
    REQUIRE(n > 0);
    CHECK(s.sent == std::vector<std::uint8_t>(expected.begin(), expected.begin() + n));
}

} // namespace

TEST_CASE("memobus master failure sweep", "[memobus][master][sweep]") {
    ferrule::test::failure_sweep<rig>(
        read_mw100,
        [](rig& r, std::error_code ec, std::size_t k) {
            ferrule::test::ended_at_failure(r.line, r.m, k);
            nothing_read(r, ec, injected);
            CHECK(r.m.attempts() == 1); // not resent
        },
        read_values);
}

TEST_CASE("memobus master: a silent controller, then the end of the stream",
          "[memobus][master][sweep]") {
    rig r;
    r.plc.drop = 3; // the first attempt and the 2 resends
    nothing_read(r, read_mw100(r), errc::timeout);
    CHECK(r.m.attempts() == 3);
    CHECK(r.m.stats().timeouts == 3);
    CHECK(r.m.stats().resends == 2);
    read_values(r, read_mw100(r));

    rig closed;
    closed.line.end_of_stream();
    nothing_read(closed, read_mw100(closed), errc::transport);
    CHECK(closed.m.attempts() == 1);
    closed.line.end_of_stream(false);
    read_values(closed, read_mw100(closed));
}

TEST_CASE("memobus server_session failure sweep", "[memobus][server_session][sweep]") {
    ferrule::test::station_sweep<station_rig>(serve_read_mw100, answered_values);
}
