// Dimetix answers: line framing, parse_reply() on the golden vectors of dimetix.md §8.2,
// and check_answers() deciding whether a line answers the command sent.
#include <catch2/catch.hpp>

#include <string>
#include <string_view>
#include <vector>

#include "ferrule/dimetix/reply.hpp"

using namespace ferrule::dimetix;
using ferrule::errc;

namespace {
std::span<const std::uint8_t> bytes_of(std::string_view s) {
    return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}
reply parsed(std::string_view s) {
    const auto r = parse_reply(bytes_of(s));
    REQUIRE(r);
    return *r;
}
std::error_code parse_error(std::string_view s) {
    return parse_reply(bytes_of(s)).error();
}
} // namespace

TEST_CASE("golden answers parse", "[dimetix][reply]") {
    const reply ack = parsed("g0?\r\n");
    CHECK(ack.kind == reply_kind::startup_or_ack);
    CHECK(ack.id == 0);
    CHECK(ack.count == 0);

    const reply d = parsed("g0g+00001234\r\n");
    CHECK(d.kind == reply_kind::value);
    CHECK(d.mnemonic.view() == "g");
    CHECK(d.count == 1);
    CHECK(d.values[0] == 1234);
    CHECK(parsed("g0g+00012345").values[0] == 12345);
    CHECK(parsed("g0g-00000234").values[0] == -234);
    CHECK(parsed("g0g+00000101").values[0] == 101);
    CHECK(parsed("g0t-00000023").values[0] == -23);

    const reply f300 = parsed("g0g+00000234+008384+254\r\n");
    REQUIRE(f300.count == 3);
    CHECK(f300.values[0] == 234);
    CHECK(f300.values[1] == 8384);
    CHECK(f300.values[2] == 254);

    const reply e = parsed("g0@E255\r\n");
    CHECK(e.kind == reply_kind::error);
    CHECK(e.error_code == 255);
    CHECK(e.buffer_status == -1);
    CHECK(parsed("g0@E203").error_code == 203);

    const reply q = parsed("g0q+00012345+1\r\n");
    CHECK(q.mnemonic.view() == "q");
    CHECK(q.values[0] == 12345);
    CHECK(q.buffer_status == 1);

    const reply dg = parsed("g0dg+084+07");
    CHECK(dg.values[0] == d_series_generation);
    CHECK(dg.values[1] == 7);
    CHECK(parsed("g0dt+0401").values[0] == d_series_device_type);
}

TEST_CASE("every answer form parses", "[dimetix][reply]") {
    const reply s = parsed("g0s?");
    CHECK(s.kind == reply_kind::set_ack);
    CHECK(s.mnemonic.view() == "s");
    CHECK(parsed("g12DI1?").mnemonic.view() == "DI1");
    CHECK(parsed("g12DI1?").id == 12);

    const reply afi = parsed("g3afi+2?"); // set acknowledge with selector (S1 §8.4.5)
    CHECK(afi.kind == reply_kind::set_ack);
    CHECK(afi.count == 1);
    CHECK(afi.values[0] == 2);

    const reply re = parsed("g0re+255+200+000");
    CHECK(re.kind == reply_kind::value);
    CHECK(re.count == 3);
    CHECK(re.values[0] == 255);
    CHECK(re.values[2] == 0);

    const reply qe = parsed("g0@E210+0"); // sNq error with buffer status (S1 §8.2.6)
    CHECK(qe.kind == reply_kind::error);
    CHECK(qe.error_code == 210);
    CHECK(qe.buffer_status == 0);

    const reply f301 = parsed("g99g+00000234+008384+254+000500");
    CHECK(f301.id == 99);
    CHECK(f301.count == 4);
    CHECK(f301.values[3] == 500);

    CHECK(parsed("g0v+00000000+00100000").values[1] == 100000);
    CHECK(parsed("g0sv+04100121").values[0] == 4100121);
}

