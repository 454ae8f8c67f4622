#include <catch2/catch.hpp>

#include <cerrno>
#include <cstring>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/dimetix/error.hpp"
#include "ferrule/lecom/error.hpp"
#include "ferrule/memobus/error.hpp"
#include "ferrule/modbus/error.hpp"
#include "ferrule/movilink/error.hpp"
#include "ferrule/profibus/error.hpp"

using ferrule::errc;
using ferrule::error;

namespace dx = ferrule::dimetix;
namespace lc = ferrule::lecom;
namespace mm = ferrule::memobus;
namespace mb = ferrule::modbus;
namespace ml = ferrule::movilink;
namespace pb = ferrule::profibus;

// What firmware relies on: a literal, trivially copyable value of two words whose texts are
// there at compile time.
static_assert(std::is_trivially_copyable_v<error>);
static_assert(sizeof(error) <= 2 * sizeof(void*));
static_assert(!error());
static_assert(error(errc::timeout));
static_assert(error(errc::timeout) == errc::timeout);
static_assert(errc::timeout == error(errc::timeout));
static_assert(error(errc::timeout) != errc::malformed);
static_assert(error(errc::timeout).value() == 1);
static_assert(error(0, ferrule::errc_domain) == error()); // 0 is "no error" in every domain
static_assert(std::string_view(error(errc::bad_checksum).message()) == "checksum mismatch");
static_assert(std::string_view(error(errc::bad_checksum).name()) == "ferrule");
static_assert(std::string_view(error(ml::device_errc::read_only).message()) == "read access only");
static_assert(error(mb::device_errc::illegal_data_address).domain() == &mb::device_domain);

namespace {
// Sessions keep their errors as ferrule::error, so they can be constant-initialised.
constinit error kept_at_compile_time;

template <class E>
void check_domain(E e, const ferrule::error_domain& domain, int value) {
    STATIC_REQUIRE(ferrule::is_error_enum_v<E>);
    const error err = e;
    CHECK(err == e);
    CHECK(e == err);
    CHECK(err.domain() == &domain);
    CHECK(err.value() == value);
    // Same value, other domain: a different error.
    const auto& other = &domain == &ferrule::errc_domain ? lc::device_domain : ferrule::errc_domain;
    CHECK(err != error(value, other));
    CHECK(err == error(value, domain));
}

// The std::error_code of `err`: category name and message text as the CLI prints them.
void check_bridge(error err, const char* name, const std::string& message) {
    const std::error_code ec = err;
    CHECK(ec.value() == err.value());
    CHECK(std::string(ec.category().name()) == name);
    CHECK(ec.message() == message);
    CHECK(ferrule::from_error_code(ec) == err); // round trip
}
} // namespace

TEST_CASE("error compares with errc and with every protocol's device_errc", "[core][error]") {
    CHECK_FALSE(kept_at_compile_time);
    check_domain(errc::unexpected_type, ferrule::errc_domain, 5);
    check_domain(ml::device_errc::read_only, ml::device_domain,
                 static_cast<int>(ml::error_data(8, 0, 0x12)));
    check_domain(dx::device_errc::signal_too_low, dx::device_domain, 255);
    check_domain(lc::device_errc::write_refused, lc::device_domain, 3);
    check_domain(mb::device_errc::illegal_data_address, mb::device_domain, 2);
    check_domain(pb::device_errc::no_resource, pb::device_domain,
                 static_cast<int>(pb::response_fn::no_resource));
    check_domain(mm::device_errc::address_error, mm::device_domain, 2);

    // The device errors the decoders make from the wire are the enums' errors.
    CHECK(ml::make_device_error(ml::error_data(8, 0, 0x12)) == ml::device_errc::read_only);
    CHECK(dx::make_device_error(255) == dx::device_errc::signal_too_low);
    CHECK(mb::make_device_error(2) == mb::device_errc::illegal_data_address);
    CHECK(mm::make_device_error(2) == mm::device_errc::address_error);
    CHECK(pb::response_error(pb::response_fn::no_resource) == pb::device_errc::no_resource);
    // Code 0 names no exception: a reply carrying it is malformed, not a success.
    CHECK(mb::make_device_error(0) == errc::malformed);
    CHECK(mm::make_device_error(0) == errc::malformed);
}

