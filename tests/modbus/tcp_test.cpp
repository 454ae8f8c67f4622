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

namespace {

// Feeds `in` to a framer `chunk` bytes at a time; the ADUs ended and the bytes taken in all.
mbap_framer::scan frame_all(mbap_framer& f, const bytes& in, std::size_t chunk) {
    mbap_framer::scan all;
    std::span<const std::uint8_t> rest(in);
    while (!rest.empty()) {
        const auto part = rest.first(std::min(chunk, rest.size()));
        const auto s = f.feed(part);
        all.ended += s.ended;
        all.taken += s.taken;
        rest = rest.subspan(part.size());
    }
    return all;
}

} // namespace

TEST_CASE("modbus mbap_framer finds where ADUs end in any chunking", "[modbus][tcp]") {
    bytes stream;
    std::vector<std::size_t> ends;
    for (std::uint16_t t = 1; t <= 5; ++t) {
        const auto f = tcp(t, 1, bytes(t * 50, 0x03)); // PDUs of 50 … 250 bytes
        stream.insert(stream.end(), f.begin(), f.end());
        ends.push_back(stream.size());
    }
    for (std::size_t chunk : {std::size_t{1}, std::size_t{7}, std::size_t{512}}) {
        INFO("chunks of " << chunk);
        mbap_framer f;
        const auto s = frame_all(f, stream, chunk);
        CHECK(s.ended == 5);
        CHECK(s.taken == stream.size());
        CHECK_FALSE(f.in_adu());
        CHECK_FALSE(f.bad());
    }
    // Where each ADU ends: the byte before leaves it under way, its last byte ends it.
    mbap_framer f;
    std::size_t at = 0;
    for (const std::size_t end : ends) {
        CHECK(f.feed(std::span<const std::uint8_t>(stream).subspan(at, end - 1 - at)).ended == 0);
        CHECK(f.in_adu());
        CHECK(f.feed(std::span<const std::uint8_t>(stream).subspan(end - 1, 1)).ended == 1);
        CHECK_FALSE(f.in_adu());
        at = end;
    }
}

TEST_CASE("modbus mbap_framer stops at a header no ADU starts with", "[modbus][tcp]") {
    const auto good = tcp(7, 1, {0x03, 0x00, 0x01, 0x00, 0x03});
    struct bad_case {
        bytes header;
        std::size_t judged_at; // bytes of it read when it is found bad
    };
    for (const auto& [bad, judged_at] :
         {bad_case{{0x00, 0x01, 0x00, 0x01, 0x00, 0x06}, 4}, // protocol 1
          bad_case{{0x00, 0x01, 0x00, 0x00, 0x00, 0x01}, 6}, // length 1
          bad_case{{0x00, 0x01, 0x00, 0x00, 0x00, 0xFF}, 6}, // length 255
          bad_case{{0x00, 0x00, 0x00, 0x00, 0x00, 0x00}, 6}}) {
        INFO("header " << int(bad[2]) << int(bad[3]) << " " << int(bad[5]));
        bytes stream = good;
        stream.insert(stream.end(), bad.begin(), bad.end());
        stream.insert(stream.end(), good.begin(), good.end());

        // In one chunk: the ADU before it is taken, nothing from the bad header on.
        mbap_framer one;
        const auto s = one.feed(stream);
        CHECK(s.ended == 1);
        CHECK(s.taken == good.size());
        CHECK(one.bad());
        CHECK(one.feed(good).taken == 0);

        // Byte by byte: it is judged as soon as the field in question is in.
        mbap_framer bytewise;
        std::size_t taken = 0;
        for (std::size_t i = 0; i < stream.size() && !bytewise.bad(); ++i)
            taken += bytewise.feed(std::span<const std::uint8_t>(stream).subspan(i, 1)).taken;
        CHECK(bytewise.bad());
        CHECK(taken == good.size() + judged_at - 1); // the header's bytes before were taken
    }
}
