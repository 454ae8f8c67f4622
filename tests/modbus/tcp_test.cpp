// Modbus TCP: MBAP header encode and tcp_decoder framing.
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "ferrule/modbus/tcp.hpp"

using namespace ferrule::modbus;
using ferrule::errc;
using bytes = std::vector<std::uint8_t>;
using status = tcp_decoder::status;

namespace {

bytes tcp(std::uint16_t transaction, std::uint8_t unit, const bytes& pdu) {
    bytes out(max_tcp_adu);
    const auto n = encode_tcp(transaction, unit, pdu, out);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

struct frame {
    std::uint16_t transaction;
    std::uint8_t unit;
    bytes pdu;
};

std::vector<frame> feed_all(tcp_decoder& d, const bytes& in, std::size_t chunk,
                            std::size_t* errors = nullptr) {
    std::vector<frame> out;
    std::span<const std::uint8_t> all(in);
    for (std::size_t pos = 0; pos < all.size(); pos += chunk) {
        auto part = all.subspan(pos, std::min(chunk, all.size() - pos));
        tcp_decoder::step s;
        do {
            s = d.feed(part);
            part = part.subspan(s.consumed);
            if (s.what == status::frame)
                out.push_back({d.transaction(), d.unit(), bytes(d.pdu().begin(), d.pdu().end())});
            if (s.what == status::error && errors) ++*errors;
        } while (s.what != status::need_more);
    }
    return out;
}

} // namespace

TEST_CASE("modbus MBAP header: transaction, protocol 0, length, unit", "[modbus][tcp]") {
    // TCP guide example: read 1 holding register at 0x0004 of unit 0x11, transaction 1.
    CHECK(tcp(0x0001, 0x11, {0x03, 0x00, 0x04, 0x00, 0x01}) ==
          bytes{0x00, 0x01, 0x00, 0x00, 0x00, 0x06, 0x11, 0x03, 0x00, 0x04, 0x00, 0x01});
    std::array<std::uint8_t, max_tcp_adu> out{};
    CHECK(encode_tcp(1, 1, {}, out).error() == errc::invalid_argument);
    const bytes full(max_pdu, 0x10);
    CHECK(*encode_tcp(0xFFFF, 0xFF, full, out) == max_tcp_adu);
    const bytes big(max_pdu + 1, 0x10);
    CHECK(encode_tcp(1, 1, big, out).error() == errc::invalid_argument);
    std::array<std::uint8_t, 8> small{};
    const bytes pdu{0x03, 0x00, 0x04, 0x00, 0x01};
    CHECK(encode_tcp(1, 1, pdu, small).error() == errc::buffer_too_small);
}

TEST_CASE("modbus tcp_decoder splits a stream into ADUs in any chunking", "[modbus][tcp]") {
    bytes stream;
    for (std::uint16_t t = 1; t <= 5; ++t) {
        const auto f = tcp(t, static_cast<std::uint8_t>(t + 10), bytes(t, 0x03));
        stream.insert(stream.end(), f.begin(), f.end());
    }
    for (std::size_t chunk : {std::size_t{1}, std::size_t{5}, stream.size()}) {
        tcp_decoder d;
        std::size_t errors = 0;
        const auto frames = feed_all(d, stream, chunk, &errors);
        CHECK(errors == 0);
        REQUIRE(frames.size() == 5);
        for (std::uint16_t t = 1; t <= 5; ++t) {
            CHECK(frames[t - 1].transaction == t);
            CHECK(frames[t - 1].unit == t + 10);
            CHECK(frames[t - 1].pdu == bytes(t, 0x03));
        }
        CHECK(d.skipped() == 0);
        CHECK_FALSE(d.in_frame());
    }
}

TEST_CASE("modbus tcp_decoder: bad protocol id or length is malformed, then resynchronised",
          "[modbus][tcp]") {
    const auto good = tcp(7, 1, {0x06, 0x00, 0x01, 0x00, 0x03});
    for (const bytes& bad : {bytes{0x00, 0x01, 0x00, 0x01, 0x00, 0x06, 0x01},    // protocol 1
                             bytes{0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x01},    // length 1
                             bytes{0x00, 0x01, 0x00, 0x00, 0x00, 0xFF, 0x01}}) { // length 255
        bytes stream = bad;
        stream.insert(stream.end(), good.begin(), good.end());
        tcp_decoder d;
        std::size_t errors = 0;
        const auto frames = feed_all(d, stream, 1, &errors);
        CHECK(errors >= 1);
        REQUIRE(frames.size() == 1);
        CHECK(frames[0].transaction == 7);
        CHECK(d.skipped() == bad.size());
    }
    tcp_decoder d;
    CHECK(d.feed(bytes{0x00, 0x01, 0x00}).what == status::need_more);
    CHECK(d.in_frame());
    d.reset();
    CHECK_FALSE(d.in_frame());
}
