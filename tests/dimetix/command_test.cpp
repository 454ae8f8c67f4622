// Dimetix requests: builders, validation and encode() against the golden vectors of
// dimetix.md §8.1.
#include <catch2/catch.hpp>

#include <array>
#include <string>
#include <string_view>

#include "ferrule/dimetix/command.hpp"

using namespace ferrule::dimetix;
using ferrule::errc;

namespace {
std::string wire(const command& c) {
    std::array<std::uint8_t, max_request_length> out{};
    const auto n = encode(c, out);
    REQUIRE(n);
    return std::string(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(*n));
}
command with(std::uint8_t id, std::string_view m, std::initializer_list<std::int32_t> p) {
    return make_command(id, m, std::span<const std::int32_t>(p.begin(), p.size()));
}
} // namespace

TEST_CASE("golden requests of the manual encode byte for byte", "[dimetix][command]") {
    CHECK(wire(distance(0)) == "s0g\r\n");
    CHECK(wire(with(3, "eg", {100})) == "s3eg+100\r\n"); // S1 §8.1.4 illustrative syntax
    CHECK(wire(*set(0, "vm", std::array{1})) == "s0vm+1\r\n");
    CHECK(wire(*set(0, "v", std::array{0, 100000})) == "s0v+0+100000\r\n");
    CHECK(wire(*set(0, "ve", std::array{0})) == "s0ve+0\r\n");
    CHECK(wire(save_configuration(0)) == "s0s\r\n");
    CHECK(wire(*set(5, "SSI", std::array{29})) == "s5SSI+29\r\n");
    CHECK(wire(*set(0, "ado", std::array{2, 1, 1, 995})) == "s0ado+2+1+1+995\r\n");
    CHECK(wire(*set(0, "2", std::array{-500, -495})) == "s02-500-495\r\n");
    CHECK(wire(*set(0, "afi", std::array{1, 5000})) == "s0afi+1+5000\r\n");
    CHECK(wire(*set(0, "mc", std::array{1})) == "s0mc+1\r\n");
    CHECK(wire(*set(0, "uo", std::array{139})) == "s0uo+139\r\n");
    CHECK(wire(*set(0, "uga", std::array{-1, 1})) == "s0uga-1+1\r\n");
    CHECK(wire(*set(0, "uof", std::array{-10000})) == "s0uof-10000\r\n");
    CHECK(wire(tracking_buffered(0, 500)) == "s0f+500\r\n");
    CHECK(wire(tracking(0, 500)) == "s0h+500\r\n");
    CHECK(wire(signal(0, false)) == "s0m+0\r\n");
    CHECK(wire(read_error_stack(0)) == "s0re\r\n");
}

TEST_CASE("zero padding on request writes the widths code in the wild uses", "[dimetix][command]") {
    command br = set_comm(0, 7);
    br.digits = 2;
    CHECK(wire(br) == "s0br+07\r\n");
    command off = *set(0, "uof", std::array{123});
    off.digits = 8;
    CHECK(wire(off) == "s0uof+00000123\r\n");
    off.params[0] = -123;
    CHECK(wire(off) == "s0uof-00000123\r\n");
}

TEST_CASE("a negative parameter uses '-' as its separator, never '+-' or '++'",
          "[dimetix][command]") {
    for (const std::int32_t v : {-1, -123, -2147483647 - 1}) {
        const std::string s = wire(*set(0, "uof", std::array{v}));
        CHECK(s.find("+-") == std::string::npos);
        CHECK(s.find("++") == std::string::npos);
        CHECK(s.rfind("s0uof-", 0) == 0);
    }
    CHECK(wire(*set(0, "uof", std::array{-2147483647 - 1})) == "s0uof-2147483648\r\n");
    CHECK(wire(*set(0, "uof", std::array{2147483647})) == "s0uof+2147483647\r\n");
    CHECK_FALSE(wire(*set(0, "uof", std::array{-123})) == "s0uof+-123\r\n");
}

TEST_CASE("every builder of the command set writes its documented request", "[dimetix][command]") {
    CHECK(wire(stop_clear(1)) == "s1c\r\n");
    CHECK(wire(tracking(0)) == "s0h\r\n");
    CHECK(wire(read_buffer(12)) == "s12q\r\n");
    CHECK(wire(signal(2, true)) == "s2m+1\r\n");
    CHECK(wire(temperature(0)) == "s0t\r\n");
    CHECK(wire(clear_error_stack(0)) == "s0ce\r\n");
    CHECK(wire(laser_on(0)) == "s0o\r\n");
    CHECK(wire(software_version(0)) == "s0sv\r\n");
    CHECK(wire(serial_number(0)) == "s0sn\r\n");
    CHECK(wire(device_type(7)) == "s7dt\r\n");
    CHECK(wire(device_type()) == "dt\r\n");
    CHECK(wire(generation()) == "dg\r\n");
    CHECK(wire(factory_default(0)) == "s0d\r\n");
    CHECK(wire(set_id(0, 42)) == "s0id+42\r\n");
    CHECK(wire(set_comm(99, 11)) == "s99br+11\r\n");
    CHECK(wire(*get(0, "uo")) == "s0uo\r\n");
    CHECK(wire(*get(0, "afi", std::array{2})) == "s0afi+2\r\n");
    CHECK(wire(*get(3, "DI1")) == "s3DI1\r\n");
    CHECK(wire(*get(0, "SSIe")) == "s0SSIe\r\n");
    CHECK(wire(*get(1, "1")) == "s11\r\n");
}

