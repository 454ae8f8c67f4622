// LECOM code addresses: the 790 rule of standard addressing and `!CCCCSS` (lecom.md §1.7,
// §1.9).
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <set>
#include <string>
#include <string_view>

#include "ferrule/lecom/code.hpp"

using namespace ferrule::lecom;
using ferrule::errc;

namespace {

std::string encoded(const code_address& a) {
    std::array<std::uint8_t, extended_code_length> out{};
    const std::size_t n = encode_code(a, out.data());
    return std::string(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n));
}

ferrule::result<code_address> parsed(std::string_view s) {
    return parse_code({reinterpret_cast<const std::uint8_t*>(s.data()), s.size()});
}

} // namespace

TEST_CASE("the 790 rule table of lecom.md 1.7, both ways", "[lecom][code]") {
    struct row {
        std::uint16_t code;
        std::string_view chars;
    };
    const row table[] = {
        {0, "00"},    {46, "46"},   {68, "68"},   {99, "99"},      {100, ":0"}, {111, ";1"},
        {125, "<5"},  {200, "D0"},  {248, "H8"},  {249, "H9"},     {789, "~9"}, {790, "0:"},
        {1002, "E<"}, {1103, "O="}, {2000, "ZD"}, {6229, "u\x7f"},
    };
    for (const row& r : table) {
        INFO("C" << r.code);
        CHECK(encoded(code(r.code)) == r.chars);
        const auto back = parsed(r.chars);
        REQUIRE(back);
        CHECK(*back == code(r.code));
        CHECK(back->length() == standard_code_length);
    }
}

TEST_CASE("standard addressing is a bijection on 0 to 6229", "[lecom][code]") {
    std::set<std::string> seen;
    for (unsigned c = 0; c <= max_standard_code; ++c) {
        const auto a = code(static_cast<std::uint16_t>(c));
        REQUIRE_FALSE(a.extended);
        const std::string s = encoded(a);
        REQUIRE(seen.insert(s).second);
        const auto back = parsed(s);
        REQUIRE(back);
        REQUIRE(back->code == c);
    }
    // Exactly those 6230 pairs of characters parse as a standard code.
    std::size_t accepted = 0;
    for (unsigned c1 = 0; c1 < 256; ++c1)
        for (unsigned c2 = 0; c2 < 256; ++c2) {
            const std::array<std::uint8_t, 2> in{static_cast<std::uint8_t>(c1),
                                                 static_cast<std::uint8_t>(c2)};
            if (parse_code(in)) ++accepted;
        }
    CHECK(accepted == seen.size());
}

TEST_CASE("extended addressing: 1002 is !03EA00", "[lecom][code]") {
    CHECK(encoded(extended_code(1002, 0)) == "!03EA00");
    CHECK(encoded(extended_code(0xFFFF, 0xFF)) == "!FFFFFF");
    CHECK(encoded(extended_code(39, 3)) == "!002703");
    const auto a = parsed("!03EA00");
    REQUIRE(a);
    CHECK(a->code == 1002);
    CHECK(a->subcode == 0);
    CHECK(a->extended);
    CHECK(a->length() == extended_code_length);
    const auto b = parsed("!0027FF");
    REQUIRE(b);
    CHECK(*b == extended_code(39, 255));
    // Above 6229 code() switches to extended addressing.
    CHECK(code(6230).extended);
    CHECK(encoded(code(6230)) == "!185600");
}

TEST_CASE("codes that standard addressing cannot carry are rejected", "[lecom][code]") {
    CHECK(is_valid(code(6229)));
    CHECK_FALSE(is_valid(code_address{6230, 0, false}));
    CHECK_FALSE(is_valid(code_address{65535, 0, false}));
    CHECK_FALSE(is_valid(code_address{39, 1, false})); // a subcode needs `!`
    CHECK(is_valid(extended_code(65535, 255)));
    // Character pairs beyond 6229: C1 'v' (70) with C2 0x7F (block 7) is 6239.
    CHECK(parsed("v\x7f").error() == errc::malformed);
}

TEST_CASE("malformed code fields are rejected", "[lecom][code]") {
    for (std::string_view bad : {
             "!03ea00", // lower-case hex (S1 p.8-18 shows A-F only)
             "!03EG00", // not hex
             "!03EA0",  // short
             "!",       //
             "/0",      // C1 below '0'
             "0/",      // C2 below '0'
             "\x7f"
             "0",  // C1 beyond '~'
             "0",  // one character
             "",   //
             " 1", // space
         }) {
        INFO('"' << std::string(bad) << '"');
        CHECK(parsed(bad).error() == errc::malformed);
    }
}
