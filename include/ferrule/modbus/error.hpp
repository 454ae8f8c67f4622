// Modbus exception responses (AP §7) as std::error_code values of modbus::device_category(),
// so callers can tell a server's refusal from a transport error (ferrule::errc: timeout = no
// reply, bad_checksum = CRC error). The value is the exception code as the server sent it.
#pragma once

#include <system_error> // std::string of message(): the category interface needs it

#include "ferrule/modbus/constants.hpp"

namespace ferrule::modbus {

// The device error enum under the name every protocol gives it: the exception code itself
// (AP §7), whose values are the bytes a server sends, so the wire and the error are one enum.
using device_errc = exception_code;

class device_category_t final : public std::error_category {
public:
    const char* name() const noexcept override { return "modbus"; }
    std::string message(int ev) const override { return describe(ev); }

    static const char* describe(int ev) noexcept {
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

inline const std::error_category& device_category() noexcept {
    static const device_category_t instance;
    return instance;
}

inline std::error_code make_error_code(device_errc e) noexcept {
    return {static_cast<int>(e), device_category()};
}

} // namespace ferrule::modbus

template <>
struct std::is_error_code_enum<ferrule::modbus::device_errc> : std::true_type {};
