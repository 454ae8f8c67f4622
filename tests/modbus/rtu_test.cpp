// Modbus RTU: CRC golden vectors, encode_rtu, rtu_decoder and rtu_receiver framing and
// resynchronisation.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <span>
#include <vector>

#include "ferrule/core/checksum.hpp"
#include "ferrule/modbus/rtu.hpp"

using namespace ferrule::modbus;
using ferrule::errc;
using bytes = std::vector<std::uint8_t>;
using status = rtu_decoder::status;

namespace {

bytes rtu(std::uint8_t address, const bytes& pdu) {
    bytes out(max_rtu_adu);
    const auto n = encode_rtu(address, pdu, out);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

struct fed {
    std::vector<bytes> frames; // address + PDU
    std::vector<std::error_code> errors;
};

// Feeds `in` in chunks of `chunk` bytes, the way the decoder asks to be fed; then, if
// `silence`, tells it the line went quiet.
fed feed_all(rtu_decoder& d, const bytes& in, std::size_t chunk = 0, bool silence = false) {
    fed out;
    std::span<const std::uint8_t> all(in);
    if (chunk == 0) chunk = in.size() ? in.size() : 1;
    for (std::size_t pos = 0; pos < all.size(); pos += chunk) {
        auto part = all.subspan(pos, std::min(chunk, all.size() - pos));
        rtu_decoder::step s;
        do {
            s = d.feed(part);
            part = part.subspan(s.consumed);
            if (s.what == status::frame) {
                bytes f{d.address()};
                f.insert(f.end(), d.pdu().begin(), d.pdu().end());
                out.frames.push_back(f);
            } else if (s.what == status::error) {
                out.errors.push_back(s.ec);
            }
        } while (s.what != status::need_more);
    }
    if (!silence) return out;
    rtu_decoder::step s;
    do {
        s = d.finish();
        if (s.what == status::frame) {
            bytes f{d.address()};
            f.insert(f.end(), d.pdu().begin(), d.pdu().end());
            out.frames.push_back(f);
        } else if (s.what == status::error) {
            out.errors.push_back(s.ec);
        }
    } while (s.what != status::need_more);
    return out;
}

} // namespace

TEST_CASE("modbus CRC golden vectors of modbus_profibus.md A.2", "[modbus][rtu]") {
    const std::array<std::uint8_t, 9> check{'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    CHECK(ferrule::crc16_modbus(check) == 0x4B37);
    // The paper's frame: 01 06 C8 00 00 25 -> CRC 0x7176, on the wire 76 71.
    CHECK(rtu(0x01, {0x06, 0xC8, 0x00, 0x00, 0x25}) ==
          bytes{0x01, 0x06, 0xC8, 0x00, 0x00, 0x25, 0x76, 0x71});
    CHECK(rtu(0x01, {0x03, 0x00, 0x00, 0x00, 0x0A}) ==
          bytes{0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD});
    CHECK(rtu(0x11, {0x03, 0x00, 0x6B, 0x00, 0x03}) ==
          bytes{0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x76, 0x87});
    CHECK(rtu(0x11, {0x01, 0x00, 0x13, 0x00, 0x25}) ==
          bytes{0x11, 0x01, 0x00, 0x13, 0x00, 0x25, 0x0E, 0x84});
    CHECK(rtu(0x11, {0x02, 0x00, 0xC4, 0x00, 0x16}) ==
          bytes{0x11, 0x02, 0x00, 0xC4, 0x00, 0x16, 0xBA, 0xA9});
    CHECK(rtu(0x11, {0x05, 0x00, 0xAC, 0xFF, 0x00}) ==
          bytes{0x11, 0x05, 0x00, 0xAC, 0xFF, 0x00, 0x4E, 0x8B});
    CHECK(rtu(0x11, {0x06, 0x00, 0x01, 0x00, 0x03}) ==
          bytes{0x11, 0x06, 0x00, 0x01, 0x00, 0x03, 0x9A, 0x9B});
    CHECK(rtu(0x11, {0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01}) ==
          bytes{0x11, 0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01, 0xBF, 0x0B});
    CHECK(rtu(0x11, {0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02}) ==
          bytes{0x11, 0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02, 0xC6, 0xF0});
    CHECK(rtu(0x01, {0x03, 0x50, 0x00, 0x00, 0x18}) ==
          bytes{0x01, 0x03, 0x50, 0x00, 0x00, 0x18, 0x54, 0xC0});
    CHECK(rtu(0x01, {0x10, 0x8A, 0x00, 0x00, 0x03}) ==
          bytes{0x01, 0x10, 0x8A, 0x00, 0x00, 0x03, 0xAA, 0x10});
    CHECK(rtu(0x04, {0x01, 0x00, 0x0A, 0x00, 0x0D}) ==
          bytes{0x04, 0x01, 0x00, 0x0A, 0x00, 0x0D, 0xDD, 0x98});
    CHECK(rtu(0x01, {0x83, 0x02}) == bytes{0x01, 0x83, 0x02, 0xC0, 0xF1});
    CHECK(rtu(0x01, {0x08, 0x00, 0x00, 0x12, 0x34}) ==
          bytes{0x01, 0x08, 0x00, 0x00, 0x12, 0x34, 0xED, 0x7C});
    const bytes t1{0x01, 0x03, 0x08, 0x2B, 0x00, 0x02};
    CHECK(ferrule::crc16_modbus(t1) == 0x63B6);
    const bytes t2{0x02, 0x07};
    CHECK(ferrule::crc16_modbus(t2) == 0x1241);
    // A whole frame, CRC included, has CRC 0.
    const auto f = rtu(0x01, {0x06, 0xC8, 0x00, 0x00, 0x25});
    CHECK(ferrule::crc16_modbus(f) == 0);
}

TEST_CASE("modbus encode_rtu refuses empty or oversized PDUs and small buffers", "[modbus][rtu]") {
    std::array<std::uint8_t, max_rtu_adu> out{};
    CHECK(encode_rtu(1, {}, out).error() == errc::invalid_argument);
    const bytes big(max_pdu + 1, 0x03);
    CHECK(encode_rtu(1, big, out).error() == errc::invalid_argument);
    const bytes full(max_pdu, 0x17);
    CHECK(*encode_rtu(1, full, out) == max_rtu_adu);
    const bytes pdu{0x03, 0x00, 0x00, 0x00, 0x01};
    std::array<std::uint8_t, 7> small{};
    CHECK(encode_rtu(1, pdu, small).error() == errc::buffer_too_small);
}

TEST_CASE("modbus rtu_decoder frames responses of every function code, byte by byte",
          "[modbus][rtu]") {
    const std::vector<bytes> pdus{
        {0x01, 0x05, 0xCD, 0x6B, 0xB2, 0x0E, 0x1B},
        {0x02, 0x03, 0xAC, 0xDB, 0x35},
        {0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64},
        {0x04, 0x02, 0x00, 0x0A},
        {0x05, 0x00, 0xAC, 0xFF, 0x00},
        {0x06, 0x00, 0x01, 0x00, 0x03},
        {0x08, 0x00, 0x00, 0x12, 0x34},
        {0x0F, 0x00, 0x13, 0x00, 0x0A},
        {0x10, 0x00, 0x01, 0x00, 0x02},
        {0x17, 0x02, 0x00, 0xFE},
        {0x2B, 0x0E, 0x01, 0x01, 0x00, 0x00, 0x01, 0x00, 0x03, 'A', 'B', 'C'},
        {0x83, 0x02},
    };
    bytes stream;
    for (const auto& p : pdus) {
        const auto f = rtu(0x11, p);
        stream.insert(stream.end(), f.begin(), f.end());
    }
    for (std::size_t chunk : {std::size_t{1}, std::size_t{3}, std::size_t{0}}) {
        rtu_decoder d;
        const auto r = feed_all(d, stream, chunk);
        CHECK(r.errors.empty());
        REQUIRE(r.frames.size() == pdus.size());
        for (std::size_t i = 0; i < pdus.size(); ++i) {
            bytes want{0x11};
            want.insert(want.end(), pdus[i].begin(), pdus[i].end());
            CHECK(r.frames[i] == want);
        }
        CHECK(d.skipped() == 0);
        CHECK_FALSE(d.in_frame());
    }
}

TEST_CASE("modbus rtu_decoder frames the other public function codes and a client decoder not",
          "[modbus][rtu]") {
    // FC 7 (read exception status) and FC 17 (report server id, byte count + data), then FC 3.
    const bytes fc7 = rtu(0x11, {0x07, 0x6D});
    const bytes fc17 = rtu(0x11, {0x11, 0x03, 'A', 'B', 'C'});
    const bytes fc3 = rtu(0x11, {0x03, 0x02, 0x00, 0x64});
    bytes stream = fc7;
    stream.insert(stream.end(), fc17.begin(), fc17.end());
    stream.insert(stream.end(), fc3.begin(), fc3.end());

    rtu_decoder tool;
    const auto all = feed_all(tool, stream);
    CHECK(all.errors.empty());
    CHECK(all.frames.size() == 3);

    // A client frames only the responses to the functions it can send: the others are bytes
    // that start no frame (or a false one, that fails its CRC), skipped until the FC 3
    // response, which is found at the latest when the line falls silent.
    using client_decoder = basic_rtu_decoder<all_functions, rtu_frames::responses>;
    client_decoder client;
    std::span<const std::uint8_t> in(stream);
    std::vector<bytes> frames;
    std::size_t errors = 0;
    const auto take = [&](const client_decoder::step& s) {
        if (s.what == client_decoder::status::error) {
            CHECK((s.ec == errc::malformed || s.ec == errc::bad_checksum));
            ++errors;
        }
        if (s.what == client_decoder::status::frame) {
            bytes f{client.address()};
            f.insert(f.end(), client.pdu().begin(), client.pdu().end());
            frames.push_back(f);
        }
    };
    client_decoder::step s;
    do {
        s = client.feed(in);
        in = in.subspan(s.consumed);
        take(s);
    } while (s.what != client_decoder::status::need_more);
    do {
        s = client.finish();
        take(s);
    } while (s.what != client_decoder::status::need_more);
    CHECK(errors >= 1);
    REQUIRE(frames.size() == 1);
    CHECK(frames[0] == bytes(fc3.begin(), fc3.end() - 2));
    CHECK(client.skipped() == fc7.size() + fc17.size());
}

TEST_CASE("modbus rtu_decoder frames requests of every function code", "[modbus][rtu]") {
    const std::vector<bytes> pdus{
        {0x01, 0x00, 0x13, 0x00, 0x25},
        {0x05, 0x00, 0xAC, 0xFF, 0x00},
        {0x08, 0x00, 0x00, 0x12, 0x34},
        {0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01},
        {0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02},
        {0x17, 0x00, 0x03, 0x00, 0x06, 0x00, 0x0E, 0x00, 0x01, 0x02, 0x00, 0xFF},
        {0x2B, 0x0E, 0x01, 0x00},
        {0x07},
        {0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25},
    };
    bytes stream;
    for (const auto& p : pdus) {
        const auto f = rtu(0x00, p); // broadcast address: the decoder does not filter
        stream.insert(stream.end(), f.begin(), f.end());
    }
    rtu_decoder d(rtu_decoder::accept::requests);
    const auto r = feed_all(d, stream, 1);
    CHECK(r.errors.empty());
    CHECK(r.frames.size() == pdus.size());
}

TEST_CASE("modbus rtu_decoder: a CRC error drops one byte and the next frame is found",
          "[modbus][rtu]") {
    auto bad = rtu(0x01, {0x03, 0x02, 0x12, 0x34});
    bad.back() ^= 0x01;
    const auto good = rtu(0x01, {0x06, 0x00, 0x01, 0x00, 0x03});
    bytes stream = bad;
    stream.insert(stream.end(), good.begin(), good.end());
    for (std::size_t chunk : {std::size_t{1}, std::size_t{0}}) {
        // Realigned on the byte after the broken frame's address, the decoder waits for a
        // longer frame; the silence after the good one ends the wait.
        rtu_decoder d;
        const auto r = feed_all(d, stream, chunk, true);
        REQUIRE_FALSE(r.errors.empty());
        CHECK(r.errors.front() == errc::bad_checksum);
        REQUIRE(r.frames.size() == 1);
        CHECK(r.frames[0] == bytes{0x01, 0x06, 0x00, 0x01, 0x00, 0x03});
        CHECK(d.skipped() == bad.size());
    }
}

TEST_CASE("modbus rtu_decoder skips garbage before a frame and reports the run once",
          "[modbus][rtu]") {
    const auto good = rtu(0x11, {0x03, 0x02, 0x00, 0x64});
    bytes stream{0x00, 0xFF, 0x80, 0x00}; // no function code 0x00 / 0x80 exists
    stream.insert(stream.end(), good.begin(), good.end());
    rtu_decoder d;
    const auto r = feed_all(d, stream);
    REQUIRE(r.frames.size() == 1);
    CHECK(r.frames[0] == bytes{0x11, 0x03, 0x02, 0x00, 0x64});
    CHECK(d.skipped() == 4);
    CHECK_FALSE(r.errors.empty());
}

TEST_CASE("modbus rtu_decoder: unknown function codes in requests are framed by the silence",
          "[modbus][rtu]") {
    const auto odd = rtu(0x05, {0x64, 0x01, 0x02, 0x03});
    rtu_decoder d(rtu_decoder::accept::requests);
    const auto r = feed_all(d, odd);
    CHECK(r.frames.empty());
    CHECK(d.in_frame());
    auto s = d.finish();
    REQUIRE(s.what == status::frame);
    CHECK(d.address() == 0x05);
    CHECK(d.pdu().size() == 4);
    CHECK(request_exception(d.pdu()) == 1);
    // A half frame at the silence is malformed and dropped.
    rtu_decoder h(rtu_decoder::accept::requests);
    const auto half = rtu(0x05, {0x03, 0x00, 0x00, 0x00, 0x01});
    (void)feed_all(h, bytes(half.begin(), half.begin() + 4));
    const auto e = feed_all(h, {}, 0, true);
    CHECK(e.frames.empty());
    CHECK(e.errors == std::vector<std::error_code>{errc::malformed});
    CHECK(h.skipped() == 4);
    CHECK_FALSE(h.in_frame());
    CHECK(h.finish().what == status::need_more);
    // In responses mode the unknown code is garbage right away.
    rtu_decoder resp;
    const auto g = feed_all(resp, odd);
    CHECK(g.frames.empty());
    CHECK_FALSE(g.errors.empty());
}

TEST_CASE("modbus rtu_decoder keeps at most 256 bytes of an unframed request", "[modbus][rtu]") {
    rtu_decoder d(rtu_decoder::accept::requests);
    const bytes junk(600, 0x64);
    const auto r = feed_all(d, junk, 7);
    CHECK(r.frames.empty());
    CHECK(d.skipped() == 600 - 255);
    CHECK(d.in_frame());
    d.reset();
    CHECK_FALSE(d.in_frame());
}

namespace {
// What an rtu_receiver hands its session; stops at the frame numbered `stop_at` (1-based).
struct recorded {
    std::vector<bytes> frames; // address + PDU
    std::vector<errc> dropped;
    std::size_t stop_at = 0;
    bool on_frame(std::uint8_t address, std::span<const std::uint8_t> pdu) {
        bytes f{address};
        f.insert(f.end(), pdu.begin(), pdu.end());
        frames.push_back(f);
        return frames.size() != stop_at;
    }
    void on_garbage(errc why) { dropped.push_back(why); }
};

template <class R>
recorded push_all(R& r, const bytes& in) {
    recorded out;
    for (const std::uint8_t b : in) r.push(b, out);
    return out;
}
} // namespace

TEST_CASE("modbus rtu_receiver: frames back to back, garbage and a CRC error between them",
          "[modbus][rtu]") {
    const auto first = rtu(0x11, {0x03, 0x02, 0x00, 0x64});
    auto broken = rtu(0x11, {0x06, 0x00, 0x01, 0x00, 0x03});
    broken.back() ^= 0x01;
    const auto second = rtu(0x12, {0x06, 0x00, 0x01, 0x00, 0x03});
    bytes stream = first;
    stream.insert(stream.end(), {0x00, 0x80}); // no function code 0x00 / 0x80 exists
    stream.insert(stream.end(), broken.begin(), broken.end());
    stream.insert(stream.end(), second.begin(), second.end());

    // Realigned on the byte after the broken frame's address, the receiver waits for a longer
    // frame; the silence after the good one ends the wait, as it does for rtu_decoder.
    rtu_receiver<rtu_frames::responses> r;
    auto got = push_all(r, stream);
    CHECK(got.frames.size() == 1);
    r.finish(got);
    REQUIRE(got.frames.size() == 2);
    CHECK(got.frames[0] == bytes{0x11, 0x03, 0x02, 0x00, 0x64});
    CHECK(got.frames[1] == bytes{0x12, 0x06, 0x00, 0x01, 0x00, 0x03});
    // The two bytes of garbage, then the broken frame's bytes one by one: the first of them
    // for its CRC.
    REQUIRE(got.dropped.size() >= 3);
    CHECK(got.dropped[0] == errc::malformed);
    CHECK(std::count(got.dropped.begin(), got.dropped.end(), errc::bad_checksum) >= 1);
    CHECK(r.empty());

    // A session that stops at the first frame (a client: its response) keeps it and the
    // bytes behind it until clear().
    rtu_receiver<rtu_frames::responses> s;
    recorded stop;
    stop.stop_at = 1;
    for (std::size_t i = 0; i < stream.size() && stop.frames.empty(); ++i) s.push(stream[i], stop);
    CHECK(stop.frames.size() == 1);
    CHECK_FALSE(s.empty());
    s.clear();
    CHECK(s.empty());
}

TEST_CASE("modbus rtu_receiver: a client's frames only its functions' responses", "[modbus][rtu]") {
    const auto read = rtu(0x01, {0x03, 0x02, 0x12, 0x34});
    const auto write = rtu(0x01, {0x06, 0x00, 0x01, 0x00, 0x03});
    const auto exception = rtu(0x01, {0x86, 0x02});
    rtu_receiver<rtu_frames::responses, functions<function::write_single_register>> r;
    bytes stream = read;
    stream.insert(stream.end(), write.begin(), write.end());
    stream.insert(stream.end(), exception.begin(), exception.end());
    const auto got = push_all(r, stream);
    REQUIRE(got.frames.size() == 2);
    CHECK(got.frames[0] == bytes{0x01, 0x06, 0x00, 0x01, 0x00, 0x03});
    CHECK(got.frames[1] == bytes{0x01, 0x86, 0x02});
    CHECK(got.dropped.size() >= read.size()); // FC 3 is not framed: its bytes are garbage
}

TEST_CASE("modbus rtu_receiver: requests of unknown function codes end at the silence",
          "[modbus][rtu]") {
    const auto odd = rtu(0x05, {0x64, 0x01, 0x02, 0x03});
    rtu_receiver<rtu_frames::requests> r;
    auto got = push_all(r, odd);
    CHECK(got.frames.empty());
    CHECK(got.dropped.empty());
    CHECK_FALSE(r.empty());
    r.finish(got);
    REQUIRE(got.frames.size() == 1);
    CHECK(got.frames[0] == bytes{0x05, 0x64, 0x01, 0x02, 0x03});
    CHECK(r.empty());

    // A half request at the silence is dropped byte by byte, as garbage.
    const auto half = rtu(0x05, {0x03, 0x00, 0x00, 0x00, 0x01});
    rtu_receiver<rtu_frames::requests> h;
    got = push_all(h, bytes(half.begin(), half.begin() + 4));
    h.finish(got);
    CHECK(got.frames.empty());
    CHECK(got.dropped == std::vector<errc>(4, errc::malformed));
    CHECK(h.empty());

    // A response receiver drops the unknown code at once.
    rtu_receiver<rtu_frames::responses> resp;
    got = push_all(resp, odd);
    CHECK(got.frames.empty());
    CHECK_FALSE(got.dropped.empty());

    // Bytes that fill an ADU and still form no request are dropped from the front.
    rtu_receiver<rtu_frames::requests> full;
    got = push_all(full, bytes(600, 0x64));
    CHECK(got.frames.empty());
    CHECK(got.dropped.size() == 600 - 255);
}
