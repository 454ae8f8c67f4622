// One naming rule for what a device answers instead of data: every protocol has
// <protocol>::device_errc, an enum registered with std::error_code in the protocol's
// device_category(), equal to the error_code the protocol makes from the bytes on the wire.
#include <catch2/catch.hpp>

#include <string>
#include <system_error>

#include "ferrule/dimetix/error.hpp"
#include "ferrule/lecom/error.hpp"
#include "ferrule/memobus/error.hpp"
#include "ferrule/modbus/error.hpp"
#include "ferrule/movilink/error.hpp"
#include "ferrule/profibus/error.hpp"

namespace {

// `e` is an error_code enum of `category` and the same error as `from_wire`.
template <class E>
void check_device_errc(E e, const std::error_category& category, std::error_code from_wire) {
    STATIC_REQUIRE(std::is_error_code_enum_v<E>);
    const std::error_code ec = e;
    CHECK(&ec.category() == &category);
    CHECK(ec == from_wire);
    CHECK(ec.message() == from_wire.message());
}

bool starts_with(const std::string& s, const char* prefix) {
    return s.rfind(prefix, 0) == 0;
}

} // namespace

TEST_CASE("every protocol names its device error enum device_errc", "[core][error]") {
    namespace dx = ferrule::dimetix;
    namespace lc = ferrule::lecom;
    namespace mm = ferrule::memobus;
    namespace mb = ferrule::modbus;
    namespace ml = ferrule::movilink;
    namespace pb = ferrule::profibus;

    // MOVILINK: the data word of the error reply, class 8 code 0 additional code 0x12.
    check_device_errc(ml::device_errc::read_only, ml::device_category(),
                      ml::make_device_error(ml::error_data(8, 0, 0x12)));
    CHECK(ml::fields_of(ml::device_errc::read_only).additional == 0x12);
    CHECK(std::error_code(ml::device_errc::read_only).message() ==
          "drive error class 8 (other), code 0, additional code 0x0012: read access only");
    check_device_errc(ml::device_errc::data_length, ml::device_category(),
                      ml::make_device_error(ml::error_data(6, 8, 0)));
    CHECK(std::error_code(ml::device_errc::data_length)
              .message()
              .ends_with("data length is not 4 bytes"));

    // Dimetix: gN@E255.
    check_device_errc(dx::device_errc::signal_too_low, dx::device_category(),
                      dx::make_device_error(255));
    CHECK(starts_with(std::error_code(dx::device_errc::signal_too_low).message(),
                      "@E255: received signal too low"));
    check_device_errc(dx::device_errc::measuring_time_too_long, dx::device_category(),
                      dx::make_device_error(361));

    // LECOM: NAK to SEND.
    check_device_errc(lc::device_errc::write_refused, lc::device_category(),
                      std::error_code(3, lc::device_category()));

    // Modbus: exception code 02 as a client reads it from the response.
    check_device_errc(mb::device_errc::illegal_data_address, mb::device_category(),
                      std::error_code(0x02, mb::device_category()));

    // PROFIBUS: the response function code RR.
    check_device_errc(pb::device_errc::no_resource, pb::device_category(),
                      pb::response_error(pb::response_fn::no_resource));

    // Extended MEMOBUS: error code 02 of an error response.
    check_device_errc(mm::device_errc::address_error, mm::device_category(),
                      std::error_code(0x02, mm::device_category()));
}
