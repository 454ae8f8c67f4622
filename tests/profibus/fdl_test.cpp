// PROFIBUS FDL telegrams: the golden telegrams of protocols/modbus_profibus.md §B.9 (master
// 2, slave 8, ident 0x0815) and the real ET200S Slave_Diag reply in SD2 (§B.2) decode and
// encode exactly; the decoder resynchronises after garbage, bad FCS, bad LE/LEr and ED.
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "ferrule/profibus/fdl.hpp"

using namespace ferrule::profibus;
using ferrule::errc;
using bytes = std::vector<std::uint8_t>;

namespace {

struct decoded {
    std::vector<telegram> telegrams;
    std::vector<bytes> data; // each telegram's data unit, copied
    std::vector<std::error_code> errors;
};

decoded decode_all(const bytes& in, std::size_t chunk = 1000) {
    fdl_decoder d;
    decoded out;
    std::span<const std::uint8_t> rest(in);
    auto take = [&](const fdl_decoder::step& s) {
        if (s.what == fdl_decoder::status::error) out.errors.push_back(s.ec);
        if (s.what == fdl_decoder::status::frame) {
            out.telegrams.push_back(d.telegram());
            out.data.emplace_back(d.telegram().data.begin(), d.telegram().data.end());
        }
    };
    while (!rest.empty()) {
        auto piece = rest.first(std::min(chunk, rest.size()));
        rest = rest.subspan(piece.size());
        fdl_decoder::step s;
        do {
            s = d.feed(piece);
            piece = piece.subspan(s.consumed);
            take(s);
        } while (s.what != fdl_decoder::status::need_more);
    }
    fdl_decoder::step s;
    do {
        s = d.finish();
        take(s);
    } while (s.what != fdl_decoder::status::need_more);
    return out;
}

bytes encoded(const telegram& t, encode_options o = {}) {
    bytes out(max_telegram);
    const auto n = encode(t, out, o);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

telegram request(std::uint8_t da, std::uint8_t sa, std::uint8_t fc, std::uint8_t dsap,
                 std::uint8_t ssap, std::span<const std::uint8_t> data) {
    telegram t;
    t.da = da;
    t.sa = sa;
    t.fc = fc;
    t.dsap = dsap;
    t.ssap = ssap;
    t.data = data;
    return t;
}

} // namespace

TEST_CASE("profibus FCS is the byte sum from DA to the last data byte", "[profibus][fdl]") {
    CHECK(fcs(bytes{0x08, 0x02, 0x49}) == 0x53);
    CHECK(fcs(bytes{0xFF, 0x82, 0x46, 0x3A, 0x3E, 0x02, 0x00}) == 0x41);
    CHECK(fcs(bytes{}) == 0);
}

TEST_CASE("profibus golden telegrams encode exactly", "[profibus][fdl]") {
    // FDL_Status.req 10 08 02 49 53 16
    CHECK(encoded(request(8, 2, request_code(request_fn::fdl_status, false, false), no_sap, no_sap,
                          {})) == bytes{0x10, 0x08, 0x02, 0x49, 0x53, 0x16});
    // FDL_Status.res from slave 8: SD1, FC 0x00
    CHECK(encoded(request(2, 8, response_code(response_fn::ok), no_sap, no_sap, {})) ==
          bytes{0x10, 0x02, 0x08, 0x00, 0x0A, 0x16});
    // Slave_Diag.req, FCB = 1, FCV = 0: 68 05 05 68 88 82 6D 3C 3E F1 16
    CHECK(encoded(request(8, 2, request_code(request_fn::srd_high, true, false), 60, 62, {})) ==
          bytes{0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x6D, 0x3C, 0x3E, 0xF1, 0x16});
    // Slave_Diag.res in WPRM, SD3: A2 82 88 08 3E 3C 02 05 00 FF 08 15 AF 16
    const bytes diag{0x02, 0x05, 0x00, 0xFF, 0x08, 0x15};
    CHECK(
        encoded(request(2, 8, response_code(response_fn::data_low), 62, 60, diag)) ==
        bytes{0xA2, 0x82, 0x88, 0x08, 0x3E, 0x3C, 0x02, 0x05, 0x00, 0xFF, 0x08, 0x15, 0xAF, 0x16});
    // Set_Prm.req: Lock | WD, 10 × 10, min TSDR 11, ident 0815, group 0
    const bytes prm{0x88, 0x0A, 0x0A, 0x0B, 0x08, 0x15, 0x00};
    CHECK(encoded(request(8, 2, request_code(request_fn::srd_high, true, true), 61, 62, prm)) ==
          bytes{0x68, 0x0C, 0x0C, 0x68, 0x88, 0x82, 0x7D, 0x3D, 0x3E, 0x88, 0x0A, 0x0A, 0x0B, 0x08,
                0x15, 0x00, 0xC6, 0x16});
    // Chk_Cfg.req (0x11, 0x21)
    const bytes cfg{0x11, 0x21};
    CHECK(encoded(request(8, 2, request_code(request_fn::srd_high, true, false), 62, 62, cfg)) ==
          bytes{0x68, 0x07, 0x07, 0x68, 0x88, 0x82, 0x6D, 0x3E, 0x3E, 0x11, 0x21, 0x25, 0x16});
    // Data_Exchange.req 2 bytes out, and its DL reply with 2 bytes in
    const bytes out2{0x12, 0x34};
    CHECK(encoded(request(8, 2, request_code(request_fn::srd_high, false, true), no_sap, no_sap,
                          out2)) ==
          bytes{0x68, 0x05, 0x05, 0x68, 0x08, 0x02, 0x5D, 0x12, 0x34, 0xAD, 0x16});
    const bytes in2{0xAB, 0xCD};
    CHECK(encoded(request(2, 8, response_code(response_fn::data_low), no_sap, no_sap, in2)) ==
          bytes{0x68, 0x05, 0x05, 0x68, 0x02, 0x08, 0x08, 0xAB, 0xCD, 0x8A, 0x16});
    // Data_Exchange.req 8 bytes out: SD3
    const bytes out8{0, 1, 2, 3, 4, 5, 6, 7};
    CHECK(encoded(request(8, 2, request_code(request_fn::srd_high, false, true), no_sap, no_sap,
                          out8)) ==
          bytes{0xA2, 0x08, 0x02, 0x5D, 0, 1, 2, 3, 4, 5, 6, 7, 0x83, 0x16});
    // Global_Control Clear_Data to 127
    const bytes clear{0x02, 0x00};
    CHECK(
        encoded(request(127, 2, request_code(request_fn::sdn_high, false, false), 58, 62, clear)) ==
        bytes{0x68, 0x07, 0x07, 0x68, 0xFF, 0x82, 0x46, 0x3A, 0x3E, 0x02, 0x00, 0x41, 0x16});
    // Short acknowledgement and token
    telegram ack;
    ack.frame = frame::short_ack;
    CHECK(encoded(ack) == bytes{0xE5});
    telegram token;
    token.frame = frame::sd4;
    token.da = 3;
    token.sa = 2;
    CHECK(encoded(token) == bytes{0xDC, 0x03, 0x02});
}

TEST_CASE("profibus an 8-byte data unit decodes the same from SD2 and SD3", "[profibus][fdl]") {
    // The real ET200S answers Slave_Diag with SD2 (§B.2).
    const bytes et200s{0x68, 0x0B, 0x0B, 0x68, 0x81, 0x88, 0x08, 0x3E, 0x3C,
                       0x02, 0x05, 0x00, 0xFF, 0x80, 0xE0, 0xF1, 0x16};
    const bytes sd3_form{0xA2, 0x81, 0x88, 0x08, 0x3E, 0x3C, 0x02,
                         0x05, 0x00, 0xFF, 0x80, 0xE0, 0xF1, 0x16};
    for (const bytes& in : {et200s, sd3_form}) {
        const auto d = decode_all(in);
        REQUIRE(d.telegrams.size() == 1);
        CHECK(d.errors.empty());
        const telegram& t = d.telegrams[0];
        CHECK(t.da == 1);
        CHECK(t.sa == 8);
        CHECK(t.fc == 0x08);
        CHECK_FALSE(t.is_request());
        CHECK(t.dsap == 62);
        CHECK(t.ssap == 60);
        CHECK(d.data[0] == bytes{0x02, 0x05, 0x00, 0xFF, 0x80, 0xE0});
    }
    telegram t;
    t.da = 1;
    t.sa = 8;
    t.fc = 0x08;
    t.dsap = 62;
    t.ssap = 60;
    const bytes diag{0x02, 0x05, 0x00, 0xFF, 0x80, 0xE0};
    t.data = diag;
    CHECK(encoded(t, {.sd2_for_8_bytes = true}) == et200s);
    CHECK(encoded(t) == sd3_form);
}

TEST_CASE("profibus golden telegrams decode, byte by byte and in one piece", "[profibus][fdl]") {
    const bytes stream{0x10, 0x08, 0x02, 0x49, 0x53, 0x16, // FDL_Status
                       0x68, 0x0C, 0x0C, 0x68, 0x88, 0x82, 0x7D, 0x3D, 0x3E, 0x88, 0x0A, // Set_Prm
                       0x0A, 0x0B, 0x08, 0x15, 0x00, 0xC6, 0x16,                         //
                       0xE5,                                                             // SC
                       0xA2, 0x08, 0x02, 0x5D, 0,    1,    2,    3,    4,    5,    6,
                       7,    0x83, 0x16,  // DX SD3
                       0xDC, 0x03, 0x02}; // token
    for (const std::size_t chunk : {std::size_t{1}, std::size_t{7}, stream.size()}) {
        const auto d = decode_all(stream, chunk);
        CHECK(d.errors.empty());
        REQUIRE(d.telegrams.size() == 5);
        CHECK(d.telegrams[0].frame == frame::sd1);
        CHECK(d.telegrams[0].function() == static_cast<std::uint8_t>(request_fn::fdl_status));
        CHECK(d.telegrams[1].frame == frame::sd2);
        CHECK(d.telegrams[1].dsap == 61);
        CHECK(d.telegrams[1].ssap == 62);
        CHECK(d.telegrams[1].fcb());
        CHECK(d.telegrams[1].fcv());
        CHECK(d.data[1] == bytes{0x88, 0x0A, 0x0A, 0x0B, 0x08, 0x15, 0x00});
        CHECK(d.telegrams[2].frame == frame::short_ack);
        CHECK(d.telegrams[3].frame == frame::sd3);
        CHECK(d.telegrams[3].dsap == no_sap);
        CHECK(d.data[3] == bytes{0, 1, 2, 3, 4, 5, 6, 7});
        CHECK(d.telegrams[4].frame == frame::sd4);
        CHECK(d.telegrams[4].da == 3);
    }
}

TEST_CASE("profibus decoder resynchronises after garbage and broken telegrams", "[profibus][fdl]") {
    const bytes good{0x10, 0x08, 0x02, 0x49, 0x53, 0x16};
    SECTION("garbage before a telegram is one malformed run") {
        bytes in{0x00, 0x55, 0x99};
        in.insert(in.end(), good.begin(), good.end());
        const auto d = decode_all(in);
        REQUIRE(d.telegrams.size() == 1);
        CHECK(d.errors == std::vector<std::error_code>{errc::malformed});
    }
    SECTION("a bad FCS is reported and the next telegram still found") {
        bytes in{0x10, 0x08, 0x02, 0x49, 0x54, 0x16};
        in.insert(in.end(), good.begin(), good.end());
        const auto d = decode_all(in);
        REQUIRE(d.telegrams.size() == 1);
        REQUIRE_FALSE(d.errors.empty());
        CHECK(d.errors[0] == errc::bad_checksum);
    }
    SECTION("LE and LEr differ, LE out of range, a wrong second SD2 or ED") {
        for (const bytes& broken :
             {bytes{0x68, 0x05, 0x06, 0x68, 0x08, 0x02, 0x5D, 0x12, 0x34, 0xAD, 0x16},
              bytes{0x68, 0x03, 0x03, 0x68, 0x08, 0x02, 0x5D, 0x67, 0x16},
              bytes{0x68, 0x05, 0x05, 0x69, 0x08, 0x02, 0x5D, 0x12, 0x34, 0xAD, 0x16},
              bytes{0x68, 0x05, 0x05, 0x68, 0x08, 0x02, 0x5D, 0x12, 0x34, 0xAD, 0x17}}) {
            bytes in = broken;
            in.insert(in.end(), good.begin(), good.end());
            const auto d = decode_all(in);
            REQUIRE(d.telegrams.size() == 1);
            CHECK(d.telegrams[0].fc == 0x49);
            CHECK_FALSE(d.errors.empty());
        }
    }
    SECTION("SAP bytes announced by the addresses but missing") {
        // DA with the extension bit, SD1 (no data unit): the DSAP is missing.
        const bytes in{0x10, 0x88, 0x02, 0x49, 0xD3, 0x16};
        const auto d = decode_all(in);
        CHECK(d.telegrams.empty());
        CHECK(d.errors == std::vector<std::error_code>{errc::malformed});
    }
    SECTION("a truncated telegram at the end is dropped by finish()") {
        const bytes in{0x68, 0x05, 0x05, 0x68, 0x08};
        const auto d = decode_all(in);
        CHECK(d.telegrams.empty());
        CHECK(d.errors == std::vector<std::error_code>{errc::malformed});
    }
}

TEST_CASE("profibus encode refuses what a telegram cannot carry", "[profibus][fdl]") {
    std::array<std::uint8_t, max_telegram> out{};
    telegram t;
    t.da = 128;
    CHECK(encode(t, out).error() == errc::invalid_argument);
    t.da = 8;
    t.dsap = 64;
    CHECK(encode(t, out).error() == errc::invalid_argument);
    t.dsap = 60;
    std::array<std::uint8_t, 246> big{};
    t.data = big; // 246 + DSAP > 246
    CHECK(encode(t, out).error() == errc::invalid_argument);
    t.data = std::span<const std::uint8_t>(big).first(245);
    REQUIRE(encode(t, out));
    CHECK(*encode(t, out) == max_telegram);
    std::array<std::uint8_t, 5> small{};
    t.data = {};
    CHECK(encode(t, small).error() == errc::buffer_too_small);
}

TEST_CASE("profibus SAP bytes with a segment or further extension are not DP: malformed",
          "[profibus][fdl]") {
    for (const bytes& in : {bytes{0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x6D, 0xBC, 0x3E, 0x71, 0x16},
                            bytes{0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x6D, 0x7C, 0x3E, 0x31, 0x16},
                            bytes{0xDC, 0x88, 0x02}}) {
        const auto d = decode_all(in);
        CHECK(d.telegrams.empty());
        CHECK(d.errors == std::vector<std::error_code>{errc::malformed});
    }
}