TEST_CASE("values are read by separators, not by columns", "[dimetix][reply]") {
    CHECK(parsed("g0g+22").values[0] == 22); // the PSI simulator's unpadded answer
    CHECK(parsed("g0g+0").values[0] == 0);
    const reply r = parsed("g0g+1-2+3");
    REQUIRE(r.count == 3);
    CHECK(r.values[1] == -2);
    CHECK(parsed("g0uof-2147483648").values[0] == -2147483647 - 1);
    CHECK(parsed("g0uof+0000000002147483647").values[0] == 2147483647);
    CHECK(parsed("g0g+12345").values[0] == parsed("g0g+00012345").values[0]);
}

TEST_CASE("malformed answers are refused, not guessed", "[dimetix][reply]") {
    for (const char* bad : {"",
                            "g",
                            "g0",
                            "x0g+1",
                            "G0g+1",
                            "g?",
                            "gg+1",
                            "g0g",
                            "g0g+",
                            "g0g+1+",
                            "g0g++1",
                            "g0g+1a",
                            "g0g 1",
                            "g0@E",
                            "g0@E0",
                            "g0@E255x",
                            "g0@E255+3",
                            "g0@E255+12",
                            "g0g@E255",
                            "g0g+2147483648",
                            "g0g-2147483649",
                            "g0?x",
                            "g0??",
                            "g0toolong+1",
                            "g1+5",
                            "g13+5",
                            "g0q+5",
                            "g0q+5+3",
                            "g0\r\n\r\n"})
        CHECK(parse_error(bad) == errc::malformed);
}

TEST_CASE("more values than a reply holds are kept in order and flagged", "[dimetix][reply]") {
    const reply r = parsed("g0re+1+2+3+4+5+6+7+8+9+10");
    CHECK(r.count == reply::max_values);
    CHECK(r.truncated);
    CHECK(r.values[7] == 8);
    CHECK_FALSE(parsed("g0re+1+2+3+4+5+6+7+8").truncated);
}

TEST_CASE("a value answer with a 2-digit head is ID and DO number", "[dimetix][reply]") {
    // g11+… has no mnemonic if 11 were the ID: it is ID 1, DO1 hysteresis (S1 §8.3.7).
    const reply r = parsed("g11+00020050+00019950");
    CHECK(r.id == 1);
    CHECK(r.mnemonic.view() == "1");
    CHECK(r.values[0] == 20050);
    const reply r2 = parsed("g122+5+6"); // ID 12, DO2
    CHECK(r2.id == 12);
    CHECK(r2.mnemonic.view() == "2");
}

TEST_CASE("the g11? clash is resolved by the command sent", "[dimetix][reply]") {
    const reply r = parsed("g11?");
    CHECK(r.id == 11);
    CHECK(r.kind == reply_kind::startup_or_ack);
    const command do1_set = *set(1, "1", std::array{20050, 19950}); // s11+20050+19950
    const command stop11 = stop_clear(11);                          // s11c
    const command stop1 = stop_clear(1);
    CHECK_FALSE(check_answers(do1_set, r));
    CHECK_FALSE(check_answers(stop11, r));
    CHECK(check_answers(stop1, r) == errc::unexpected_address);
    const reply as_do1 = answered(do1_set, r);
    CHECK(as_do1.id == 1);
    CHECK(as_do1.kind == reply_kind::set_ack);
    CHECK(as_do1.mnemonic.view() == "1");
    // ID 0's DO1 acknowledge reads as "g01?".
    CHECK_FALSE(check_answers(*set(0, "1", std::array{1, 2}), parsed("g01?")));
    CHECK_FALSE(check_answers(stop_clear(1), parsed("g01?"))); // leading zero tolerated
    // The get answer of ID 1's DO1.
    CHECK_FALSE(check_answers(*get(1, "1"), parsed("g11+00020050+00019950")));
    CHECK(check_answers(*get(11, "1"), parsed("g11+00020050+00019950")) ==
          errc::unexpected_address);
}

