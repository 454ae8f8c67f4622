#include <catch2/catch.hpp>

#include "ferrule/core/error.hpp"
#include "ferrule/core/serial_format.hpp"

using namespace std::chrono_literals;

TEST_CASE("serial_format bits per character and character time", "[core][serial]") {
    const ferrule::serial_format f8e1{9600, 8, ferrule::parity::even, 1};
    CHECK(f8e1.bits_per_char() == 11);
    // 11 bits / 9600 baud = 1145833.33 ns, rounded up.
    CHECK(f8e1.char_time() == 1'145'834ns);
    // n characters computed exactly, rounded once: 10 chars = 11458333.3 ns.
    CHECK(f8e1.chars_time(10) == 11'458'334ns);
    const ferrule::serial_format f8n1{115200, 8, ferrule::parity::none, 1};
    CHECK(f8n1.bits_per_char() == 10);
    CHECK(f8n1.chars_time(1152) == 100ms);
    const ferrule::serial_format f7e1{19200, 7, ferrule::parity::even, 1};
    CHECK(f7e1.bits_per_char() == 10);
}

TEST_CASE("serial_format parses 8E1-style specs and rejects bad ones", "[core][serial]") {
    auto f = ferrule::serial_format::parse("7E1", 19200);
    REQUIRE(f);
    CHECK(f->data_bits == 7);
    CHECK(f->parity == ferrule::parity::even);
    CHECK(f->stop_bits == 1);
    CHECK(f->baud == 19200);
    auto g = ferrule::serial_format::parse("8n2");
    REQUIRE(g);
    CHECK(g->parity == ferrule::parity::none);
    CHECK(g->stop_bits == 2);
    CHECK(ferrule::serial_format::parse("9E1").error() == ferrule::errc::invalid_argument);
    CHECK(ferrule::serial_format::parse("8X1").error() == ferrule::errc::invalid_argument);
    CHECK(ferrule::serial_format::parse("8E3").error() == ferrule::errc::invalid_argument);
    CHECK(ferrule::serial_format::parse("8E").error() == ferrule::errc::invalid_argument);
    CHECK(ferrule::serial_format::parse("8E1", 0).error() == ferrule::errc::invalid_argument);
}

TEST_CASE("ferrule::errc codes carry readable messages", "[core][error]") {
    std::error_code ec = ferrule::errc::timeout;
    CHECK(std::string(ec.category().name()) == "ferrule");
    CHECK(ec.message() == "no reply before the response timeout");
    CHECK(ec == ferrule::errc::timeout);
    CHECK(ec != ferrule::errc::bad_checksum);
    for (int e = 1; e <= static_cast<int>(ferrule::errc::out_of_range); ++e)
        CHECK(ferrule::make_error_code(static_cast<ferrule::errc>(e)).message() !=
              "unknown ferrule error");
}