TEST_CASE("get and set accept only the documented configuration forms", "[dimetix][command]") {
    CHECK(get(0, "xx").error() == errc::invalid_argument);
    CHECK(get(0, "g").error() == errc::invalid_argument);   // measures: use distance()
    CHECK(get(0, "br").error() == errc::invalid_argument);  // set-only (S1 §8.3.1)
    CHECK(get(0, "afi").error() == errc::invalid_argument); // needs its filter number
    CHECK(get(100, "uo").error() == errc::invalid_argument);
    CHECK(set(0, "uo", {}).error() == errc::invalid_argument);
    CHECK(set(0, "v", std::array{1}).error() == errc::invalid_argument);  // needs two
    CHECK(set(0, "vm", std::array{2}).error() == errc::invalid_argument); // 0 or 1
    CHECK(set(0, "br", std::array{3}).error() == errc::invalid_argument); // not a setting
    CHECK(set(0, "ri", std::array{1}).error() == errc::invalid_argument); // case matters
    CHECK(set(0, "RI", std::array{1}).error() == errc::invalid_argument); // read-only
    CHECK(set(0, "h", std::array{10}).error() == errc::invalid_argument); // not configuration
    CHECK(set(0, "br", std::array{7}));
    CHECK(set(0, "id", std::array{99}));
    CHECK(set(0, "ado", std::array{1, 0, 0, 10}));
}

TEST_CASE("validate checks IDs, mnemonics and parameter counts", "[dimetix][command]") {
    CHECK(validate(distance(99)));
    CHECK_FALSE(validate(distance(100)));
    CHECK(validate(generation()));
    CHECK_FALSE(validate(make_command(command::no_id, "g"))); // only dt / dg go without ID
    CHECK_FALSE(validate(set_id(0, 100)));
    CHECK_FALSE(validate(tracking(0, max_sampling_time_ms + 1)));
    CHECK(validate(tracking(0, max_sampling_time_ms)));
    CHECK_FALSE(validate(make_command(0, "m"))); // sNm needs its mode
    CHECK_FALSE(validate(with(0, "m", {2})));
    CHECK_FALSE(validate(make_command(0, "eg")));
}

TEST_CASE("encode refuses what the syntax cannot express", "[dimetix][command]") {
    std::array<std::uint8_t, max_request_length> out{};
    CHECK(encode(distance(100), out).error() == errc::invalid_argument);
    CHECK(encode(make_command(0, ""), out).error() == errc::invalid_argument);
    CHECK(encode(make_command(0, "toolong"), out).error() == errc::invalid_argument);
    CHECK(encode(make_command(0, "g+"), out).error() == errc::invalid_argument);
    std::array<std::uint8_t, 4> small{};
    CHECK(encode(distance(0), small).error() == errc::buffer_too_small);
    std::array<std::uint8_t, 5> exact{};
    CHECK(encode(distance(0), exact).value_or(0) == 5);
    // The longest request fits max_request_length.
    command longest =
        with(99, "SSIe", {-2147483647 - 1, -2147483647 - 1, -2147483647 - 1, -2147483647 - 1});
    CHECK(wire(longest).size() == 3 + 4 + 4 * 11 + 2);
}

TEST_CASE("continuous commands are recognised", "[dimetix][command]") {
    CHECK(is_continuous(tracking(0)));
    CHECK(is_continuous(tracking(0, 100)));
    CHECK(is_continuous(signal(0, true)));
    CHECK_FALSE(is_continuous(signal(0, false)));
    CHECK_FALSE(is_continuous(tracking_buffered(0, 100)));
    CHECK_FALSE(is_continuous(distance(0)));
}

TEST_CASE("parse_request reads requests, resolving s11+ as ID 1 DO1", "[dimetix][command]") {
    auto p = [](std::string_view s) {
        return parse_request(std::span(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()));
    };
    CHECK(*p("s0g\r\n") == distance(0));
    CHECK(*p("s12g") == distance(12));
    CHECK(*p("s11c") == stop_clear(11));
    CHECK(*p("s11+20050+19950") == *set(1, "1", std::array{20050, 19950}));
    CHECK(*p("s21") == *get(2, "1"));
    CHECK(*p("s112-5+6") == *set(11, "2", std::array{-5, 6}));
    CHECK(*p("dg") == generation());
    CHECK(*p("s0uga-1+1") == *set(0, "uga", std::array{-1, 1}));
    CHECK(p("s").error() == errc::malformed);
    CHECK(p("s1").error() == errc::malformed);
    CHECK(p("s0g+").error() == errc::malformed);
    CHECK(p("s0g+1+2+3+4+5").error() == errc::malformed);
    CHECK(p("s0uof+2147483648").error() == errc::malformed);
    CHECK(p("s0g x").error() == errc::malformed);
}