TEST_CASE("check_answers accepts the answer and nothing else", "[dimetix][reply]") {
    CHECK_FALSE(check_answers(distance(0), parsed("g0g+00001234")));
    CHECK_FALSE(check_answers(distance(3), parsed("g03g+00001234"))); // leading zero
    CHECK(check_answers(distance(0), parsed("g1g+00001234")) == errc::unexpected_address);
    CHECK(check_answers(distance(0), parsed("g0?")) == errc::unexpected_type); // startup
    CHECK(check_answers(distance(0), parsed("g0h+00001234")) == errc::unexpected_type);
    CHECK(check_answers(stop_clear(0), parsed("g0h+00001234")) == errc::unexpected_type);
    CHECK_FALSE(check_answers(stop_clear(0), parsed("g0?")));
    CHECK_FALSE(check_answers(save_configuration(0), parsed("g0s?")));
    CHECK(check_answers(save_configuration(0), parsed("g0?")) == errc::unexpected_type);
    CHECK_FALSE(check_answers(*set(0, "uo", std::array{300}), parsed("g0uo?")));
    CHECK_FALSE(check_answers(*set(0, "afi", std::array{1, 5000}), parsed("g0afi+1?")));
    CHECK(check_answers(*set(0, "afi", std::array{1, 5000}), parsed("g0afi+2?")) ==
          errc::unexpected_type);
    CHECK_FALSE(check_answers(*get(0, "ot"), parsed("g0ot+1?"))); // as printed in S1 §8.3.6
    CHECK_FALSE(check_answers(*get(0, "ot"), parsed("g0ot+1")));
    CHECK(check_answers(*get(0, "ot"), parsed("g0ot?")) == errc::unexpected_type);
    CHECK_FALSE(check_answers(generation(), parsed("g7dg+084+07")));
    CHECK(check_answers(generation(), parsed("g7dt+0401")) == errc::unexpected_type);
    // Unknown mnemonics follow the set/get convention (S1 §8.1.4).
    CHECK_FALSE(check_answers(make_command(3, "eg", 100), parsed("g3eg?")));
}

TEST_CASE("an error answer is a device error of the sensor asked", "[dimetix][reply]") {
    const std::error_code ec = check_answers(distance(0), parsed("g0@E255"));
    CHECK(ec == make_device_error(255));
    CHECK(ec.category() == device_category());
    CHECK(std::string(ec.category().name()) == "dimetix");
    CHECK(ec.message().find("signal too low") != std::string::npos);
    CHECK(check_answers(distance(0), parsed("g1@E255")) == errc::unexpected_address);
    CHECK(check_answers(generation(), parsed("g4@E203")) == make_device_error(203));
}

TEST_CASE("every documented error code has the manual's text", "[dimetix][error]") {
    for (int code : {0,   200, 203, 210, 211, 212, 220, 230, 233, 234, 236, 252, 253,
                     255, 256, 257, 258, 259, 260, 261, 262, 284, 290, 400, 401, 402})
        CHECK(std::string(device_domain_t::message(code)).find("not documented") ==
              std::string::npos);
    for (int code : {231, 232, 254, 263, 264, 330, 331, 360, 361})
        CHECK(std::string(device_domain_t::message(code)).rfind("older generations", 0) == 0);
    CHECK(std::error_code(make_device_error(999)).message() ==
          "@E999: error code not documented for the D-Series");
    CHECK(std::error_code(make_device_error(212)).message().rfind("@E212: ", 0) == 0);
}

TEST_CASE("measurement_of reads the user output formats", "[dimetix][reply]") {
    const auto m0 = measurement_of(parsed("g0g+00001234"));
    REQUIRE(m0);
    CHECK(m0->distance == 1234);
    CHECK(m0->fields == 1);
    const auto m301 = measurement_of(parsed("g0g+00000234+008384+254+000500"));
    REQUIRE(m301);
    CHECK(m301->signal == 8384);
    CHECK(m301->temperature == 254);
    CHECK(m301->speed == 500);
    CHECK(m301->fields == 4);
    const auto q = measurement_of(parsed("g0q+00000100+2"));
    REQUIRE(q);
    CHECK(q->distance == 100);
    CHECK(q->fields == 1);
    CHECK(measurement_of(parsed("g0g+1+2")).error() == errc::malformed);
    CHECK(measurement_of(parsed("g0t+1")).error() == errc::unexpected_type);
}

