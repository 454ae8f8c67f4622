// Dimetix line framing: line_decoder at CR LF, garbage, overlong lines, resynchronisation.
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
} // namespace

TEST_CASE("the line decoder yields lines at CR LF, split anywhere", "[dimetix][line]") {
    const std::string_view in = "g0?\r\ng0g+00001234\r\n";
    for (std::size_t chunk = 1; chunk <= in.size(); ++chunk) {
        line_decoder d;
        std::vector<std::string> lines;
        for (std::size_t off = 0; off < in.size(); off += chunk) {
            auto part = bytes_of(in.substr(off, chunk));
            while (!part.empty()) {
                const auto s = d.feed(part);
                REQUIRE(s.consumed >= 1);
                part = part.subspan(s.consumed);
                REQUIRE(s.what != line_decoder::status::error);
                if (s.what == line_decoder::status::line)
                    lines.emplace_back(d.line().begin(), d.line().end());
            }
        }
        CHECK(lines == std::vector<std::string>{"g0?", "g0g+00001234"});
        CHECK_FALSE(d.in_line());
    }
}

TEST_CASE("garbage then a good line: one error, then the line", "[dimetix][line]") {
    line_decoder d;
    auto in = bytes_of("\x13\xff noise\r\ng0g+1\r\nbare\ng0?\r\n\r\n");
    std::vector<std::string> events;
    while (!in.empty()) {
        const auto s = d.feed(in);
        in = in.subspan(s.consumed);
        if (s.what == line_decoder::status::error) {
            CHECK(s.ec == errc::malformed);
            events.emplace_back("error");
        } else if (s.what == line_decoder::status::line) {
            events.emplace_back(d.line().begin(), d.line().end());
        }
    }
    CHECK(events == std::vector<std::string>{"error", "g0g+1", "error", "g0?", "error"});
    CHECK(d.skipped() == 10 + 5 + 2);
}

TEST_CASE("an overlong line is reported once and dropped up to its LF", "[dimetix][line]") {
    line_decoder d;
    std::string overlong(max_line_length + 20, '1');
    overlong += "\r\ng0?\r\n";
    auto in = bytes_of(overlong);
    int errors = 0;
    std::vector<std::string> lines;
    while (!in.empty()) {
        const auto s = d.feed(in);
        in = in.subspan(s.consumed);
        errors += s.what == line_decoder::status::error;
        if (s.what == line_decoder::status::line)
            lines.emplace_back(d.line().begin(), d.line().end());
    }
    CHECK(errors == 1);
    CHECK(lines == std::vector<std::string>{"g0?"});
    CHECK(d.skipped() == max_line_length + 22);
    // The longest line accepted: max_line_length bytes with CR LF.
    line_decoder d2;
    std::string longest = "g0re";
    while (longest.size() < max_line_length - 2) longest += "+0";
    longest.resize(max_line_length - 2);
    CHECK(longest.size() == max_line_length - 2);
    const auto s = d2.feed(bytes_of(longest + "\r\n"));
    CHECK(s.what == line_decoder::status::line);
}
