// Extended MEMOBUS messages: the golden vectors of protocols/memobus.md §8.1 encode and
// decode exactly (V: the manual's, D: Yaskawa's sample program's, C: composed from the rules
// and cross-checked with HSL/FieldLink), error responses for a bad SFC, address and count,
// the limits, and the framing of a TCP stream.
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "ferrule/memobus/message.hpp"

using namespace ferrule::memobus;
using ferrule::errc;
using octets = std::vector<std::uint8_t>;

namespace {

octets command(const request& r, std::uint8_t serial, data_order o = data_order::big_endian) {
    octets out(max_message);
    const auto n = encode_command(r, serial, out, o);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

octets reply(const octets& cmd, const response& rsp, data_order o = data_order::big_endian) {
    const auto req = parse_request(std::span<const std::uint8_t>(cmd).subspan(header_size), o);
    REQUIRE(req);
    octets out(max_message);
    const auto n = encode_response(load_header(cmd.data()), *req, rsp, out, o);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

request make(sfc f, std::uint8_t cpu, std::uint16_t address, std::uint16_t count) {
    request r;
    r.function = f;
    r.cpu = cpu;
    r.address = address;
    r.count = count;
    return r;
}

std::span<const std::uint8_t> body(const octets& m) {
    return std::span<const std::uint8_t>(m).subspan(header_size);
}

} // namespace

TEST_CASE("memobus golden requests encode exactly", "[memobus]") {
    // #1b: the manual's SFC 03 example (ref 0x006B, 3 registers, CPU 0x12) in a 218 header
    CHECK(command(make(sfc::read_holding_registers, 0x12, 0x006B, 3), 0) ==
          octets{0x11, 0,    0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                 0,    0x07, 0x00, 0x20, 0x03, 0x12, 0x00, 0x6B, 0x00, 0x03});
    // #2: Yaskawa's sample, SFC 09 from the PC to CPU 1, MW00000 × 10
    CHECK(command(make(sfc::read_holding_registers_ext, default_cpu, 0, 10), 0) ==
          octets{0x11, 0,    0,    0,    0,    0,    0x16, 0,    0,    0,    0,
                 0,    0x08, 0x00, 0x20, 0x09, 0x10, 0x00, 0x00, 0x00, 0x0A, 0x00});
    // #3: SFC 09, CPU byte 0, MW00001 × 15
    CHECK(command(make(sfc::read_holding_registers_ext, 0x00, 1, 15), 0) ==
          octets{0x11, 0,    0,    0,    0,    0,    0x16, 0,    0,    0,    0,
                 0,    0x08, 0x00, 0x20, 0x09, 0x00, 0x00, 0x01, 0x00, 0x0F, 0x00});
    // #5: SFC 01 read coils 100 × 10 (HSL's CPU byte 0x21)
    CHECK(command(make(sfc::read_coils, 0x21, 100, 10), 0) ==
          octets{0x11, 0,    0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                 0,    0x07, 0x00, 0x20, 0x01, 0x21, 0x00, 0x64, 0x00, 0x0A});
    // #7: SFC 05 coil 100 on
    request coil = make(sfc::write_coil, 0x21, 100, 1);
    coil.value = coil_on;
    CHECK(command(coil, 2) == octets{0x11, 0x02, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                                     0,    0x07, 0x00, 0x20, 0x05, 0x21, 0x00, 0x64, 0xFF, 0x00});
    // #8: SFC 06 MW100 = 0x1234
    request one = make(sfc::write_holding_register, 0x21, 100, 1);
    one.value = 0x1234;
    CHECK(command(one, 3) == octets{0x11, 0x03, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                                    0,    0x07, 0x00, 0x20, 0x06, 0x21, 0x00, 0x64, 0x12, 0x34});
    // #9: SFC 08 loopback, the manual's data AA AA
    request loop = make(sfc::loopback, 0x21, 0x0000, 1);
    loop.value = 0xAAAA;
    CHECK(command(loop, 4) == octets{0x11, 0x04, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                                     0,    0x07, 0x00, 0x20, 0x08, 0x21, 0x00, 0x00, 0xAA, 0xAA});
    // #10: SFC 0F write 10 coils from 100, bits 05 02
    const std::array<std::uint8_t, 2> bits{0x05, 0x02};
    request coils = make(sfc::write_coils, 0x21, 100, 10);
    coils.bits = bits;
    CHECK(command(coils, 5) == octets{0x11, 0x05, 0,    0,    0,    0,    0x17, 0,
                                      0,    0,    0,    0,    0x09, 0x00, 0x20, 0x0F,
                                      0x21, 0x00, 0x64, 0x00, 0x0A, 0x05, 0x02});
    // #11: SFC 10 MW100..101 = 1234, ABCD (big-endian data, the default)
    const std::array<std::uint16_t, 2> words{0x1234, 0xABCD};
    request regs = make(sfc::write_holding_registers, 0x21, 100, 2);
    regs.words = words;
    CHECK(command(regs, 6) == octets{0x11, 0x06, 0,    0,    0,    0,    0x19, 0,    0,
                                     0,    0,    0,    0x0B, 0x00, 0x20, 0x10, 0x21, 0x00,
                                     0x64, 0x00, 0x02, 0x12, 0x34, 0xAB, 0xCD});
    // #12: SFC 0B, the same registers: spare byte, everything little-endian
    request ext = make(sfc::write_holding_registers_ext, 0x21, 100, 2);
    ext.words = words;
    CHECK(command(ext, 7) == octets{0x11, 0x07, 0,    0,    0,    0,    0x1A, 0,    0,
                                    0,    0,    0,    0x0C, 0x00, 0x20, 0x0B, 0x21, 0x00,
                                    0x64, 0x00, 0x02, 0x00, 0x34, 0x12, 0xCD, 0xAB});
    // #13: SFC 0D read MW10 and MW20
    const std::array<std::uint16_t, 2> addresses{10, 20};
    request random = make(sfc::read_holding_registers_random, 0x21, 0, 2);
    random.words = addresses;
    CHECK(command(random, 8) == octets{0x11, 0x08, 0,    0,    0,    0,    0x18, 0,
                                       0,    0,    0,    0,    0x0A, 0x00, 0x20, 0x0D,
                                       0x21, 0x00, 0x02, 0x00, 0x0A, 0x00, 0x14, 0x00});
    // #15: SFC 0A read IW0 × 1
    CHECK(command(make(sfc::read_input_registers_ext, 0x21, 0, 1), 0x0A) ==
          octets{0x11, 0x0A, 0,    0,    0,    0,    0x16, 0,    0,    0,    0,
                 0,    0x08, 0x00, 0x20, 0x0A, 0x21, 0x00, 0x00, 0x00, 0x01, 0x00});
}

TEST_CASE("memobus golden responses encode from the request and parse back", "[memobus]") {
    // #5r: coils 0, 2 and 9 on
    const auto coils_cmd = command(make(sfc::read_coils, 0x21, 100, 10), 0);
    const std::array<std::uint8_t, 2> packed{0x05, 0x02};
    response bits;
    bits.bits = packed;
    const auto r5 = reply(coils_cmd, bits);
    CHECK(r5 == octets{0x19, 0, 0, 0, 0, 0, 0x13, 0, 0, 0, 0, 0, 0x05, 0x00, 0x20, 0x01, 0x12, 0x05,
                       0x02});
    const auto p5 = parse_response(make(sfc::read_coils, 0x21, 100, 10), body(r5));
    REQUIRE(p5);
    CHECK(p5->cpu == 0x12);
    CHECK(octets(p5->raw.begin(), p5->raw.end()) == octets{0x05, 0x02});
    // #6r: MW100, MW101 = 0x1234, 0xABCD, big-endian
    const request read2 = make(sfc::read_holding_registers, 0x21, 100, 2);
    const std::array<std::uint16_t, 2> values{0x1234, 0xABCD};
    response regs;
    regs.words = values;
    const auto r6 = reply(command(read2, 1), regs);
    CHECK(r6 == octets{0x19, 0x01, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                       0,    0x07, 0x00, 0x20, 0x03, 0x12, 0x12, 0x34, 0xAB, 0xCD});
    const auto p6 = parse_response(read2, body(r6));
    REQUIRE(p6);
    CHECK(word_at(p6->function, p6->raw, 0) == 0x1234);
    CHECK(word_at(p6->function, p6->raw, 1) == 0xABCD);
    // The same read with little-endian data (the uncertain order, §11.1)
    const auto r6le = reply(command(read2, 1), regs, data_order::little_endian);
    CHECK(octets(r6le.end() - 4, r6le.end()) == octets{0x34, 0x12, 0xCD, 0xAB});
    const auto p6le = parse_response(read2, body(r6le), data_order::little_endian);
    CHECK(word_at(p6le->function, p6le->raw, 0, data_order::little_endian) == 0x1234);
    // #10r, #11r: 0F and 10 echo address and count
    const std::array<std::uint8_t, 2> b{0x05, 0x02};
    request wc = make(sfc::write_coils, 0x21, 100, 10);
    wc.bits = b;
    CHECK(reply(command(wc, 5), {}) == octets{0x19, 0x05, 0,    0,    0,    0,    0x15,
                                              0,    0,    0,    0,    0,    0x07, 0x00,
                                              0x20, 0x0F, 0x12, 0x00, 0x64, 0x00, 0x0A});
    request wr = make(sfc::write_holding_registers, 0x21, 100, 2);
    wr.words = values;
    const auto r11 = reply(command(wr, 6), {});
    CHECK(r11 == octets{0x19, 0x06, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                        0,    0x07, 0x00, 0x20, 0x10, 0x12, 0x00, 0x64, 0x00, 0x02});
    CHECK(parse_response(wr, body(r11)));
    // #12r: 0B echoes spare, address, count
    request wx = make(sfc::write_holding_registers_ext, 0x21, 100, 2);
    wx.words = values;
    const auto r12 = reply(command(wx, 7), {});
    CHECK(r12 == octets{0x19, 0x07, 0,    0,    0,    0,    0x16, 0,    0,    0,    0,
                        0,    0x08, 0x00, 0x20, 0x0B, 0x12, 0x00, 0x64, 0x00, 0x02, 0x00});
    CHECK(parse_response(wx, body(r12)));
    // #14r: 0E answers spare and count
    const std::array<std::uint16_t, 4> pairs{10, 0x1111, 20, 0x2222};
    request we = make(sfc::write_holding_registers_random, 0x21, 0, 2);
    we.words = pairs;
    octets cmd14 = command(we, 9);
    CHECK(reply(cmd14, {}) == octets{0x19, 0x09, 0,    0,    0,    0,    0x14, 0,    0,    0,
                                     0,    0,    0x06, 0x00, 0x20, 0x0E, 0x12, 0x00, 0x02, 0x00});
    // 09: spare, count, little-endian data
    const request ext = make(sfc::read_holding_registers_ext, default_cpu, 0, 2);
    const auto r9 = reply(command(ext, 0), regs);
    CHECK(octets(r9.begin() + 12, r9.end()) ==
          octets{0x0A, 0x00, 0x20, 0x09, 0x01, 0x00, 0x02, 0x00, 0x34, 0x12, 0xCD, 0xAB});
    const auto p9 = parse_response(ext, body(r9));
    REQUIRE(p9);
    CHECK(word_at(p9->function, p9->raw, 1) == 0xABCD);
}

TEST_CASE("memobus error responses: bad SFC, address and count", "[memobus]") {
    // #16: SFC 09, reference address error, CPU 0x01 (the request's 0x10 swapped)
    const request ext = make(sfc::read_holding_registers_ext, default_cpu, 0, 10);
    const auto cmd = command(ext, 0);
    octets out(max_message);
    const auto n = encode_error(load_header(cmd.data()), static_cast<std::uint8_t>(ext.function),
                                ext.cpu, device_errc::address_error, out);
    REQUIRE(n);
    out.resize(*n);
    CHECK(out ==
          octets{0x19, 0, 0, 0, 0, 0, 0x12, 0, 0, 0, 0, 0, 0x04, 0x00, 0x20, 0x89, 0x01, 0x02});
    CHECK(parse_response(ext, body(out)).error() == device_errc::address_error);
    CHECK(std::error_code(parse_response(ext, body(out)).error()).message() ==
          "controller: reference address error");

    // What a controller answers with, from parse_request():
    auto raw = [](std::initializer_list<std::uint8_t> b) { return octets(b); };
    // an unknown SFC: 01
    CHECK(parse_request(raw({0x07, 0x00, 0x20, 0x07, 0x10, 0x00, 0x00, 0x00, 0x01})).error() ==
          device_errc::sfc_error);
    // another MFC: 01
    CHECK(parse_request(raw({0x07, 0x00, 0x21, 0x03, 0x10, 0x00, 0x00, 0x00, 0x01})).error() ==
          device_errc::sfc_error);
    // SFC 03 of 126 registers, SFC 09 of 2045: 03
    CHECK(parse_request(raw({0x07, 0x00, 0x20, 0x03, 0x10, 0x00, 0x00, 0x00, 0x7E})).error() ==
          device_errc::count_error);
    CHECK(
        parse_request(raw({0x08, 0x00, 0x20, 0x09, 0x10, 0x00, 0x00, 0x00, 0xFD, 0x07})).error() ==
        device_errc::count_error);
    // SFC 09 from 0xFFFF × 2: beyond the address range, 02
    CHECK(
        parse_request(raw({0x08, 0x00, 0x20, 0x09, 0x10, 0x00, 0xFF, 0xFF, 0x02, 0x00})).error() ==
        device_errc::address_error);
    // SFC 10 whose data is shorter than its count: 03
    CHECK(parse_request(raw({0x09, 0x00, 0x20, 0x10, 0x10, 0x00, 0x64, 0x00, 0x02, 0x12, 0x34}))
              .error() == device_errc::count_error);
    // The client refuses to send what the limits do not allow.
    CHECK(encode_command(make(sfc::read_holding_registers, default_cpu, 0, 126), 0, out).error() ==
          errc::invalid_argument);
    CHECK(encode_command(make(sfc::write_holding_registers_random, default_cpu, 0, 1023), 0, out)
              .error() == errc::invalid_argument);
}

TEST_CASE("memobus parse_request reads every SFC back", "[memobus]") {
    const std::array<std::uint16_t, 2> values{0x1234, 0xABCD};
    request wr = make(sfc::write_holding_registers, 0x21, 100, 2);
    wr.words = values;
    const auto m = command(wr, 6);
    const auto r = parse_request(body(m));
    REQUIRE(r);
    CHECK(r->function == sfc::write_holding_registers);
    CHECK(r->cpu == 0x21);
    CHECK(r->address == 100);
    CHECK(r->count == 2);
    CHECK(word_at(r->function, r->raw, 1) == 0xABCD);
    request wx = make(sfc::write_holding_registers_ext, 0x21, 100, 2);
    wx.words = values;
    const auto mx = command(wx, 7);
    const auto rx = parse_request(body(mx));
    REQUIRE(rx);
    CHECK(rx->address == 100);
    CHECK(word_at(rx->function, rx->raw, 0) == 0x1234);
    request one = make(sfc::write_holding_register, 0x21, 100, 1);
    one.value = 0x1234;
    const auto m6le = command(one, 3, data_order::little_endian);
    CHECK(octets(m6le.end() - 2, m6le.end()) == octets{0x34, 0x12});
    CHECK(parse_request(body(m6le), data_order::little_endian)->value == 0x1234);
}

TEST_CASE("memobus message_decoder frames a TCP stream and resynchronises", "[memobus]") {
    const auto a = command(make(sfc::read_holding_registers_ext, default_cpu, 0, 10), 0);
    const auto b = command(make(sfc::read_holding_registers, 0x12, 0x006B, 3), 1);
    octets stream{0x00, 0x55}; // garbage
    stream.insert(stream.end(), a.begin(), a.end());
    // A header with a total of 65535: no message, dropped
    const octets bogus{0x11, 0x00, 0, 0, 0, 0, 0xFF, 0xFF, 0, 0, 0, 0};
    stream.insert(stream.end(), bogus.begin(), bogus.end());
    stream.insert(stream.end(), b.begin(), b.end());
    for (const std::size_t chunk : {std::size_t{1}, std::size_t{5}, stream.size()}) {
        message_decoder d;
        std::vector<octets> got;
        std::size_t errors = 0;
        std::span<const std::uint8_t> rest(stream);
        while (!rest.empty()) {
            auto piece = rest.first(std::min(chunk, rest.size()));
            rest = rest.subspan(piece.size());
            message_decoder::step s;
            do {
                s = d.feed(piece);
                piece = piece.subspan(s.consumed);
                if (s.what == message_decoder::status::error) ++errors;
                if (s.what == message_decoder::status::frame)
                    got.emplace_back(d.message().begin(), d.message().end());
            } while (s.what != message_decoder::status::need_more);
        }
        REQUIRE(got.size() == 2);
        CHECK(got[0] == a);
        CHECK(got[1] == b);
        CHECK(errors >= 2);
    }
    // One UDP datagram, one message: its length must be the datagram's.
    CHECK(parse_message(a)->serial == 0);
    octets longer = a;
    longer.push_back(0);
    CHECK(parse_message(longer).error() == errc::malformed);
    octets wrong_length = a;
    wrong_length[12] = 0x09; // MEMOBUS length 9, total says 8
    CHECK(parse_message(wrong_length).error() == errc::malformed);
}

TEST_CASE("memobus message_decoder drops a header whose lengths disagree at once", "[memobus]") {
    // Total 4000 but a MEMOBUS length of 7: dropped at byte 14, not after 4000 bytes.
    const octets liar{0x11, 0x00, 0, 0, 0, 0, 0xA0, 0x0F, 0, 0, 0, 0, 0x07, 0x00};
    const auto good = command(make(sfc::read_holding_registers_ext, default_cpu, 0, 10), 0);
    octets stream = liar;
    stream.insert(stream.end(), good.begin(), good.end());
    message_decoder d;
    std::span<const std::uint8_t> rest(stream);
    std::vector<octets> got;
    message_decoder::step s;
    do {
        s = d.feed(rest);
        rest = rest.subspan(s.consumed);
        if (s.what == message_decoder::status::frame)
            got.emplace_back(d.message().begin(), d.message().end());
    } while (s.what != message_decoder::status::need_more);
    REQUIRE(got.size() == 1);
    CHECK(got[0] == good);
    CHECK(d.skipped() == liar.size());
}
