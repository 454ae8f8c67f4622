#include <catch2/catch.hpp>

#include <array>
#include <string_view>
#include <vector>

#include "ferrule/movilink/frame.hpp"

using namespace ferrule::movilink;
using bytes = std::vector<std::uint8_t>;

namespace {
bytes encoded(const telegram& t) {
    bytes out(max_telegram_size);
    auto n = encode(t, out);
    REQUIRE(n);
    out.resize(*n);
    return out;
}
telegram parsed(const bytes& b) {
    auto t = parse(b);
    REQUIRE(t);
    return *t;
}
} // namespace

// Golden vectors: ../shared/protocols/movilink.md §4 (M* from SEW manuals, D* constructed).
TEST_CASE("M1: SC01 Fig. 20 cyclic 3PD request", "[movilink][frame][golden]") {
    const bytes m1{0x02, 0x01, 0x05, 0x00, 0x06, 0x3A, 0x98, 0x01, 0xF4, 0x57};
    const telegram t = parsed(m1);
    CHECK(t.dir == direction::request);
    CHECK(t.address == 1);
    CHECK(t.type == pdu_type::pd3);
    CHECK(t.pd[0] == 0x0006);
    CHECK(t.pd[1] == 0x3A98);
    CHECK(t.pd[2] == 0x01F4);
    CHECK(encoded(t) == m1);
}

TEST_CASE("M2: SC01 Fig. 23 acyclic 3PD request and response", "[movilink][frame][golden]") {
    const bytes req{0x02, 0x01, 0x85, 0x00, 0x06, 0x20, 0x00, 0x0B, 0xB8, 0x13};
    const bytes rsp{0x1D, 0x01, 0x85, 0x02, 0x06, 0x00, 0x00, 0x06, 0x06, 0x9D};
    const telegram q{direction::request, 1, pdu_type::pd3_acyclic, {}, {0x0006, 0x2000, 0x0BB8}};
    CHECK(encoded(q) == req);
    CHECK(parsed(req) == q);
    const telegram r = parsed(rsp);
    CHECK(r.dir == direction::response);
    CHECK(r.pd == std::array<std::uint16_t, 3>{0x0206, 0x0000, 0x0606});
    CHECK(encoded(r) == rsp);
}

TEST_CASE("D1-D10: constructed telegrams encode and decode exactly", "[movilink][frame][golden]") {
    struct vec {
        bytes wire;
        telegram t;
    };
    const std::vector<vec> vectors{
        {{0x02, 0x01, 0x05, 0x00, 0x06, 0x20, 0x00, 0x0B, 0xB8, 0x93},
         {direction::request, 1, pdu_type::pd3, {}, {0x0006, 0x2000, 0x0BB8}}},
        {{0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x7E, 0x00, 0x00, 0x00, 0x00, 0xEA},
         {direction::request,
          1,
          pdu_type::param_acyclic,
          param_channel::make(service::read, 0x207E),
          {}}},
        {{0x1D, 0x01, 0x86, 0x31, 0x00, 0x20, 0x87, 0x00, 0x00, 0x00, 0x14, 0x18},
         {direction::response, 1, pdu_type::param_acyclic, {0x31, 0, 0x2087, 0x14}, {}}},
        {{0x1D, 0x01, 0x86, 0xB1, 0x00, 0x20, 0x7E, 0x08, 0x00, 0x00, 0x10, 0x6D},
         {direction::response, 1, pdu_type::param_acyclic, {0xB1, 0, 0x207E, 0x08000010}, {}}},
        {{0x02, 0x01, 0x86, 0x33, 0x00, 0x20, 0x71, 0x00, 0x00, 0x00, 0x01, 0xE6},
         {direction::request,
          1,
          pdu_type::param_acyclic,
          param_channel::make(service::write_volatile, 0x2071, 1),
          {}}},
        {{0x02, 0x01, 0x04, 0x71, 0x00, 0x20, 0x7E, 0x00, 0x00, 0x00, 0x00, 0x00, 0x06, 0x07, 0xD0,
          0x00, 0x00, 0xF9},
         {direction::request, 1, pdu_type::param_3pd, {0x71, 0, 0x207E, 0}, {0x0006, 0x07D0, 0}}},
        {{0x02, 0xFF, 0x03, 0x00, 0x06, 0x10, 0x00, 0xE8},
         {direction::request, 255, pdu_type::pd2, {}, {0x0006, 0x1000, 0}}},
        {{0x02, 0x65, 0x85, 0x00, 0x06, 0x20, 0x00, 0x0B, 0xB8, 0x77},
         {direction::request, 101, pdu_type::pd3_acyclic, {}, {0x0006, 0x2000, 0x0BB8}}},
        {{0x02, 0x03, 0x01, 0x00, 0x00, 0x00},
         {direction::request, 3, pdu_type::pd1, {}, {0, 0, 0}}},
        {{0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x76, 0x00, 0x00, 0x00, 0x00, 0xE2},
         {direction::request,
          1,
          pdu_type::param_acyclic,
          param_channel::make(service::read, 0x2076),
          {}}},
    };
    for (const auto& v : vectors) {
        CAPTURE(v.wire);
        CHECK(encoded(v.t) == v.wire);
        CHECK(parsed(v.wire) == v.t);
    }
}

