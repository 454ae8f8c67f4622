// Modbus exception responses (AP §7) as ferrule::error values of modbus::device_domain,
// so callers can tell a server's refusal from a transport error (ferrule::errc: timeout = no
// reply, bad_checksum = CRC error). The value is the exception code as the server sent it.
#pragma once

#include <cstdint>

#include "ferrule/core/error.hpp"
#include "ferrule/modbus/constants.hpp"

namespace ferrule::modbus {

// The device error enum under the name every protocol gives it: the exception code itself
// (AP §7), whose values are the bytes a server sends, so the wire and the error are one enum.
using device_errc = exception_code;

struct device_domain_t {
    static constexpr const char* message(int ev) noexcept {
        switch (static_cast<device_errc>(ev)) {
        case device_errc::illegal_function:
            return "illegal function: the server does not support this function code";
        case device_errc::illegal_data_address:
            return "illegal data address: the address or address + quantity is out of range";
        case device_errc::illegal_data_value: return "illegal data value in the request";
        case device_errc::server_device_failure:
            return "server device failure while performing the action";
        case device_errc::acknowledge:
            return "acknowledge: request accepted, processing takes long";
        case device_errc::server_device_busy: return "server device busy; retry later";
        case device_errc::negative_acknowledge:
            return "negative acknowledge: the program function cannot be performed";
        case device_errc::memory_parity_error:
            return "memory parity error in the server's record file";
        case device_errc::gateway_path_unavailable: return "gateway path unavailable";
        case device_errc::gateway_target_failed: return "gateway target device failed to respond";
        }
        return "unknown Modbus exception code";
    }
};

inline constexpr error_domain device_domain{"modbus", &device_domain_t::message};

constexpr error make_error(device_errc e) noexcept {
    return {static_cast<int>(e), device_domain};
}

// The error for the exception code of an exception response (AP §7). No code is 0, and an
// error of value 0 would read as "no error": a 0 there makes the reply malformed.
constexpr error make_device_error(std::uint8_t code) noexcept {
    if (code == 0) return errc::malformed;
    return {code, device_domain};
}

// Host bridge: device_domain's std::error_category.
inline const std::error_category& device_category() {
    return category_of(device_domain);
}
inline std::error_code make_error_code(device_errc e) noexcept {
    return make_error(e);
}

} // namespace ferrule::modbus

template <>
struct ferrule::is_error_enum<ferrule::modbus::device_errc> : std::true_type {};
template <>
struct std::is_error_code_enum<ferrule::modbus::device_errc> : std::true_type {};
