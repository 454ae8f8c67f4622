// What a LECOM drive answers instead of a value or an ACK, as std::error_code values of
// lecom::device_category(), so callers can tell them apart from transport errors
// (ferrule::errc: timeout = no reply, bad_checksum = bad BCC from the drive).
#pragma once

#include <string>
#include <system_error>

namespace ferrule::lecom {

enum class device_errc {
    code_does_not_exist = 1, // STX C1 C2 EOT, or the 4900's bare EOT (S1 p.8-21)
    checksum_fault = 2,      // STX C1 C2 ? ETX BCC, or the 4900's bare NAK to RECEIVE
    write_refused = 3,       // NAK to SEND: parity/BCC, unknown code, range or access (S1 p.8-20)
};

class device_category_t final : public std::error_category {
public:
    const char* name() const noexcept override { return "lecom"; }
    std::string message(int ev) const override { return describe(ev); }

    static const char* describe(int ev) noexcept {
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

inline const std::error_category& device_category() noexcept {
    static const device_category_t instance;
    return instance;
}

inline std::error_code make_error_code(device_errc e) noexcept {
    return {static_cast<int>(e), device_category()};
}

} // namespace ferrule::lecom

template <>
struct std::is_error_code_enum<ferrule::lecom::device_errc> : std::true_type {};
