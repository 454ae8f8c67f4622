#include <catch2/catch.hpp>

#include <system_error>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/modbus/error.hpp"

using ferrule::errc;
using ferrule::stored_error;

namespace {
// Sessions keep their errors in stored_error so that they can be constant-initialised.
constinit stored_error kept_at_compile_time;
} // namespace

TEST_CASE("stored_error gives back the error_code it was given", "[core][error]") {
    CHECK_FALSE(kept_at_compile_time);
    CHECK(std::error_code(kept_at_compile_time) == std::error_code());

    const stored_error timeout = errc::timeout;
    REQUIRE(timeout);
    CHECK(std::error_code(timeout) == errc::timeout);
    CHECK(&std::error_code(timeout).category() == &ferrule::errc_category());

    const stored_error exception = ferrule::modbus::device_errc::illegal_data_address;
    CHECK(std::error_code(exception) == ferrule::modbus::device_errc::illegal_data_address);
    CHECK(std::error_code(exception) != errc::unexpected_type); // same value 2, other category

    const std::error_code os = std::make_error_code(std::errc::io_error);
    CHECK(std::error_code(stored_error(os)) == os);

    // A zero value is "no error" in any category: it is kept as empty.
    CHECK_FALSE(stored_error(std::error_code(0, ferrule::errc_category())));
}

TEST_CASE("result carries a value or an error", "[core][error]") {
    const ferrule::result<int> ok = 5;
    REQUIRE(ok);
    CHECK(*ok == 5);
    CHECK_FALSE(ok.error());
    const ferrule::result<int> bad = errc::malformed;
    CHECK_FALSE(bad);
    CHECK(bad.error() == errc::malformed);
    CHECK(bad.value_or(7) == 7);
}

TEST_CASE("before() orders time points like operator<", "[core][time]") {
    using ferrule::before;
    using ferrule::earliest;
    using ferrule::time_point;
    const time_point a{std::chrono::nanoseconds(-5)};
    const time_point b{std::chrono::nanoseconds(3)};
    for (const time_point x : {a, b, time_point::min(), ferrule::never})
        for (const time_point y : {a, b, time_point::min(), ferrule::never}) {
            CHECK(before(x, y) == (x < y));
            CHECK(earliest(x, y) == std::min(x, y));
        }
}