TEST_CASE("the classify clash needs a DO mnemonic, not any one-letter command",
          "[dimetix][reply]") {
    // g51? is ID 51's acknowledge: 51 is not 0 * 10 + ('c' - '0').
    CHECK(check_answers(stop_clear(0), parsed("g51?")) == errc::unexpected_address);
    CHECK(check_answers(stop_clear(5), parsed("g51?")) == errc::unexpected_address);
    CHECK_FALSE(check_answers(*set(5, "1", std::array{1, 2}), parsed("g51?")));
}

namespace {
struct line_read {
    detail::line_is what;
    reply r;
};
line_read read_as(const command& c, std::string_view line) {
    line_read out{};
    out.r.count = 5; // read_answer() starts from a blank reply
    out.what = detail::read_answer(c, detail::expected_answer(c), bytes_of(line), out.r);
    return out;
}
} // namespace

TEST_CASE("the session reads a line as the answer to the command sent", "[dimetix][reply]") {
    using detail::line_is;
    const line_read d = read_as(distance(0), "g0g+00012345");
    REQUIRE(d.what == line_is::answer);
    CHECK(d.r.id == 0);
    CHECK(d.r.id_digits == 1);
    CHECK(d.r.mnemonic.view() == "g");
    CHECK(d.r.kind == reply_kind::value);
    CHECK(d.r.count == 1);
    CHECK(d.r.values[0] == 12345);
    CHECK(d.r.values[1] == 0);
    CHECK(d.r.buffer_status == -1);

    const line_read f300 = read_as(distance(42), "g42g+00000234+008384+254");
    REQUIRE(f300.what == line_is::answer);
    CHECK(f300.r.count == 3);
    CHECK(f300.r.values[2] == 254);

    const line_read ack = read_as(stop_clear(3), "g3?");
    REQUIRE(ack.what == line_is::answer);
    CHECK(ack.r.kind == reply_kind::startup_or_ack);
    CHECK(ack.r.mnemonic.size == 0);

    const line_read q = read_as(read_buffer(0), "g0q+00012000+2");
    REQUIRE(q.what == line_is::answer);
    CHECK(q.r.buffer_status == 2);
    CHECK(q.r.count == 2);

    const line_read s = read_as(*set(0, "uo", std::array{300}), "g0uo?");
    REQUIRE(s.what == line_is::answer);
    CHECK(s.r.kind == reply_kind::set_ack);
    CHECK(s.r.mnemonic.view() == "uo");

    // As the manual prints the get answer of sNot (S1 §8.3.6): a value.
    const line_read ot = read_as(*get(0, "ot"), "g0ot+1?");
    REQUIRE(ot.what == line_is::answer);
    CHECK(ot.r.kind == reply_kind::value);
    CHECK(ot.r.values[0] == 1);
    CHECK(read_as(*get(0, "ot"), "g0ot?").what == line_is::skipped);

    // dt / dg without ID: whichever sensor is on the line answers.
    const line_read dg = read_as(generation(), "g7dg+084+07");
    REQUIRE(dg.what == line_is::answer);
    CHECK(dg.r.id == 7);
    CHECK(dg.r.values[0] == d_series_generation);
}

