// The error codes of an Extended MEMOBUS error response (SFC | 0x80, §3.5) as
// ferrule::error values of memobus::device_domain.
#pragma once

#include <cstdint>

#include "ferrule/core/error.hpp"

namespace ferrule::memobus {

enum class device_errc : int {
    sfc_error = 0x01,           // function (SFC) not supported
    address_error = 0x02,       // reference address out of range
    count_error = 0x03,         // number of data items out of range (or write not allowed)
    register_type_error = 0x40, // MFC 0x43
    data_type_error = 0x41,     // MFC 0x43
    local_register_type_error = 0x42,
};

struct device_domain_t {
    static constexpr const char* message(int ev) noexcept {
        switch (static_cast<device_errc>(ev)) {
        case device_errc::sfc_error: return "controller: function (SFC) error";
        case device_errc::address_error: return "controller: reference address error";
        case device_errc::count_error: return "controller: number of data items error";
        case device_errc::register_type_error: return "controller: register type error";
        case device_errc::data_type_error: return "controller: data type error";
        case device_errc::local_register_type_error:
            return "controller: local station register type error";
        }
        return "controller: unknown MEMOBUS error code";
    }
};

inline constexpr error_domain device_domain{"memobus", &device_domain_t::message};

constexpr error make_error(device_errc e) noexcept {
    return {static_cast<int>(e), device_domain};
}

// The error for the error code of an error response (§3.5). No code is 0, and an
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

} // namespace ferrule::memobus

template <>
struct ferrule::is_error_enum<ferrule::memobus::device_errc> : std::true_type {};
template <>
struct std::is_error_code_enum<ferrule::memobus::device_errc> : std::true_type {};
