// What a DP slave answers instead of data, as ferrule::error values of
// profibus::device_domain, so callers can tell a slave's refusal from a transport error
// (ferrule::errc: timeout = no reply, bad_checksum = FCS error). Values:
//   * the response function codes UE, RR, RS, NR (FC bits 3…0, §B.3) as the slave sent them;
//   * the verdicts of a Slave_Diag after the start-up sequence of §B.6 (Prm_Fault, Cfg_Fault,
//     locked to another master, still not ready), above the FC range.
#pragma once

#include "ferrule/core/error.hpp"
#include "ferrule/profibus/constants.hpp"

namespace ferrule::profibus {

enum class device_errc : int {
    user_error = static_cast<int>(response_fn::user_error),             // UE
    no_resource = static_cast<int>(response_fn::no_resource),           // RR
    sap_not_active = static_cast<int>(response_fn::sap_not_active),     // RS
    no_response_data = static_cast<int>(response_fn::no_response_data), // NR
    prm_fault = 0x100, // Station_Status_1 Prm_Fault after Set_Prm (§B.5)
    cfg_fault = 0x101, // Station_Status_1 Cfg_Fault after Chk_Cfg (§B.5)
    not_ready = 0x102, // not ready for Data_Exchange after the last Slave_Diag poll
    // Diag.Master_Add names another master: the slave is locked to it and ignores this one
    // (the master's own Station_Status_1 Master_Lock, §B.5)
    master_lock = 0x103,
};

struct device_domain_t {
    static constexpr const char* message(int ev) noexcept {
        switch (static_cast<device_errc>(ev)) {
        case device_errc::user_error: return "slave: user error (UE)";
        case device_errc::no_resource: return "slave: no resources for the request (RR)";
        case device_errc::sap_not_active: return "slave: SAP not activated (RS)";
        case device_errc::no_response_data: return "slave: no response data (NR)";
        case device_errc::prm_fault: return "slave: parameter fault (Prm_Fault)";
        case device_errc::cfg_fault: return "slave: configuration fault (Cfg_Fault)";
        case device_errc::not_ready: return "slave: not ready for data exchange";
        case device_errc::master_lock: return "slave: locked to another master (Master_Lock)";
        }
        return "unknown PROFIBUS slave error";
    }
};

inline constexpr error_domain device_domain{"profibus", &device_domain_t::message};

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

// The error a response function code stands for: UE, RR, RS and NR; empty for the others.
constexpr error response_error(response_fn f) noexcept {
    switch (f) {
    case response_fn::user_error:
    case response_fn::no_resource:
    case response_fn::sap_not_active:
    case response_fn::no_response_data: return {static_cast<int>(f), device_domain};
    default: return {};
    }
}

} // namespace ferrule::profibus

template <>
struct ferrule::is_error_enum<ferrule::profibus::device_errc> : std::true_type {};
template <>
struct std::is_error_code_enum<ferrule::profibus::device_errc> : std::true_type {};
