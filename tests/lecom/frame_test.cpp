// LECOM telegrams and the stream decoder: the test vectors of lecom.md §4, the BCC that
// looks like a control character, every error form, and resynchronisation.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "ferrule/lecom/frame.hpp"

using namespace ferrule::lecom;
using ferrule::errc;
using bytes = std::vector<std::uint8_t>;
using accept = frame_decoder::accept;
using status = frame_decoder::status;

namespace {

bytes wire(const frame& f) {
    bytes out(max_frame_length);
    const auto n = encode(f, out);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

// Every telegram and error a decoder yields for `in`, fed in chunks of `chunk` bytes.
struct decoded {
    std::vector<bytes> frames;
    std::size_t errors = 0;
};
decoded decode(frame_decoder& d, const bytes& in, std::size_t chunk = 0) {
    decoded out;
    std::size_t pos = 0;
    while (pos < in.size()) {
        const std::size_t n = chunk == 0 ? in.size() - pos : std::min(chunk, in.size() - pos);
        std::span<const std::uint8_t> piece(in.data() + pos, n);
        while (!piece.empty()) {
            const auto s = d.feed(piece);
            REQUIRE(s.consumed <= piece.size());
            piece = piece.subspan(s.consumed);
            if (s.what == status::frame) {
                const auto f = d.frame();
                out.frames.emplace_back(f.begin(), f.end());
            } else if (s.what == status::error) {
                CHECK(s.ec == errc::malformed);
                ++out.errors;
            } else {
                REQUIRE(piece.empty());
            }
        }
        pos += n;
    }
    return out;
}
decoded decode(accept a, const bytes& in, std::size_t chunk = 0) {
    frame_decoder d(a);
    return decode(d, in, chunk);
}

bytes cat(std::initializer_list<bytes> parts) {
    bytes out;
    for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
    return out;
}

struct vector_case {
    const char* what;
    bytes raw;
    frame f;
};

value vd(const char* s) {
    return *parse_value(std::string_view(s));
}

// lecom.md §4.1 (from the manuals, BCCs derived) and §4.2 (derived).
std::vector<vector_case> golden() {
    return {
        {"1 read C46 @01", {0x04, 0x30, 0x31, 0x34, 0x36, 0x05}, read_request(1, code(46))},
        {"2 reply C46 = 35.4",
         {0x02, 0x34, 0x36, 0x33, 0x35, 0x2E, 0x34, 0x03, 0x1D},
         {frame_kind::data, 0, code(46), vd("35.4")}},
        {"3 reply C46 checksum fault",
         {0x02, 0x34, 0x36, 0x3F, 0x03, 0x3E},
         {frame_kind::fault, 0, code(46), {}}},
        {"4 reply C46 does not exist",
         {0x02, 0x34, 0x36, 0x04},
         {frame_kind::no_code, 0, code(46), {}}},
        {"5 read C68 @25", {0x04, 0x32, 0x35, 0x36, 0x38, 0x05}, read_request(25, code(68))},
        {"6 reply C68 = H0900",
         {0x02, 0x36, 0x38, 0x48, 0x30, 0x39, 0x30, 0x30, 0x03, 0x4C},
         {frame_kind::data, 0, code(68), *hex(0x0900)}},
        {"7 write C11 = 95.2 @34",
         {0x04, 0x33, 0x34, 0x02, 0x31, 0x31, 0x39, 0x35, 0x2E, 0x32, 0x03, 0x13},
         write_request(34, code(11), vd("95.2"))},
        {"7 ACK", {0x06}, {frame_kind::ack}},
        {"7 NAK", {0x15}, {frame_kind::nak}},
        {"8 broadcast C40 = 0 @00",
         {0x04, 0x30, 0x30, 0x02, 0x34, 0x30, 0x30, 0x03, 0x37},
         write_request(0, code(40), vd("0"))},
        {"11 motrona :1 @11 (code 101 by the 790 rule)",
         {0x04, 0x31, 0x31, 0x3A, 0x31, 0x05},
         read_request(11, code(101))},
        {"read C111 @01", {0x04, 0x30, 0x31, 0x3B, 0x31, 0x05}, read_request(1, code(111))},
        {"read C1002 @01 standard",
         {0x04, 0x30, 0x31, 0x45, 0x3C, 0x05},
         read_request(1, code(1002))},
        {"read C1002/0 @01 extended",
         {0x04, 0x30, 0x31, 0x21, 0x30, 0x33, 0x45, 0x41, 0x30, 0x30, 0x05},
         read_request(1, extended_code(1002, 0))},
        {"write C9 = 12 @01 (BCC 09)",
         {0x04, 0x30, 0x31, 0x02, 0x30, 0x39, 0x31, 0x32, 0x03, 0x09},
         write_request(1, code(9), vd("12"))},
        {"reply C111 = -12.5",
         {0x02, 0x3B, 0x31, 0x2D, 0x31, 0x32, 0x2E, 0x35, 0x03, 0x3C},
         {frame_kind::data, 0, code(111), vd("-12.5")}},
        {"reply C200 = S82EV123",
         {0x02, 0x44, 0x30, 0x53, 0x38, 0x32, 0x45, 0x56, 0x31, 0x32, 0x33, 0x03, 0x0D},
         {frame_kind::data, 0, code(200), *string("82EV123")}},
        {"bare EOT (4900)", {0x04}, {frame_kind::eot}},
    };
}

bool same(const frame& a, const frame& b) {
    return a.kind == b.kind && a.address == b.address && a.code == b.code &&
           (a.kind != frame_kind::send && a.kind != frame_kind::data ? true : a.value == b.value);
}

} // namespace

TEST_CASE("golden vectors of lecom.md 4 encode byte for byte", "[lecom][frame]") {
    for (const auto& v : golden()) {
        INFO(v.what);
        CHECK(wire(v.f) == v.raw);
    }
}

TEST_CASE("golden vectors of lecom.md 4 parse to their frames", "[lecom][frame]") {
    for (const auto& v : golden()) {
        INFO(v.what);
        const auto f = v.raw.size() == 1 ? parse_reply(v.raw) : parse_frame(v.raw);
        REQUIRE(f);
        CHECK(same(*f, v.f));
        CHECK(is_request(f->kind) == (v.raw[0] == eot && v.raw.size() > 1));
    }
}

TEST_CASE("golden vectors come out of the decoder whole, in one span or byte by byte",
          "[lecom][frame]") {
    for (const auto& v : golden()) {
        INFO(v.what);
        const bool request = v.raw[0] == eot && v.raw.size() > 1;
        const accept own = request ? accept::requests : accept::replies;
        for (const accept a : {own, accept::both}) {
            for (std::size_t chunk : {std::size_t{0}, std::size_t{1}}) {
                frame_decoder d(a);
                auto r = decode(d, v.raw, chunk);
                if (a == accept::both && v.raw == bytes{eot}) {
                    // A lone EOT waits for the next byte in both mode (see below).
                    CHECK(r.frames.empty());
                    const auto s = d.finish();
                    REQUIRE(s.what == status::frame);
                    r.frames.emplace_back(d.frame().begin(), d.frame().end());
                }
                CHECK(r.errors == 0);
                REQUIRE(r.frames.size() == 1);
                CHECK(r.frames[0] == v.raw);
            }
        }
    }
}

TEST_CASE("a BCC equal to a control character is the BCC", "[lecom][frame]") {
    // Find a data reply of C46 for each BCC: the decoder must take the one byte after ETX,
    // whatever it is (lecom.md §1.6), and frame the next telegram normally.
    for (const std::uint8_t target : {0x00, 0x02, 0x03, 0x04, 0x05, 0x06, 0x0A, 0x15}) {
        INFO("BCC " << int(target));
        bytes reply;
        for (std::int32_t n = 0; n < 100'000 && reply.empty(); ++n)
            for (const std::int32_t v : {n, -n}) {
                const bytes b = wire({frame_kind::data, 0, code(46), *decimal(v)});
                if (b.back() == target && reply.empty()) reply = b;
            }
        REQUIRE_FALSE(reply.empty());
        const auto f = parse_reply(reply);
        REQUIRE(f);
        CHECK(f->kind == frame_kind::data);
        const bytes next{ack};
        for (const accept a : {accept::replies, accept::both})
            for (std::size_t chunk : {std::size_t{0}, std::size_t{1}, std::size_t{3}}) {
                const auto r = decode(a, cat({reply, next}), chunk);
                CHECK(r.errors == 0);
                REQUIRE(r.frames.size() == 2);
                CHECK(r.frames[0] == reply);
                CHECK(r.frames[1] == next);
            }
        // The same BCC in a SEND, framed by a drive's decoder.
        bytes request;
        for (std::int32_t n = 0; n < 100'000 && request.empty(); ++n)
            for (const std::int32_t v : {n, -n}) {
                const bytes b = wire(write_request(1, code(46), *decimal(v)));
                if (b.back() == target && request.empty()) request = b;
            }
        REQUIRE_FALSE(request.empty());
        const bytes poll = wire(read_request(2, code(68)));
        for (const accept a : {accept::requests, accept::both}) {
            const auto r = decode(a, cat({request, poll}), 1);
            CHECK(r.errors == 0);
            REQUIRE(r.frames.size() == 2);
            CHECK(r.frames[0] == request);
            CHECK(r.frames[1] == poll);
        }
    }
}

TEST_CASE("every reply form of lecom.md 2 parses", "[lecom][frame]") {
    CHECK(parse_reply(bytes{ack})->kind == frame_kind::ack);
    CHECK(parse_reply(bytes{nak})->kind == frame_kind::nak);
    CHECK(parse_reply(bytes{eot})->kind == frame_kind::eot);
    const auto fault = parse_reply(wire({frame_kind::fault, 0, extended_code(1002, 3), {}}));
    REQUIRE(fault);
    CHECK(fault->kind == frame_kind::fault);
    CHECK(fault->code == extended_code(1002, 3));
    const bytes no_code_ext{0x02, '!', '0', '3', 'E', 'A', '0', '0', 0x04};
    CHECK(wire({frame_kind::no_code, 0, extended_code(1002, 0), {}}) == no_code_ext);
    const auto nc = parse_reply(no_code_ext);
    REQUIRE(nc);
    CHECK(nc->kind == frame_kind::no_code);
    CHECK(nc->code == extended_code(1002, 0));
    const auto r = decode(accept::replies, no_code_ext, 1);
    REQUIRE(r.frames.size() == 1);
    CHECK(r.frames[0] == no_code_ext);
}

TEST_CASE("parse errors: BCC, form, value", "[lecom][frame]") {
    bytes reply{0x02, 0x34, 0x36, 0x33, 0x35, 0x2E, 0x34, 0x03, 0x1D};
    reply.back() ^= 0x01;
    CHECK(parse_reply(reply).error() == errc::bad_checksum);
    const bytes bad_value{0x02, 0x34, 0x36, 0x33, 0x35, 0x2E, 0x03, 0x29}; // "35."
    CHECK(parse_reply(bad_value).error() == errc::malformed);
    const bytes control_in_text{0x02, 0x34, 0x36, 0x01, 0x03, 0x00};
    CHECK(parse_reply(control_in_text).error() == errc::malformed);
    CHECK(parse_reply(bytes{}).error() == errc::malformed);
    CHECK(parse_reply(bytes{0x41}).error() == errc::malformed);
    CHECK(parse_reply(bytes{0x02, 0x34, 0x04}).error() == errc::malformed); // one-char code
    CHECK(parse_request(bytes{0x04, 0x30, 0x31, 0x34, 0x05}).error() == errc::malformed);
    CHECK(parse_request(bytes{0x04, 0x30, 0x58, 0x34, 0x36, 0x05}).error() == errc::malformed);
    // `?` is no value of a SEND.
    CHECK(parse_request(bytes{0x04, 0x30, 0x31, 0x02, 0x34, 0x36, 0x3F, 0x03, 0x3E}).error() ==
          errc::malformed);
}

TEST_CASE("encode refuses what LECOM cannot express", "[lecom][frame]") {
    std::array<std::uint8_t, max_frame_length> out{};
    CHECK(encode(read_request(10, code(46)), out).error() == errc::invalid_argument);
    CHECK(encode(read_request(0, code(46)), out).error() == errc::invalid_argument);
    CHECK(encode(read_request(100, code(46)), out).error() == errc::invalid_argument);
    CHECK(encode(write_request(100, code(46), *decimal(1)), out).error() == errc::invalid_argument);
    CHECK(encode(read_request(1, code_address{6230, 0, false}), out).error() ==
          errc::invalid_argument);
    CHECK(encode(write_request(10, code(40), *decimal(0)), out)); // group SEND is fine
    CHECK(encode(read_request(1, code(46)), std::span(out).first(5)).error() ==
          errc::buffer_too_small);
}

TEST_CASE("encode_request writes a request in place, as encode() does", "[lecom][frame]") {
    const bytes read46{0x04, 0x30, 0x31, 0x34, 0x36, 0x05};
    const bytes write11{0x04, 0x33, 0x34, 0x02, 0x31, 0x31, 0x39, 0x35, 0x2E, 0x32, 0x03, 0x13};
    const value v95_2 = decimal_fixed(952'000);
    std::array<std::uint8_t, max_request_length> out{};
    auto written = [&out](std::size_t n) { return bytes(out.begin(), out.begin() + n); };

    CHECK(written(encode_request(1, code(46), nullptr, out.data())) == read46);
    CHECK(written(encode_request(34, code(11), &v95_2, out.data())) == write11);
    const frame requests[] = {read_request(99, extended_code(1002, 3)),
                              write_request(0, code(40), *decimal(0)), // a group SEND
                              write_request(10, code(6229), *string("82EV")),
                              write_request(1, extended_code(65535, 255), *hex(0xFFFFFFFF, 8))};
    for (const frame& f : requests) {
        const value* v = f.kind == frame_kind::send ? &f.value : nullptr;
        CHECK(is_valid_request(f.address, f.code, v));
        CHECK(written(encode_request(f.address, f.code, v, out.data())) == wire(f));
    }

    // What encode() refuses, encode_request() leaves unwritten and is_valid_request() denies.
    value bad_hex;
    bad_hex.format = value_format::hex;
    bad_hex.digits = 3;
    const frame refused[] = {read_request(10, code(46)),  // a group never answers
                             read_request(0, code(46)),   //
                             read_request(100, code(46)), // beyond 99
                             write_request(100, code(46), v95_2),
                             read_request(1, code_address{6230, 0, false}),
                             read_request(1, code_address{46, 1, false}), // standard: no subcode
                             write_request(1, code(46), bad_hex)};
    for (const frame& f : refused) {
        const value* v = f.kind == frame_kind::send ? &f.value : nullptr;
        out.fill(0xAA);
        CHECK_FALSE(is_valid_request(f.address, f.code, v));
        CHECK(encode_request(f.address, f.code, v, out.data()) == 0);
        CHECK(encode(f, out).error() == errc::invalid_argument);
    }
}

TEST_CASE("the decoder resynchronises after garbage", "[lecom][frame]") {
    const bytes reply{0x02, 0x34, 0x36, 0x33, 0x35, 0x2E, 0x34, 0x03, 0x1D};
    for (std::size_t chunk : {std::size_t{0}, std::size_t{1}, std::size_t{4}}) {
        frame_decoder d(accept::replies);
        const auto r = decode(d, cat({bytes{'x', 'y', 0xFF}, reply, bytes{'z'}, reply}), chunk);
        CHECK(r.errors == 2); // each run of garbage once
        REQUIRE(r.frames.size() == 2);
        CHECK(r.frames[0] == reply);
        CHECK(r.frames[1] == reply);
        CHECK(d.skipped() == 4);
    }
    // Requests mode skips replies: STX is no start there.
    const bytes poll{0x04, 0x30, 0x31, 0x34, 0x36, 0x05};
    const auto r = decode(accept::requests, cat({reply, poll}));
    CHECK(r.errors == 1);
    REQUIRE(r.frames.size() == 1);
    CHECK(r.frames[0] == poll);
}

TEST_CASE("a telegram cut by a control character gives way to the next", "[lecom][frame]") {
    const bytes reply{0x02, 0x34, 0x36, 0x33, 0x35, 0x2E, 0x34, 0x03, 0x1D};
    for (std::size_t chunk : {std::size_t{0}, std::size_t{1}}) {
        // STX 4 6 3 5 STX … : the second STX starts the telegram that counts.
        frame_decoder d(accept::replies);
        auto r = decode(d, cat({bytes{0x02, 0x34, 0x36, 0x33, 0x35}, reply}), chunk);
        CHECK(r.errors == 1);
        REQUIRE(r.frames.size() == 1);
        CHECK(r.frames[0] == reply);
        CHECK(d.skipped() == 5);
        // STX 4 6 ACK: the ACK is a telegram of its own.
        r = decode(accept::replies, bytes{0x02, 0x34, 0x36, ack}, chunk);
        CHECK(r.errors == 1);
        REQUIRE(r.frames.size() == 1);
        CHECK(r.frames[0] == bytes{ack});
        // A request cut by the next request's EOT.
        const bytes poll{0x04, 0x30, 0x31, 0x34, 0x36, 0x05};
        r = decode(accept::requests, cat({bytes{0x04, 0x30, 0x31, 0x34}, poll}), chunk);
        CHECK(r.errors == 1);
        REQUIRE(r.frames.size() == 1);
        CHECK(r.frames[0] == poll);
    }
}

TEST_CASE("requests mode checks both address digits", "[lecom][frame]") {
    // Found in review: in requests mode the decoder took any character as AD2.
    const bytes bad{0x04, 0x30, 0x58, 0x34, 0x36, 0x05};
    const bytes poll{0x04, 0x30, 0x31, 0x34, 0x36, 0x05};
    for (const accept a : {accept::requests, accept::both}) {
        const auto r = decode(a, cat({bad, poll}), 1);
        CHECK(r.errors == 1);
        REQUIRE(r.frames.size() == 1);
        CHECK(r.frames[0] == poll);
    }
}

TEST_CASE("overlong telegrams are dropped", "[lecom][frame]") {
    const bytes reply{0x02, 0x34, 0x36, 0x33, 0x35, 0x2E, 0x34, 0x03, 0x1D};
    bytes longer{0x02, 0x34, 0x36};
    longer.insert(longer.end(), 60, '1');
    longer.push_back(0x03);
    longer.push_back(0x00);
    for (std::size_t chunk : {std::size_t{0}, std::size_t{1}, std::size_t{7}}) {
        const auto r = decode(accept::replies, cat({longer, reply}), chunk);
        CHECK(r.errors == 1);
        REQUIRE(r.frames.size() == 1);
        CHECK(r.frames[0] == reply);
    }
    // The longest request that exists still fits.
    const auto o = octets(std::array<std::uint8_t, value::max_octets>{});
    const bytes longest = wire(write_request(99, extended_code(65535, 255), *o));
    CHECK(longest.size() == max_request_length);
    const auto r = decode(accept::requests, longest, 1);
    CHECK(r.errors == 0);
    REQUIRE(r.frames.size() == 1);
    CHECK(r.frames[0] == longest);
}

TEST_CASE("both mode: a lone EOT is decided by the next byte or by finish()", "[lecom][frame]") {
    frame_decoder d(accept::both);
    auto s = d.feed(bytes{eot});
    CHECK(s.what == status::need_more);
    CHECK(d.in_frame());
    s = d.finish();
    REQUIRE(s.what == status::frame);
    CHECK(d.frame().size() == 1);
    CHECK(d.frame()[0] == eot);
    CHECK_FALSE(d.in_frame());
    CHECK(d.finish().what == status::need_more); // nothing pending
    // EOT then ACK: two telegrams.
    const auto r = decode(accept::both, bytes{eot, ack});
    REQUIRE(r.frames.size() == 2);
    CHECK(r.frames[0] == bytes{eot});
    CHECK(r.frames[1] == bytes{ack});
    // EOT then digits: a request.
    const auto q = decode(accept::both, bytes{eot, 0x30, 0x31, 0x34, 0x36, 0x05});
    REQUIRE(q.frames.size() == 1);
    CHECK(q.frames[0].size() == 6);
    // An unfinished telegram at finish() is malformed.
    frame_decoder e(accept::replies);
    (void)e.feed(bytes{0x02, 0x34});
    CHECK(e.finish().what == status::error);
    CHECK(e.skipped() == 2);
    // In replies mode a lone EOT is the 4900's "no such code" at once.
    const auto p = decode(accept::replies, bytes{eot});
    REQUIRE(p.frames.size() == 1);
}

TEST_CASE("a RECEIVE that fills the buffer is cut before its ENQ", "[lecom][frame]") {
    // Found by fuzz_lecom_decoder: the ENQ was stored one byte past the buffer (into the
    // decoder's size), and a 47-byte "telegram" came out.
    bytes in{0x04, 0x30, 0x31};
    in.insert(in.end(), max_frame_length - 3, '#');
    in.push_back(enq);
    const bytes poll{0x04, 0x30, 0x31, 0x34, 0x36, 0x05};
    for (const accept a : {accept::requests, accept::both}) {
        frame_decoder d(a);
        const auto r = decode(d, cat({in, poll}), 1);
        CHECK(r.errors == 1);
        REQUIRE(r.frames.size() == 1);
        CHECK(r.frames[0] == poll);
        CHECK(d.skipped() == in.size());
    }
}