TEST_CASE("the session matches the ID digits as sent: g11? and g10g", "[dimetix][reply]") {
    using detail::line_is;
    // s11+… is ID 1, DO1; its acknowledge g11? reads like ID 11's (dimetix.md §11.1).
    const command do1 = *set(1, "1", std::array{20050, 19950});
    const line_read a = read_as(do1, "g11?");
    REQUIRE(a.what == line_is::answer);
    CHECK(a.r.id == 1);
    CHECK(a.r.id_digits == 1);
    CHECK(a.r.mnemonic.view() == "1");
    CHECK(a.r.kind == reply_kind::set_ack);
    CHECK(read_as(*set(0, "1", std::array{1, 2}), "g01?").what == line_is::answer);
    CHECK(read_as(stop_clear(11), "g11?").what == line_is::answer);
    CHECK(read_as(stop_clear(1), "g11?").what == line_is::foreign);
    const line_read get_do1 = read_as(*get(1, "1"), "g11+00020050+00019950");
    REQUIRE(get_do1.what == line_is::answer);
    CHECK(get_do1.r.values[1] == 19950);
    CHECK(read_as(*get(1, "2"), "g11+00020050+00019950").what == line_is::foreign);

    // ID 10's answer is not ID 1's, nor the other way round.
    CHECK(read_as(distance(1), "g10g+00001234").what == line_is::foreign);
    CHECK(read_as(distance(10), "g1g+00001234").what == line_is::foreign);
    CHECK(read_as(distance(10), "g10g+00001234").what == line_is::answer);
    CHECK(read_as(distance(1), "g2g+00001234").what == line_is::foreign);
    CHECK(read_as(stop_clear(0), "g51?").what == line_is::foreign);

    // A leading zero of a 1-digit ID is tolerated (dimetix.md §11.2), not of a 2-digit one.
    const line_read zero = read_as(distance(3), "g03g+00001234");
    REQUIRE(zero.what == line_is::answer);
    CHECK(zero.r.id == 3);
    CHECK(zero.r.id_digits == 1);
    CHECK(read_as(stop_clear(1), "g01?").what == line_is::answer);
    CHECK(read_as(distance(0), "g00g+1").what == line_is::answer);
    CHECK(read_as(distance(12), "g012g+1").what == line_is::foreign);
}

TEST_CASE("the session tells errors, echoes and other lines apart", "[dimetix][reply]") {
    using detail::line_is;
    const line_read e = read_as(distance(1), "g1@E255");
    REQUIRE(e.what == line_is::device_error);
    CHECK(e.r.kind == reply_kind::error);
    CHECK(e.r.error_code == 255);
    CHECK(e.r.id == 1);
    CHECK(e.r.count == 0);
    CHECK(read_as(distance(1), "g01@E255").what == line_is::device_error);
    CHECK(read_as(distance(1), "g2@E255").what == line_is::foreign);
    CHECK(read_as(stop_clear(1), "g1@E255").what == line_is::device_error);
    CHECK(read_as(generation(), "g4@E203").what == line_is::device_error);
    const line_read qe = read_as(read_buffer(0), "g0@E210+0");
    REQUIRE(qe.what == line_is::device_error);
    CHECK(qe.r.buffer_status == 0);
    CHECK(read_as(distance(1), "g1@E").what == line_is::malformed);
    CHECK(read_as(distance(1), "g1@E2x").what == line_is::malformed);
    CHECK(read_as(distance(1), "g1@E1000").what == line_is::malformed);

    // afi echoes its selector; another one is not the answer (S1 §8.4.5).
    const command afi = *set(0, "afi", std::array{1, 5000});
    CHECK(read_as(afi, "g0afi+1?").what == line_is::answer);
    CHECK(read_as(afi, "g0afi?").what == line_is::answer);
    CHECK(read_as(afi, "g0afi+2?").what == line_is::skipped);
    CHECK(read_as(afi, "g0afi+1").what == line_is::skipped);
    CHECK(read_as(*set(0, "id", std::array{5}), "g0+5?").what == line_is::skipped);

    // The startup string and queued tracking lines of the ID asked are not its answer.
    CHECK(read_as(distance(0), "g0?").what == line_is::startup);
    CHECK(read_as(distance(0), "g0h+00001000").what == line_is::skipped);
    CHECK(read_as(stop_clear(0), "g0h+00001000").what == line_is::skipped);
    CHECK(read_as(distance(0), "g1?").what == line_is::foreign);
    // Another mnemonic beginning with the one asked is another command's answer.
    CHECK(read_as(*get(0, "v"), "g0vm+1").what == line_is::skipped);

    for (const char* bad : {"", "g", "g0", "x0g+1", "G0g+1", "gg+1", "g0g", "g0g+", "g0g+1x",
                            "g0g++1", "g0g+2147483648", "g0g+1?x"})
        CHECK(read_as(distance(0), bad).what == line_is::malformed);
    CHECK(read_as(read_buffer(0), "g0q+5").what == line_is::malformed); // no buffer status
    CHECK(read_as(stop_clear(0), "g0?x").what == line_is::malformed);
}
