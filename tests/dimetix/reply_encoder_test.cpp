// Dimetix answers written: reply_encoder and encode_reply() on the golden vectors of
// dimetix.md §8.2, and the round trip with parse_reply() for every reply kind.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "ferrule/dimetix/reply.hpp"
#include "ferrule/dimetix/reply_encoder.hpp"

using namespace ferrule::dimetix;
using ferrule::errc;

namespace {
std::span<const std::uint8_t> bytes_of(std::string_view s) {
    return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}
std::string text_of(std::span<const std::uint8_t> b) {
    return {reinterpret_cast<const char*>(b.data()), b.size()};
}
reply parsed(std::string_view s) {
    const auto r = parse_reply(bytes_of(s));
    REQUIRE(r);
    return *r;
}
std::string encoded(const reply& r, std::size_t digits = 1) {
    std::array<std::uint8_t, max_line_length> out{};
    const auto n = encode_reply(r, out, digits);
    REQUIRE(n);
    return text_of({out.data(), *n});
}
void check_same(const reply& a, const reply& b) {
    CHECK(a.id == b.id);
    CHECK(a.id_digits == b.id_digits);
    CHECK(a.kind == b.kind);
    CHECK(a.mnemonic == b.mnemonic);
    CHECK(a.count == b.count);
    CHECK(std::ranges::equal(a.value_span(), b.value_span()));
    CHECK(a.truncated == b.truncated);
    CHECK(a.error_code == b.error_code);
    CHECK(a.buffer_status == b.buffer_status);
}
} // namespace

TEST_CASE("dimetix reply_encoder writes the golden answers field by field",
          "[dimetix][reply_encoder]") {
    reply_encoder e;
    e.begin(0);
    e.put_ack();
    CHECK(text_of(e.finish()) == "g0?\r\n");

    e.begin(0);
    e.put_mnemonic("g");
    e.put_value(1234, 8);
    CHECK(text_of(e.finish()) == "g0g+00001234\r\n");

    e.begin(0);
    e.put_mnemonic("g");
    e.put_value(-234, 8);
    CHECK(text_of(e.finish()) == "g0g-00000234\r\n");

    // User output format 300: distance, signal, temperature (S1 §8.4.1 p.50).
    e.begin(0);
    e.put_mnemonic("g");
    e.put_value(234, 8);
    e.put_value(8384, 6);
    e.put_value(254, 3);
    CHECK(text_of(e.finish()) == "g0g+00000234+008384+254\r\n");

    e.begin(0);
    e.put_error(255);
    CHECK(text_of(e.finish()) == "g0@E255\r\n");

    e.begin(0);
    e.put_mnemonic("q");
    e.put_value(12345, 8);
    e.put_value(1, 1);
    CHECK(text_of(e.finish()) == "g0q+00012345+1\r\n");

    e.begin(0);
    e.put_mnemonic("t");
    e.put_value(-23, 8);
    CHECK(text_of(e.finish()) == "g0t-00000023\r\n");

    e.begin(0);
    e.put_mnemonic("dg");
    e.put_value(d_series_generation, 3);
    e.put_value(7, 2);
    CHECK(text_of(e.finish()) == "g0dg+084+07\r\n");

    e.begin(0);
    e.put_mnemonic("dt");
    e.put_value(d_series_device_type, 4);
    CHECK(text_of(e.finish()) == "g0dt+0401\r\n");

    // Set acknowledge echoing the selector (S1 §8.4.5), a 2-digit ID, an error with buffer
    // status (S1 §8.2.6), and the int32 extremes.
    e.begin(12);
    e.put_mnemonic("afi");
    e.put_value(2, 1);
    e.put_ack();
    CHECK(text_of(e.finish()) == "g12afi+2?\r\n");

    e.begin(3, 2);
    e.put_ack();
    CHECK(text_of(e.finish()) == "g03?\r\n");

    e.begin(0);
    e.put_error(210);
    e.put_value(0, 1);
    CHECK(text_of(e.finish()) == "g0@E210+0\r\n");

    e.begin(0);
    e.put_mnemonic("uof");
    e.put_value(-2147483647 - 1);
    e.put_value(2147483647);
    CHECK(text_of(e.finish()) == "g0uof-2147483648+2147483647\r\n");
    CHECK_FALSE(e.overflowed());
}

TEST_CASE("dimetix reply_encoder keeps CR LF and reports a line beyond max_line_length",
          "[dimetix][reply_encoder]") {
    reply_encoder e;
    e.begin(0);
    e.put_mnemonic("re");
    for (int i = 0; i < 20; ++i) e.put_value(200, 3);
    const std::string line = text_of(e.finish());
    CHECK(e.overflowed());
    REQUIRE(line.size() == max_line_length);
    CHECK(line.substr(line.size() - 2) == "\r\n");
    // begin() starts afresh.
    e.begin(0);
    e.put_ack();
    CHECK(text_of(e.finish()) == "g0?\r\n");
    CHECK_FALSE(e.overflowed());
}

