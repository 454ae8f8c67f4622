// MP register names: MW00100, IW0010, MB00100A, IB00100 to {kind, word, bit} and back, the
// coil address word × 16 + bit, and everything else refused.
#include <catch2/catch.hpp>

#include <array>
#include <string>
#include <string_view>

#include "ferrule/memobus/names.hpp"

using namespace ferrule::memobus;
using ferrule::errc;

namespace {

std::string name_of(const register_ref& r) {
    std::array<char, max_register_name> buf{};
    const auto n = format_register(r, buf);
    REQUIRE(n);
    return std::string(buf.data(), *n);
}

} // namespace

// Usable in constant expressions.
static_assert(try_parse_register("MW00100") == register_ref{register_kind::mw, 100, 0});
static_assert(try_parse_register("MB00100A") == register_ref{register_kind::mb, 100, 10});
static_assert(!try_parse_register("MW65535"));
static_assert(bit_address(*try_parse_register("MB00100A")) == 1610);

TEST_CASE("memobus register names parse", "[memobus][names]") {
    CHECK(*parse_register("MW00100") == register_ref{register_kind::mw, 100, 0});
    CHECK(*parse_register("MW0") == register_ref{register_kind::mw, 0, 0});
    CHECK(*parse_register("MW65534") == register_ref{register_kind::mw, 65534, 0});
    CHECK(*parse_register("mw123") == register_ref{register_kind::mw, 123, 0});
    CHECK(*parse_register("IW0010") == register_ref{register_kind::iw, 10, 0});
    CHECK(*parse_register("IW65535") == register_ref{register_kind::iw, 65535, 0});
    CHECK(*parse_register("iW7") == register_ref{register_kind::iw, 7, 0});
    // MB: the word in decimal, then one hex digit for the bit
    CHECK(*parse_register("MB001000") == register_ref{register_kind::mb, 100, 0});
    CHECK(*parse_register("MB00100A") == register_ref{register_kind::mb, 100, 10});
    CHECK(*parse_register("mb00100f") == register_ref{register_kind::mb, 100, 15});
    CHECK(*parse_register("MB10") == register_ref{register_kind::mb, 1, 0});
    CHECK(*parse_register("MB65534F") == register_ref{register_kind::mb, 65534, 15});
    CHECK(*parse_register("IB00100") == register_ref{register_kind::ib, 10, 0});
    CHECK(*parse_register("Ib655359") == register_ref{register_kind::ib, 65535, 9});

    CHECK(bit_address(*parse_register("MB001000")) == 1600);
    CHECK(bit_address(*parse_register("MB00100A")) == 1610);
    CHECK(bit_address(*parse_register("MB04095F")) == 65535);
    CHECK(bit_address(*parse_register("MB040960")) == 65536); // beyond MEMOBUS
    CHECK(is_bit(register_kind::ib));
    CHECK_FALSE(is_bit(register_kind::iw));
}

TEST_CASE("memobus register names refused", "[memobus][names]") {
    for (const std::string_view bad :
         {"",         "M",      "MW",        "MB",        "MB0",      "IB",       "IB1",
          "MW000100", "IW1A",   "IWC000",    "MB0001000", "MB00100G", "MB0010x0", "MW-1",
          "MW+1",     "MW 100", " MW100",    "MW100 ",    "MX100",    "ML100",    "MF100",
          "OW100",    "SW100",  "GW100",     "XW00100",   "WM100",    "M W100",   "MW1.0",
          "MW0x10",   "MB.0",   "MB00100AA", "MW999999"}) {
        INFO(bad);
        CHECK(parse_register(bad).error() == errc::invalid_argument);
        CHECK_FALSE(try_parse_register(bad));
    }
    // A name with a NUL inside
    CHECK_FALSE(try_parse_register(std::string_view("MW1\0", 4)));
}

TEST_CASE("memobus register names beyond their area are out of range", "[memobus][names]") {
    // Well-formed names whose word number the area does not have: not "no name" (§3.4).
    for (const std::string_view far : {"MW65535", "MW99999", "mw65535", "IW65536", "IW99999",
                                       "MB65535F", "MB999990", "IB655360", "ib99999F"}) {
        INFO(far);
        CHECK(parse_register(far).error() == errc::out_of_range);
        CHECK_FALSE(try_parse_register(far));
    }
    // What the name may reach, for a message: MW65535 is beyond MW00000…MW65534.
    CHECK(area_of("MW65535") == register_kind::mw);
    CHECK(area_of("ib99999F") == register_kind::ib);
    CHECK(area_of("Iw1") == register_kind::iw);
    CHECK(area_of("MB") == register_kind::mb);
    CHECK_FALSE(area_of("XW1"));
    CHECK_FALSE(area_of("MX1"));
    CHECK_FALSE(area_of("M"));
    CHECK(last_word(register_kind::mw) == 65534);
    CHECK(last_word(register_kind::mb) == 65534);
    CHECK(last_word(register_kind::iw) == 65535);
    CHECK(last_word(register_kind::ib) == 65535);
    // The last word of each area is still a name.
    CHECK(parse_register("MW65534"));
    CHECK(parse_register("IW65535"));
    CHECK(parse_register("MB65534F"));
    CHECK(parse_register("IB65535F"));
}

TEST_CASE("memobus register names format back", "[memobus][names]") {
    CHECK(name_of({register_kind::mw, 100, 0}) == "MW00100");
    CHECK(name_of({register_kind::mw, 65534, 0}) == "MW65534");
    CHECK(name_of({register_kind::iw, 10, 0}) == "IW0010");
    CHECK(name_of({register_kind::iw, 65535, 0}) == "IW65535");
    CHECK(name_of({register_kind::mb, 100, 0}) == "MB001000");
    CHECK(name_of({register_kind::mb, 100, 10}) == "MB00100A");
    CHECK(name_of({register_kind::ib, 10, 15}) == "IB0010F");
    // Round trips
    for (const std::string_view n :
         {"MW00000", "MW12345", "IW9999", "IW10000", "MB12345F", "MB000007", "IB00000", "IB65535C"})
        CHECK(name_of(*parse_register(n)) == n);

    std::array<char, 6> small{};
    CHECK(format_register({register_kind::mw, 1, 0}, small).error() == errc::buffer_too_small);
    std::array<char, max_register_name> buf{};
    CHECK(format_register({register_kind::mw, 65535, 0}, buf).error() == errc::invalid_argument);
    CHECK(format_register({register_kind::mb, 1, 16}, buf).error() == errc::invalid_argument);
    CHECK(format_register({register_kind::iw, 1, 3}, buf).error() == errc::invalid_argument);
}
