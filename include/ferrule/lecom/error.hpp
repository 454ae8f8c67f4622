// What a LECOM drive answers instead of a value or an ACK, as ferrule::error values of
// lecom::device_domain, so callers can tell them apart from transport errors
// (ferrule::errc: timeout = no reply, bad_checksum = bad BCC from the drive).
#pragma once

#include "ferrule/core/error.hpp"

namespace ferrule::lecom {

enum class device_errc {
    code_does_not_exist = 1, // STX C1 C2 EOT, or the 4900's bare EOT (S1 p.8-21)
    checksum_fault = 2,      // STX C1 C2 ? ETX BCC, or the 4900's bare NAK to RECEIVE
    write_refused = 3,       // NAK to SEND: parity/BCC, unknown code, range or access (S1 p.8-20)
};

struct device_domain_t {
    static constexpr const char* message(int ev) noexcept {
        switch (static_cast<device_errc>(ev)) {
        case device_errc::code_does_not_exist: return "the drive has no such code";
        case device_errc::checksum_fault:
            return "the drive saw a checksum or parity fault in the request";
        case device_errc::write_refused:
            return "the drive refused the write (NAK: parity or checksum fault, unknown code, "
                   "value out of range, or not writable in this state)";
        }
        return "unknown LECOM reply";
    }
};

inline constexpr error_domain device_domain{"lecom", &device_domain_t::message};

constexpr error make_error(device_errc e) noexcept {
    return {static_cast<int>(e), device_domain};
}

// Host bridge: device_domain's std::error_category.
inline const std::error_category& device_category() {
    return category_of(device_domain);
}
inline std::error_code make_error_code(device_errc e) noexcept {
    return make_error(e);
}

} // namespace ferrule::lecom

template <>
struct ferrule::is_error_enum<ferrule::lecom::device_errc> : std::true_type {};
template <>
struct std::is_error_code_enum<ferrule::lecom::device_errc> : std::true_type {};