TEST_CASE("error converts to std::error_code with today's names and texts", "[core][error]") {
    check_bridge(errc::timeout, "ferrule", "no reply before the response timeout");
    check_bridge(errc::fault_latched, "ferrule",
                 "fault latched after repeated failures; reset required");
    check_bridge(ml::device_errc::read_only, "movilink",
                 "drive error class 8 (other), code 0, additional code 0x0012: read access only");
    // A compound MOVILINK reply: class 6 (access) code 8, a special return code.
    check_bridge(ml::make_device_error(ml::error_data(6, 8, 0)), "movilink",
                 "drive error class 6 (access), code 8, additional code 0x0000: data length is "
                 "not 4 bytes");
    check_bridge(ml::make_device_error(ml::error_data(3, 17, 0x1A)), "movilink",
                 "drive error class 3 (definition), code 17, additional code 0x001A: parameter "
                 "access via RS-485 diagnostic interface only");
    check_bridge(dx::make_device_error(255), "dimetix",
                 "@E255: received signal too low or distance not in range: use a more "
                 "reflective target");
    check_bridge(dx::make_device_error(999), "dimetix",
                 "@E999: error code not documented for the D-Series");
    check_bridge(lc::device_errc::code_does_not_exist, "lecom", "the drive has no such code");
    check_bridge(mb::device_errc::server_device_busy, "modbus", "server device busy; retry later");
    check_bridge(pb::device_errc::master_lock, "profibus",
                 "slave: locked to another master (Master_Lock)");
    check_bridge(mm::device_errc::count_error, "memobus", "controller: number of data items error");

    // One category per domain: std::error_code compares categories by address.
    const std::error_code a = error(errc::busy);
    const std::error_code b = ferrule::make_error_code(errc::busy);
    CHECK(&a.category() == &b.category());
    CHECK(&a.category() == &ferrule::category_of(ferrule::errc_domain));
    CHECK(&std::error_code(error(mb::device_errc::acknowledge)).category() ==
          &mb::device_category());

    // std::error_code compares with the enums, as tests and the CLI do.
    CHECK(a == errc::busy);
    CHECK(std::error_code(error(mb::device_errc::acknowledge)) == mb::device_errc::acknowledge);
    CHECK(std::error_code(error(mb::device_errc::illegal_data_address)) !=
          errc::unexpected_type); // value 2 in both, other categories
    CHECK(std::error_code(error()) == std::error_code());
}

TEST_CASE("error keeps errno values with the system's texts", "[core][error]") {
    const std::error_code os = std::make_error_code(std::errc::io_error);
    const error kept = ferrule::from_error_code(os);
    REQUIRE(kept.domain() == &ferrule::system_domain);
    CHECK(kept.value() == EIO);
    CHECK(std::string(kept.message()) == std::strerror(EIO));
    const std::error_code back = kept;
    CHECK(&back.category() == &std::system_category());
    CHECK(back == std::errc::io_error);
    CHECK(back.message() == os.message());
    CHECK_FALSE(ferrule::from_error_code(std::error_code()));
}

TEST_CASE("error formats its full text into a caller's buffer", "[core][error]") {
    char buf[96];
    const error e = ml::make_device_error(ml::error_data(8, 0, 0x10));
    const std::size_t n = e.format(buf, sizeof buf);
    CHECK(std::string(buf, n) ==
          "drive error class 8 (other), code 0, additional code 0x0010: invalid parameter index");
    // Cut to the buffer, still NUL-terminated.
    char small[8];
    CHECK(e.format(small, sizeof small) == 7);
    CHECK(std::string(small) == "drive e");
    // Without a formatter: message().
    CHECK(error(errc::malformed).format(buf, sizeof buf) == std::strlen("malformed telegram"));
    CHECK(std::string(buf) == "malformed telegram");
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