TEST_CASE("dimetix encode_reply gives back the golden lines it parses from",
          "[dimetix][reply_encoder]") {
    // Each line as parse_reply() reads it, written again with the same value width.
    const struct {
        std::string_view line;
        std::size_t digits;
        reply_kind kind;
    } golden[] = {
        {"g0?\r\n", 1, reply_kind::startup_or_ack},
        {"g03?\r\n", 1, reply_kind::startup_or_ack},
        {"g12s?\r\n", 1, reply_kind::set_ack},
        {"g0afi+2?\r\n", 1, reply_kind::set_ack},
        {"g0g+00001234\r\n", 8, reply_kind::value},
        {"g0g+00012345\r\n", 8, reply_kind::value},
        {"g0g-00000234\r\n", 8, reply_kind::value},
        {"g0g+00000101\r\n", 8, reply_kind::value},
        {"g0t-00000023\r\n", 8, reply_kind::value},
        {"g0g+22\r\n", 1, reply_kind::value},
        {"g0re+200+255+000\r\n", 3, reply_kind::value},
        {"g0q+00012345+1\r\n", 8, reply_kind::value},
        {"g11+00020050+00019950\r\n", 8, reply_kind::value}, // ID 1, DO1 (dimetix.md §11.1)
        {"g0@E255\r\n", 1, reply_kind::error},
        {"g0@E203\r\n", 1, reply_kind::error},
        {"g0@E210+2\r\n", 1, reply_kind::error},
    };
    for (const auto& g : golden) {
        INFO(g.line);
        const reply r = parsed(g.line);
        CHECK(r.kind == g.kind);
        CHECK(encoded(r, g.digits) == g.line);
    }
}

TEST_CASE("dimetix parse_reply reads back what encode_reply writes, every reply kind",
          "[dimetix][reply_encoder]") {
    reply ack;
    ack.id = 7;

    reply set_ack;
    set_ack.id = 42;
    set_ack.id_digits = 2;
    set_ack.kind = reply_kind::set_ack;
    set_ack.mnemonic = "ado";
    set_ack.values[0] = 3;
    set_ack.count = 1;

    reply values;
    values.id = 99;
    values.id_digits = 2;
    values.kind = reply_kind::value;
    values.mnemonic = "v";
    for (std::int32_t i = 0; i < static_cast<std::int32_t>(reply::max_values); ++i)
        values.values[static_cast<std::size_t>(i)] = (i % 2 ? -1 : 1) * i * 1000003;
    values.count = reply::max_values;

    reply buffered;
    buffered.kind = reply_kind::value;
    buffered.mnemonic = "q";
    buffered.values[0] = 12345;
    buffered.values[1] = 2;
    buffered.count = 2;
    buffered.buffer_status = 2;

    reply error;
    error.id = 5;
    error.kind = reply_kind::error;
    error.error_code = 999;

    reply error_status = error;
    error_status.error_code = 1;
    error_status.buffer_status = 0;

    for (const reply& r : {ack, set_ack, values, buffered, error, error_status}) {
        for (const std::size_t digits : {std::size_t{1}, std::size_t{8}}) {
            const std::string line = encoded(r, digits);
            INFO(line);
            check_same(parsed(line), r);
        }
    }
}

TEST_CASE("dimetix encode_reply refuses what no line parses to, and a short buffer",
          "[dimetix][reply_encoder]") {
    std::array<std::uint8_t, max_line_length> out{};
    const auto refused = [&](const reply& r) { return encode_reply(r, out).error(); };

    reply r;
    r.id = 100; // beyond max_id
    CHECK(refused(r) == errc::invalid_argument);

    r = {};
    r.mnemonic = "g"; // an acknowledge has none
    CHECK(refused(r) == errc::invalid_argument);

    r = {};
    r.kind = reply_kind::value; // a value needs a mnemonic and a value
    CHECK(refused(r) == errc::invalid_argument);
    r.mnemonic = "g";
    CHECK(refused(r) == errc::invalid_argument);
    r.count = 1;
    r.buffer_status = 1; // only sNq carries it
    CHECK(refused(r) == errc::invalid_argument);

    r = {};
    r.kind = reply_kind::value;
    r.mnemonic = "q";
    r.values[0] = 5;
    r.values[1] = 1;
    r.count = 2;
    r.buffer_status = 2; // not its last value
    CHECK(refused(r) == errc::invalid_argument);

    r = {};
    r.kind = reply_kind::error;
    CHECK(refused(r) == errc::invalid_argument); // code 0
    r.error_code = 1000;
    CHECK(refused(r) == errc::invalid_argument);
    r.error_code = 255;
    r.buffer_status = 3;
    CHECK(refused(r) == errc::invalid_argument);

    r = {};
    r.kind = reply_kind::set_ack;
    r.mnemonic = "a-b"; // not 1..5 letters or digits
    CHECK(refused(r) == errc::invalid_argument);

    // Eight 10-digit values do not fit a line; the buffer given is too small for g0g+1.
    reply many;
    many.kind = reply_kind::value;
    many.mnemonic = "re";
    many.count = reply::max_values;
    CHECK(encode_reply(many, out, 10).error() == errc::buffer_too_small);
    reply g;
    g.kind = reply_kind::value;
    g.mnemonic = "g";
    g.values[0] = 1;
    g.count = 1;
    std::array<std::uint8_t, 6> small{};
    CHECK(encode_reply(g, small).error() == errc::buffer_too_small);
    std::array<std::uint8_t, 7> exact{};
    const auto written = encode_reply(g, exact);
    REQUIRE(written);
    CHECK(*written == 7);
}