TEST_CASE("D4: error response fields", "[movilink][frame][golden]") {
    const telegram t =
        parsed({0x1D, 0x01, 0x86, 0xB1, 0x00, 0x20, 0x7E, 0x08, 0x00, 0x00, 0x10, 0x6D});
    CHECK(t.param.is_error());
    CHECK(t.param.svc() == service::read);
    CHECK(t.param.data_length() == 4);
    CHECK(t.param.error_class() == 8);
    CHECK(t.param.error_code() == 0);
    CHECK(t.param.additional_code() == 0x0010);
}

TEST_CASE("every documented TYP round-trips in both directions", "[movilink][frame]") {
    const std::array<std::uint8_t, 14> types{0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06,
                                             0x80, 0x81, 0x82, 0x83, 0x84, 0x85, 0x86};
    const std::array<std::size_t, 14> sizes{14, 6, 16, 8, 18, 10, 12, 14, 6, 16, 8, 18, 10, 12};
    for (std::size_t i = 0; i < types.size(); ++i) {
        for (auto dir : {direction::request, direction::response}) {
            const auto type = static_cast<pdu_type>(types[i]);
            telegram t{dir, 42, type, {0x43, 7, 0x2081, 0xDEADBEEF}, {0x1111, 0x2222, 0x3333}};
            const bytes wire = encoded(t);
            CAPTURE(types[i]);
            CHECK(wire.size() == sizes[i]);
            CHECK(wire.size() == telegram_size(type));
            CHECK(parsed(wire) == t);
        }
    }
}

TEST_CASE("encode_fixed matches the runtime encoder", "[movilink][frame]") {
    const telegram t{
        direction::request, 1, pdu_type::param_3pd, {0x71, 0, 0x207E, 0}, {6, 0x07D0, 0}};
    std::array<std::uint8_t, telegram_size(pdu_type::param_3pd)> fixed{};
    encode_fixed<pdu_type::param_3pd>(t, fixed);
    CHECK(bytes(fixed.begin(), fixed.end()) == encoded(t));
    const telegram p{direction::request, 1, pdu_type::pd3, {}, {0x0006, 0x3A98, 0x01F4}};
    std::array<std::uint8_t, 10> f3{};
    encode_fixed<pdu_type::pd3>(p, f3);
    CHECK(f3[9] == 0x57);
}

TEST_CASE("encode and parse reject what the protocol cannot carry", "[movilink][frame]") {
    telegram t{direction::request, 1, static_cast<pdu_type>(0x07), {}, {}};
    std::array<std::uint8_t, 18> out{};
    CHECK(encode(t, out).error() == ferrule::errc::invalid_argument);
    t.type = pdu_type::param_3pd;
    std::array<std::uint8_t, 17> small{};
    CHECK(encode(t, small).error() == ferrule::errc::buffer_too_small);

    CHECK(parse(bytes{0x02, 0x01}).error() == ferrule::errc::malformed);
    CHECK(parse(bytes{0x03, 0x03, 0x01, 0x00, 0x00, 0x01}).error() == ferrule::errc::malformed);
    CHECK(parse(bytes{0x02, 0x03, 0x07, 0x00, 0x00, 0x06}).error() == ferrule::errc::malformed);
    CHECK(parse(bytes{0x02, 0x03, 0x01, 0x00, 0x00, 0x01}).error() == ferrule::errc::bad_checksum);
    CHECK(parse(bytes{0x02, 0x03, 0x01, 0x00, 0x00, 0x00, 0x00}).error() ==
          ferrule::errc::malformed);
}

TEST_CASE("address kinds and their reply rules", "[movilink][frame]") {
    CHECK(kind_of(0) == address_kind::single);
    CHECK(kind_of(99) == address_kind::single);
    CHECK(kind_of(100) == address_kind::group);
    CHECK(kind_of(199) == address_kind::group);
    CHECK(kind_of(200) == address_kind::undefined);
    CHECK(kind_of(253) == address_kind::local);
    CHECK(kind_of(254) == address_kind::point_to_point);
    CHECK(kind_of(255) == address_kind::broadcast);
    CHECK(expects_response(5));
    CHECK(expects_response(254));
    CHECK_FALSE(expects_response(101));
    CHECK_FALSE(expects_response(255));
}

