// memobus::server, one channel of the controller's side: the golden responses of
// protocols/memobus.md §8.1, every SFC against a register_image, the PARAM08…11 offsets, the
// write range, error responses 01 / 02 / 03, and the messages that get no answer.
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/register_image.hpp"
#include "ferrule/memobus/server.hpp"

using namespace ferrule::memobus;
using octets = std::vector<std::uint8_t>;
using image_type = register_image<1024, 256>;

namespace {

octets run(server& s, image_type& image, const octets& message) {
    octets out(max_message);
    out.resize(s.handle(message, image, out));
    return out;
}

request make(sfc f, std::uint16_t address, std::uint16_t count, std::uint8_t cpu = 0x21) {
    request r;
    r.function = f;
    r.cpu = cpu;
    r.address = address;
    r.count = count;
    return r;
}

octets command(const request& r, std::uint8_t serial = 0, data_order o = data_order::big_endian) {
    octets out(max_message);
    const auto n = encode_command(r, serial, out, o);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

// The reply to `r`, checked against it the way a master does (type, serial, parse_response).
response transact(server& s, image_type& image, const request& r, std::uint8_t serial = 7,
                  data_order o = data_order::big_endian) {
    static octets reply; // the response's raw data points into it
    reply = run(s, image, command(r, serial, o));
    REQUIRE(reply.size() >= header_size + length_size);
    REQUIRE(parse_message(reply));
    CHECK(reply[0] == 0x19);
    CHECK(reply[1] == serial);
    const auto rsp =
        parse_response(r, std::span<const std::uint8_t>(reply).subspan(header_size), o);
    REQUIRE(rsp);
    CHECK(rsp->cpu == swap_nibbles(r.cpu));
    return *rsp;
}

// The error code of the reply to `r`, 0 for a normal response.
int error_of(server& s, image_type& image, const request& r) {
    const octets reply = run(s, image, command(r));
    REQUIRE(reply.size() >= header_size + length_size + 3);
    if (reply.size() != 18 || (reply[15] & error_flag) == 0) return 0;
    CHECK(reply[15] == (static_cast<std::uint8_t>(r.function) | error_flag));
    return reply[17];
}

} // namespace

TEST_CASE("memobus server: golden responses", "[memobus]") {
    image_type image;
    server s;
    SECTION("5r: SFC 01 read coils 100 x 10, coils 0, 2, 9 on") {
        image.set_mb(100, true);
        image.set_mb(102, true);
        image.set_mb(109, true);
        CHECK(run(s, image, {0x11, 0x00, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                             0,    0x07, 0x00, 0x20, 0x01, 0x21, 0x00, 0x64, 0x00, 0x0A}) ==
              octets{0x19, 0x00, 0, 0, 0, 0, 0x13, 0, 0, 0, 0, 0, 0x05, 0x00, 0x20, 0x01, 0x12,
                     0x05, 0x02});
    }
    SECTION("6r: SFC 03 read MW100 x 2") {
        image.set_mw(100, 0x1234);
        image.set_mw(101, 0xABCD);
        CHECK(run(s, image, {0x11, 0x01, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                             0,    0x07, 0x00, 0x20, 0x03, 0x21, 0x00, 0x64, 0x00, 0x02}) ==
              octets{0x19, 0x01, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                     0,    0x07, 0x00, 0x20, 0x03, 0x12, 0x12, 0x34, 0xAB, 0xCD});
    }
    SECTION("10r: SFC 0F write 10 coils from 100") {
        CHECK(run(s, image, {0x11, 0x05, 0,    0,    0,    0,    0x17, 0,    0,    0,    0,   0,
                             0x09, 0x00, 0x20, 0x0F, 0x21, 0x00, 0x64, 0x00, 0x0A, 0x05, 0x02}) ==
              octets{0x19, 0x05, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                     0,    0x07, 0x00, 0x20, 0x0F, 0x12, 0x00, 0x64, 0x00, 0x0A});
        // coils 100, 102, 109: MW6 bits 4, 6 and 13
        CHECK(image.mw(6) == (1u << 4 | 1u << 6 | 1u << 13));
    }
    SECTION("11r: SFC 10 write MW100..101") {
        CHECK(run(s, image,
                  {0x11, 0x06, 0,    0,    0,    0,    0x19, 0,    0,    0,    0,    0,   0x0B,
                   0x00, 0x20, 0x10, 0x21, 0x00, 0x64, 0x00, 0x02, 0x12, 0x34, 0xAB, 0xCD}) ==
              octets{0x19, 0x06, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                     0,    0x07, 0x00, 0x20, 0x10, 0x12, 0x00, 0x64, 0x00, 0x02});
        CHECK(image.mw(100) == 0x1234);
        CHECK(image.mw(101) == 0xABCD);
    }
    SECTION("12r: SFC 0B write MW100..101 (LE)") {
        CHECK(run(s, image,
                  {0x11, 0x07, 0,    0,    0,    0,    0x1A, 0,    0,    0,    0,    0,    0x0C,
                   0x00, 0x20, 0x0B, 0x21, 0x00, 0x64, 0x00, 0x02, 0x00, 0x34, 0x12, 0xCD, 0xAB}) ==
              octets{0x19, 0x07, 0,    0,    0,    0,    0x16, 0,    0,    0,    0,
                     0,    0x08, 0x00, 0x20, 0x0B, 0x12, 0x00, 0x64, 0x00, 0x02, 0x00});
        CHECK(image.mw(100) == 0x1234);
        CHECK(image.mw(101) == 0xABCD);
    }
    SECTION("14r: SFC 0E write MW10 = 1234, MW20 = ABCD") {
        CHECK(run(s, image, {0x11, 0x09, 0,    0,    0,    0,    0x1C, 0,    0,    0,
                             0,    0,    0x0E, 0x00, 0x20, 0x0E, 0x21, 0x00, 0x02, 0x00,
                             0x0A, 0x00, 0x34, 0x12, 0x14, 0x00, 0xCD, 0xAB}) ==
              octets{0x19, 0x09, 0,    0,    0,    0,    0x14, 0,    0,    0,
                     0,    0,    0x06, 0x00, 0x20, 0x0E, 0x12, 0x00, 0x02, 0x00});
        CHECK(image.mw(10) == 0x1234);
        CHECK(image.mw(20) == 0xABCD);
    }
    SECTION("16: SFC 09 reference address error, CPU 0x10") {
        // MW1020 x 10 runs past MW1023, the image's last
        CHECK(run(s, image, {0x11, 0x00, 0,    0,    0,    0,    0x16, 0,    0,    0,    0,
                             0,    0x08, 0x00, 0x20, 0x09, 0x10, 0x00, 0xFC, 0x03, 0x0A, 0x00}) ==
              octets{0x19, 0x00, 0, 0, 0, 0, 0x12, 0, 0, 0, 0, 0, 0x04, 0x00, 0x20, 0x89, 0x01,
                     0x02});
        CHECK(s.stats().address_errors == 1);
    }
}

TEST_CASE("memobus server: every SFC against the register image", "[memobus]") {
    image_type image;
    server s;
    for (std::size_t i = 0; i < image.mw_size; ++i) image.set_mw(i, static_cast<std::uint16_t>(i));
    for (std::size_t i = 0; i < image.iw_size; ++i)
        image.set_iw(i, static_cast<std::uint16_t>(0x8000 + i));

    SECTION("01 and 02 read MB and IB, the bits of MW and IW") {
        image.set_mw(3, 0x0005); // MB00030, MB00032
        auto r = transact(s, image, make(sfc::read_coils, 48, 16));
        CHECK(r.raw.size() == 2);
        CHECK(r.raw[0] == 0x05);
        CHECK(r.raw[1] == 0x00);
        image.set_ib(17, true); // IW1 = 0x8001 | 0x0002
        r = transact(s, image, make(sfc::read_input_relays, 16, 3));
        CHECK(r.raw.size() == 1);
        CHECK(r.raw[0] == 0x03);
    }
    SECTION("03 04 09 0A read MW and IW") {
        auto r = transact(s, image, make(sfc::read_holding_registers, 200, 125));
        CHECK(word_at(r.function, r.raw, 124) == 324);
        r = transact(s, image, make(sfc::read_input_registers, 255, 1));
        CHECK(word_at(r.function, r.raw, 0) == 0x80FF);
        r = transact(s, image, make(sfc::read_holding_registers_ext, 0, 1024));
        CHECK(word_at(r.function, r.raw, 1023) == 1023);
        r = transact(s, image, make(sfc::read_input_registers_ext, 10, 2));
        CHECK(word_at(r.function, r.raw, 1) == 0x800B);
    }
    SECTION("05 0F write MB") {
        auto q = make(sfc::write_coil, 36, 1); // MW2 bit 4
        q.value = coil_on;
        transact(s, image, q);
        CHECK(image.mw(2) == 0x0012);
        q.value = 0;
        transact(s, image, q);
        CHECK(image.mw(2) == 0x0002);
        const std::array<std::uint8_t, 2> bits{0xFF, 0x01};
        q = make(sfc::write_coils, 160, 9); // MW10 = 10 -> 0x01FF | 10
        q.bits = bits;
        transact(s, image, q);
        CHECK(image.mw(10) == 0x01FF);
    }
    SECTION("06 10 0B 0E write MW") {
        auto q = make(sfc::write_holding_register, 500, 1);
        q.value = 0xBEEF;
        transact(s, image, q);
        CHECK(image.mw(500) == 0xBEEF);
        const std::array<std::uint16_t, 3> v{1, 2, 3};
        q = make(sfc::write_holding_registers, 600, 3);
        q.words = v;
        transact(s, image, q);
        CHECK(image.mw(602) == 3);
        q = make(sfc::write_holding_registers_ext, 1021, 3);
        q.words = v;
        transact(s, image, q);
        CHECK(image.mw(1023) == 3);
        const std::array<std::uint16_t, 4> pairs{700, 0x1111, 5, 0x2222};
        q = make(sfc::write_holding_registers_random, 0, 2);
        q.words = pairs;
        transact(s, image, q);
        CHECK(image.mw(700) == 0x1111);
        CHECK(image.mw(5) == 0x2222);
    }
    SECTION("0D reads MW here and there") {
        const std::array<std::uint16_t, 3> at{1023, 0, 512};
        auto q = make(sfc::read_holding_registers_random, 0, 3);
        q.words = at;
        const auto r = transact(s, image, q);
        CHECK(word_at(r.function, r.raw, 0) == 1023);
        CHECK(word_at(r.function, r.raw, 1) == 0);
        CHECK(word_at(r.function, r.raw, 2) == 512);
    }
    SECTION("08 loopback echoes") {
        auto q = make(sfc::loopback, 0, 1);
        q.value = 0xAAAA;
        CHECK(transact(s, image, q).value == 0xAAAA);
    }
    CHECK(s.stats().requests == s.stats().responses);
    CHECK(s.stats().bytes_in > 0);
    CHECK(s.stats().bytes_out > 0);
}

TEST_CASE("memobus server: little-endian data order for the MEMOBUS-compatible SFCs", "[memobus]") {
    image_type image;
    channel_config c;
    c.order = data_order::little_endian;
    server s(c);
    image.set_mw(100, 0x1234);
    CHECK(run(s, image, command(make(sfc::read_holding_registers, 100, 1))) ==
          octets{0x19, 0x00, 0, 0, 0, 0, 0x13, 0, 0, 0, 0, 0, 0x05, 0x00, 0x20, 0x03, 0x12, 0x34,
                 0x12});
    auto q = make(sfc::write_holding_register, 101, 1);
    q.value = 0xABCD;
    transact(s, image, q, 1, data_order::little_endian);
    CHECK(image.mw(101) == 0xABCD);
}

TEST_CASE("memobus server: the reply swaps the channel bytes and echoes the serial", "[memobus]") {
    image_type image;
    server s;
    octets cmd(max_message);
    const auto n = encode_command(make(sfc::read_holding_registers_ext, 0, 1, 0x10), 0xFE, cmd,
                                  data_order::big_endian, 3, 5);
    REQUIRE(n);
    cmd.resize(*n);
    const octets reply = run(s, image, cmd);
    REQUIRE(reply.size() == 22);
    CHECK(reply[1] == 0xFE);
    CHECK(reply[2] == 5);
    CHECK(reply[3] == 3);
    CHECK(reply[16] == 0x01);
}

TEST_CASE("memobus server: PARAM08-11 offsets move each area", "[memobus]") {
    image_type image;
    channel_config c;
    c.mw_offset = 1000;
    c.iw_offset = 200;
    c.mb_offset = 500; // coil 0 = MB05000 = MW500 bit 0
    c.ib_offset = 100;
    server s(c);
    image.set_mw(1000, 0x4242);
    image.set_iw(201, 0x0707);
    image.set_iw(100, 0x0001);

    auto r = transact(s, image, make(sfc::read_holding_registers_ext, 0, 1));
    CHECK(word_at(r.function, r.raw, 0) == 0x4242);
    r = transact(s, image, make(sfc::read_input_registers, 1, 1));
    CHECK(word_at(r.function, r.raw, 0) == 0x0707);
    r = transact(s, image, make(sfc::read_input_relays, 0, 1));
    CHECK(r.raw[0] == 1);
    auto q = make(sfc::write_coil, 17, 1);
    q.value = coil_on;
    transact(s, image, q);
    CHECK(image.mw(501) == 0x0002);
    const std::array<std::uint16_t, 2> pairs{23, 0x5555};
    q = make(sfc::write_holding_registers_random, 0, 1);
    q.words = pairs;
    transact(s, image, q);
    CHECK(image.mw(1023) == 0x5555);
    const std::array<std::uint16_t, 1> at{23};
    q = make(sfc::read_holding_registers_random, 0, 1);
    q.words = at;
    r = transact(s, image, q);
    CHECK(word_at(r.function, r.raw, 0) == 0x5555);

    // MW1000 + 24 is beyond the image: address error
    CHECK(error_of(s, image, make(sfc::read_holding_registers_ext, 24, 1)) == 2);
    CHECK(error_of(s, image, make(sfc::read_holding_registers, 20, 5)) == 2);
    CHECK(error_of(s, image, make(sfc::read_input_registers_ext, 56, 1)) == 2);
    CHECK(error_of(s, image, make(sfc::read_coils, 16 * 524, 1)) == 2);
}

TEST_CASE("memobus server: writes outside the write range get error 03 and write nothing",
          "[memobus]") {
    image_type image;
    channel_config c;
    c.write_low = 100;
    c.write_high = 199;
    server s(c);
    const std::array<std::uint16_t, 10> ten{1, 2, 3, 4, 5, 6, 7, 8, 9, 10};

    auto q = make(sfc::write_holding_registers_ext, 95, 10);
    q.words = ten;
    CHECK(error_of(s, image, q) == 3);
    q.address = 195;
    CHECK(error_of(s, image, q) == 3);
    q.address = 190;
    CHECK(error_of(s, image, q) == 0);
    CHECK(image.mw(199) == 10);

    q = make(sfc::write_holding_register, 200, 1);
    q.value = 1;
    CHECK(error_of(s, image, q) == 3);
    q.address = 100;
    CHECK(error_of(s, image, q) == 0);

    q = make(sfc::write_holding_registers, 99, 2);
    q.words = std::span<const std::uint16_t>(ten).first(2);
    CHECK(error_of(s, image, q) == 3);

    const std::array<std::uint16_t, 4> pairs{150, 1, 250, 2};
    q = make(sfc::write_holding_registers_random, 0, 2);
    q.words = pairs;
    CHECK(error_of(s, image, q) == 3);
    CHECK(image.mw(150) == 0); // nothing of a refused request is written

    // Coils by the MW word that holds them: coil 1615 is MW100 bit 15, coil 3200 MW200 bit 0.
    q = make(sfc::write_coil, 1615, 1);
    q.value = coil_on;
    CHECK(error_of(s, image, q) == 0);
    q.address = 3200;
    CHECK(error_of(s, image, q) == 3);
    const std::array<std::uint8_t, 1> bits{0xFF};
    q = make(sfc::write_coils, 1596, 8); // MW99 bits 12…15, MW100 bits 0…3
    q.bits = bits;
    CHECK(error_of(s, image, q) == 3);
    CHECK(image.mw(100) == 0x8001);

    // Reads are not limited by it.
    CHECK(error_of(s, image, make(sfc::read_holding_registers_ext, 0, 1024)) == 0);
    CHECK(s.stats().count_errors == 7);
}

TEST_CASE("memobus server: error responses 01, 02 and 03", "[memobus]") {
    image_type image;
    server s;
    SECTION("01: an unknown SFC or MFC") {
        octets m = command(make(sfc::read_holding_registers_ext, 0, 1));
        m[15] = 0x07;
        auto reply = run(s, image, m);
        CHECK(reply ==
              octets{0x19, 0, 0, 0, 0, 0, 0x12, 0, 0, 0, 0, 0, 0x04, 0x00, 0x20, 0x87, 0x12, 0x01});
        m[14] = mfc_32bit;
        m[15] = 0x09;
        reply = run(s, image, m);
        REQUIRE(reply.size() == 18);
        CHECK(reply[17] == 0x01);
        CHECK(s.stats().sfc_errors == 2);
    }
    SECTION("02: beyond the image") {
        CHECK(error_of(s, image, make(sfc::read_holding_registers, 1000, 25)) == 2);
        CHECK(error_of(s, image, make(sfc::read_input_registers_ext, 256, 1)) == 2);
        CHECK(error_of(s, image, make(sfc::read_input_relays, 16 * 256 - 1, 2)) == 2);
        auto q = make(sfc::write_holding_register, 1024, 1);
        CHECK(error_of(s, image, q) == 2);
        const std::array<std::uint16_t, 2> at{3, 1024};
        q = make(sfc::read_holding_registers_random, 0, 2);
        q.words = at;
        CHECK(error_of(s, image, q) == 2);
        CHECK(s.stats().address_errors == 5);
    }
    SECTION("03: a count out of the limits or a length that does not fit") {
        octets m = command(make(sfc::read_holding_registers, 0, 1));
        m[20] = 126; // 03 reads at most 125
        CHECK(run(s, image, m).back() == 0x03);
        m[20] = 0;
        CHECK(run(s, image, m).back() == 0x03);
        m = command(make(sfc::read_holding_registers_ext, 0, 1));
        m[20] = 0xFD; // 2045 > 2044
        m[21] = 0x07;
        CHECK(run(s, image, m).back() == 0x03);
        // SFC 10 announcing 3 registers with the data of 2
        const std::array<std::uint16_t, 2> v{1, 2};
        auto q = make(sfc::write_holding_registers, 0, 2);
        q.words = v;
        m = command(q);
        m[20] = 3;
        CHECK(run(s, image, m).back() == 0x03);
        CHECK(image.mw(0) == 0);
        CHECK(s.stats().count_errors == 4);
    }
}

TEST_CASE("memobus server: general-purpose messages, responses and broken messages get no "
          "answer",
          "[memobus]") {
    image_type image;
    server s;
    // type 0x12: 218 header and two words of raw MW data (§5)
    CHECK(
        run(s, image, {0x12, 0, 0, 0, 0, 0, 0x10, 0, 0, 0, 0, 0, 0x34, 0x12, 0xCD, 0xAB}).empty());
    CHECK(s.stats().general == 1);
    // a response (0x19) sent to the controller
    CHECK(run(s, image, {0x19, 0x01, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                         0,    0x07, 0x00, 0x20, 0x03, 0x12, 0x12, 0x34, 0xAB, 0xCD})
              .empty());
    // total length and datagram disagree
    CHECK(run(s, image, {0x11, 0x00, 0,    0,    0,    0,    0x16, 0,    0,    0,   0,
                         0,    0x07, 0x00, 0x20, 0x03, 0x21, 0x00, 0x64, 0x00, 0x02})
              .empty());
    CHECK(s.stats().ignored == 2);
    CHECK(s.stats().requests == 0);
    // too small an output buffer: nothing is executed
    auto q = make(sfc::write_holding_register, 1, 1);
    q.value = 9;
    const octets m = command(q);
    std::array<std::uint8_t, 64> small{};
    CHECK(s.handle(m, image, small) == 0);
    CHECK(image.mw(1) == 0);
}
