// The error codes of an Extended MEMOBUS error response (SFC | 0x80, §3.5) as
// std::error_code values in memobus::device_category().
#pragma once

#include <string>
#include <system_error>

namespace ferrule::memobus {

enum class device_errc : int {
    sfc_error = 0x01,           // function (SFC) not supported
    address_error = 0x02,       // reference address out of range
    count_error = 0x03,         // number of data items out of range (or write not allowed)
    register_type_error = 0x40, // MFC 0x43
    data_type_error = 0x41,     // MFC 0x43
    local_register_type_error = 0x42,
};

class device_category_t final : public std::error_category {
public:
    const char* name() const noexcept override { return "memobus"; }
    std::string message(int ev) const override { return describe(static_cast<device_errc>(ev)); }

    static const char* describe(device_errc e) noexcept {
        switch (e) {
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

inline const std::error_category& device_category() noexcept {
    static const device_category_t instance;
    return instance;
}

inline std::error_code make_error_code(device_errc e) noexcept {
    return {static_cast<int>(e), device_category()};
}

} // namespace ferrule::memobus

template <>
struct std::is_error_code_enum<ferrule::memobus::device_errc> : std::true_type {};
