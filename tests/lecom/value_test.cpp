// LECOM parameter values VD / VH / VS / VO (S1 p.8-18/8-19, lecom.md §1.10) and the FIX32
// examples of S6.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>

#include "ferrule/lecom/frame.hpp"
#include "ferrule/lecom/value.hpp"

using namespace ferrule::lecom;
using ferrule::errc;

namespace {

std::string text(const value& v) {
    std::array<std::uint8_t, max_value_length> out{};
    const std::size_t n = encode_value(v, out.data());
    return std::string(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n));
}

} // namespace

TEST_CASE("VD: decimals are FIX32, value times 10000", "[lecom][value]") {
    struct row {
        std::string_view text;
        std::int32_t fixed;
        std::uint8_t digits;
    };
    const row rows[] = {
        {"35.4", 354'000, 1},
        {"-12.5", -125'000, 1},
        {"0", 0, 0},
        {"95.2", 952'000, 1},
        {"12", 120'000, 0},
        {"1.2345", 12'345, 4},
        {"123456", 1'234'560'000, 0},
        {"214748.3647", std::numeric_limits<std::int32_t>::max(), 4},
        {"-214748.3648", std::numeric_limits<std::int32_t>::min(), 4},
    };
    for (const row& r : rows) {
        INFO(std::string(r.text));
        const auto v = parse_value(r.text);
        REQUIRE(v);
        CHECK(v->format == value_format::decimal);
        CHECK(v->fixed == r.fixed);
        CHECK(v->digits == r.digits);
        CHECK(text(*v) == r.text); // canonical forms come back unchanged
    }
    CHECK(parse_value("35.4")->whole() == 35);
    CHECK(parse_value("-12.5")->whole() == -12);
}

TEST_CASE("VD: what the manual rules out is rejected", "[lecom][value]") {
    for (std::string_view bad : {
             "214748.3648",  // one above the FIX32 range
             "-214748.3649", // one below
             "1234567",      // 7 integer digits
             "999999.9999",  // 6 digits, but beyond the range
             "12.",          // "the decimal point must not be transmitted" without decimals
             "1.23456",      // 5 decimals
             ".5",           // no integer digit
             "-",            //
             "",             //
             "+5",           // no plus sign in VD
             "1,5",          //
             "1 ",           //
             "--1",          //
         }) {
        INFO('"' << std::string(bad) << '"');
        CHECK(parse_value(bad).error() == errc::malformed);
    }
}

TEST_CASE("VD encoding: as many decimals as needed, or as asked", "[lecom][value]") {
    CHECK(text(decimal_fixed(354'000)) == "35.4");
    CHECK(text(decimal_fixed(-125'000)) == "-12.5");
    CHECK(text(decimal_fixed(-5'000)) == "-0.5");
    CHECK(text(decimal_fixed(350'000)) == "35");
    CHECK(text(decimal_fixed(350'000, 2)) == "35.00");
    CHECK(text(decimal_fixed(1, 9)) == "0.0001"); // at most 4 decimals
    CHECK(text(decimal_fixed(std::numeric_limits<std::int32_t>::min())) == "-214748.3648");
    CHECK(text(decimal_fixed(std::numeric_limits<std::int32_t>::max())) == "214748.3647");
    CHECK(text(*decimal(1500)) == "1500");
    CHECK(text(*decimal(-214748)) == "-214748");
    CHECK(decimal(214749).error() == errc::invalid_argument);
    CHECK(decimal(-214749).error() == errc::invalid_argument);
    CHECK(needed_decimals(354'000) == 1);
    CHECK(needed_decimals(12'345) == 4);
    CHECK(needed_decimals(0) == 0);
}

TEST_CASE("FIX32 examples of the attribute tables: 1.2 and -10.45", "[lecom][value]") {
    const auto a = parse_value("1.2");
    REQUIRE(a);
    CHECK(a->fixed == 12'000);
    CHECK(static_cast<std::uint32_t>(a->fixed) == 0x00002EE0u);
    const auto b = parse_value("-10.45");
    REQUIRE(b);
    CHECK(b->fixed == -104'500);
    CHECK(static_cast<std::uint32_t>(b->fixed) == 0xFFFE67CCu);
}

TEST_CASE("VH: 2, 4 or 8 upper-case hex digits", "[lecom][value]") {
    const auto w = parse_value("H0900"); // C68 of S1 p.8-22
    REQUIRE(w);
    CHECK(w->format == value_format::hex);
    CHECK(w->hex == 0x0900);
    CHECK(w->digits == 4);
    CHECK(parse_value("H1F")->hex == 0x1F);
    CHECK(parse_value("H0001D4C0")->hex == 0x1D4C0);
    CHECK(parse_value("HFFFFFFFF")->hex == 0xFFFFFFFFu);
    for (std::string_view bad : {"H", "H1", "H123", "H12345", "H123456789", "H09a0", "H0G00"})
        CHECK(parse_value(bad).error() == errc::malformed);
    CHECK(text(*hex(0x0900)) == "H0900");
    CHECK(text(*hex(0x1F, 2)) == "H1F");
    CHECK(text(*hex(0xFFFFFFFF, 8)) == "HFFFFFFFF");
    CHECK(text(*hex(0x1D4C0, 8)) == "H0001D4C0");
    CHECK(hex(0x1FF, 2).error() == errc::invalid_argument);
    CHECK(hex(1, 3).error() == errc::invalid_argument);
    CHECK(hex(0x10000, 4).error() == errc::invalid_argument);
}

TEST_CASE("VS: visible ASCII, read-only strings of the drive", "[lecom][value]") {
    const auto s = parse_value("S82EV123");
    REQUIRE(s);
    CHECK(s->format == value_format::string);
    CHECK(s->text() == "82EV123");
    CHECK(text(*string("82EV123")) == "S82EV123");
    CHECK(text(*string("a b")) == "Sa b");
    CHECK(parse_value("S")->size == 0);
    CHECK(parse_value("S12345678901234567890")->size == 20);
    CHECK(parse_value("S123456789012345678901").error() == errc::malformed);
    CHECK(string("123456789012345678901").error() == errc::invalid_argument);
    CHECK(string("tab\t").error() == errc::invalid_argument);
}

TEST_CASE("VO: one hex digit per nibble, high nibble first", "[lecom][value]") {
    const auto o = parse_value("O0A1BFF");
    REQUIRE(o);
    CHECK(o->format == value_format::octets);
    REQUIRE(o->size == 3);
    CHECK(o->data()[0] == 0x0A);
    CHECK(o->data()[1] == 0x1B);
    CHECK(o->data()[2] == 0xFF);
    CHECK(text(*o) == "O0A1BFF");
    CHECK(parse_value("O").has_value());
    for (std::string_view bad : {"O0A1", "O0a", "O0G"})
        CHECK(parse_value(bad).error() == errc::malformed);
    const std::array<std::uint8_t, 17> too_many{};
    CHECK(octets(too_many).error() == errc::invalid_argument);
    CHECK(text(*octets(std::span(too_many).first(16))).size() == max_value_length);
}

TEST_CASE("values the factories cannot make are not encoded", "[lecom][value]") {
    // Found in review: encode() wrote a hand-built value without looking, and 40 hex digits
    // ran past its buffer.
    std::array<std::uint8_t, max_frame_length> out{};
    value h;
    h.format = value_format::hex;
    h.digits = 40;
    CHECK(encode(write_request(1, code(46), h), out).error() == errc::invalid_argument);
    h.digits = 2;
    h.hex = 0x100;
    CHECK(encode(write_request(1, code(46), h), out).error() == errc::invalid_argument);
    value s;
    s.format = value_format::string;
    s.size = 30;
    CHECK(encode(write_request(1, code(46), s), out).error() == errc::invalid_argument);
    s.size = 1;
    s.bytes[0] = 0x03; // ETX inside a text would cut the telegram
    CHECK(encode(write_request(1, code(46), s), out).error() == errc::invalid_argument);
    value o;
    o.format = value_format::octets;
    o.size = 17;
    CHECK(encode(write_request(1, code(46), o), out).error() == errc::invalid_argument);
    value d = decimal_fixed(1);
    d.digits = 5;
    CHECK(encode(write_request(1, code(46), d), out).error() == errc::invalid_argument);
}

TEST_CASE("encode_value writes nothing for a value the factories cannot make", "[lecom][value]") {
    std::array<std::uint8_t, max_value_length> out{};
    CHECK(encode_value(*string(""), out.data()) == 1); // "S": the shortest texts are 1 long
    CHECK(encode_value(*octets({}), out.data()) == 1);
    CHECK(encode_value(decimal_fixed(0), out.data()) == 1);

    value d = decimal_fixed(1);
    d.digits = 5;
    value h = *hex(0xAB, 2);
    h.digits = 3;
    value wide = *hex(0xAB, 2);
    wide.hex = 0x1AB; // three digits' worth in two
    value s = *string("OK");
    s.bytes[1] = 0x03; // ETX inside a text would cut the telegram
    value long_s = *string("12345678901234567890");
    long_s.size = value::max_string + 1;
    value o = *octets({});
    o.size = value::max_octets + 1;
    value none;
    none.format = static_cast<value_format>(4);
    for (const value& v : {d, h, wide, s, long_s, o, none}) {
        out.fill(0);
        CHECK(encode_value(v, out.data()) == 0);
    }
}
