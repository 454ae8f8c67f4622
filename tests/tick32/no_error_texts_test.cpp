// The firmware's build of the errors: FERRULE_NO_ERROR_TEXTS (set for this binary, as for the
// firmware examples) keeps values, domains and comparisons, and leaves every text out.
#include <catch2/catch.hpp>

#include "ferrule/dimetix/error.hpp"
#include "ferrule/modbus/error.hpp"
#include "ferrule/movilink/error.hpp"

#if !defined(FERRULE_NO_ERROR_TEXTS)
#error "this test is built with FERRULE_NO_ERROR_TEXTS"
#endif

TEST_CASE("without error texts a domain keeps its name and no text function") {
    STATIC_REQUIRE(ferrule::errc_domain.message == nullptr);
    STATIC_REQUIRE(ferrule::movilink::device_domain.message == nullptr);
    STATIC_REQUIRE(ferrule::movilink::device_domain.format == nullptr);
    STATIC_REQUIRE(ferrule::dimetix::device_domain.format == nullptr);
    constexpr ferrule::error timeout = ferrule::errc::timeout;
    STATIC_REQUIRE(timeout == ferrule::errc::timeout);
    STATIC_REQUIRE(timeout.value() == 1);
    CHECK(std::string(timeout.message()) == "ferrule");
    const ferrule::error illegal = ferrule::modbus::device_errc::illegal_data_address;
    CHECK(illegal == ferrule::modbus::device_errc::illegal_data_address);
    CHECK(illegal.domain() == &ferrule::modbus::device_domain);
    CHECK(std::string(illegal.message()) == "modbus");
    char buf[16];
    CHECK(ferrule::error(ferrule::movilink::device_errc::read_only).format(buf, sizeof buf) == 8);
    CHECK(std::string(buf) == "movilink");
}