TEST_CASE("decoder frames by idle + SD + TYP length, even with 0x02/0x1D in the data",
          "[movilink][decoder]") {
    // PO2 = 0x021D contains both start delimiters.
    const telegram t{direction::response, 2, pdu_type::pd3, {}, {0x1D02, 0x021D, 0x0202}};
    const bytes wire = encoded(t);
    decoder d(decoder::accept::responses);
    for (std::size_t i = 0; i + 1 < wire.size(); ++i) {
        const auto s = d.feed(std::span(&wire[i], 1));
        REQUIRE(s.what == decoder::status::need_more);
    }
    const auto s = d.feed(std::span(&wire.back(), 1));
    REQUIRE(s.what == decoder::status::frame);
    CHECK(bytes(d.frame().begin(), d.frame().end()) == wire);
}

TEST_CASE("decoder resynchronises at the next idle gap after garbage", "[movilink][decoder]") {
    const bytes good{0x1D, 0x01, 0x85, 0x02, 0x06, 0x00, 0x00, 0x06, 0x06, 0x9D};
    decoder d(decoder::accept::responses);
    // A request start delimiter where a response is expected.
    const bytes garbage{0x02, 0x1D, 0x01, 0x85};
    auto s = d.feed(garbage);
    CHECK(s.what == decoder::status::error);
    CHECK(s.ec == ferrule::errc::malformed);
    CHECK(s.consumed == 1);
    // Without an idle gap everything else is skipped, even a valid-looking telegram.
    s = d.feed(std::span(garbage).subspan(1));
    CHECK(s.what == decoder::status::need_more);
    s = d.feed(good);
    CHECK(s.what == decoder::status::need_more);
    CHECK(d.skipped() == garbage.size() + good.size());
    d.idle();
    s = d.feed(good);
    CHECK(s.what == decoder::status::frame);
    CHECK(s.consumed == good.size());
}

TEST_CASE("decoder reports bad BCC, bad TYP and trailing bytes", "[movilink][decoder]") {
    decoder d;
    bytes bad_bcc{0x1D, 0x01, 0x85, 0x02, 0x06, 0x00, 0x00, 0x06, 0x06, 0x9C};
    auto s = d.feed(bad_bcc);
    CHECK(s.what == decoder::status::error);
    CHECK(s.ec == ferrule::errc::bad_checksum);
    CHECK(s.consumed == bad_bcc.size());

    d.idle();
    s = d.feed(bytes{0x1D, 0x01, 0x42});
    CHECK(s.what == decoder::status::error);
    CHECK(s.ec == ferrule::errc::malformed);
    CHECK(s.consumed == 3);

    d.idle();
    const bytes d9{0x02, 0x03, 0x01, 0x00, 0x00, 0x00, 0xEE};
    s = d.feed(d9);
    CHECK(s.what == decoder::status::frame); // D9: BCC 0x00 is a valid BCC
    CHECK(s.consumed == 6);
    s = d.feed(std::span(d9).subspan(6));
    CHECK(s.what == decoder::status::error); // a byte behind a telegram without a gap
}

TEST_CASE("decoder counts every skipped byte once", "[movilink][decoder]") {
    // Found by fuzz_movilink_decoder: the byte that broke a telegram was counted twice.
    decoder d;
    auto s = d.feed(bytes{0x1D, 0x01, 0x42}); // bad TYP in the third byte
    REQUIRE(s.what == decoder::status::error);
    CHECK(d.skipped() == 3);
    d.idle();
    s = d.feed(bytes{0x1D, 0x01, 0x81, 0x00, 0x06, 0x00}); // 1PD with a wrong BCC
    REQUIRE(s.what == decoder::status::error);
    CHECK(s.ec == ferrule::errc::bad_checksum);
    CHECK(d.skipped() == 3 + 6);
    d.idle();
    s = d.feed(bytes{0x55}); // no start delimiter
    REQUIRE(s.what == decoder::status::error);
    CHECK(d.skipped() == 3 + 6 + 1);
}

TEST_CASE("names of PDU types, services and address kinds", "[movilink][frame]") {
    CHECK(std::string_view(name(pdu_type::pd3)) == "3PD cyclic");
    CHECK(std::string_view(name(pdu_type::param_acyclic)) == "PARAM acyclic");
    CHECK(std::string_view(name(pdu_type::param_1pd_acyclic)) == "PARAM + 1PD acyclic");
    CHECK(std::string_view(name(service::write_volatile)) == "write volatile");
    CHECK(std::string_view(name(service::read_attribute)) == "read attribute");
    CHECK(std::string_view(name(kind_of(101))) == "group");
    CHECK(std::string_view(name(kind_of(254))) == "point-to-point");
}
