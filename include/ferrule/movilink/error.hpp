// Device errors reported in the MOVILINK parameter channel (status bit set), kept as a
// ferrule::error whose value packs class, code and additional code so nothing the drive
// said is lost. Texts: SC01 §6.2 p.65-66 (MOVIDRIVE) and MTB "additional codes" (MOVITRAC B).
#pragma once

#include <cstddef>
#include <cstdint>

#include "ferrule/core/error.hpp"
#include "ferrule/movilink/param.hpp"

namespace ferrule::movilink {

// Error classes (SC01 p.65, EN 50170 / IEC 61158).
enum class error_class : std::uint8_t {
    vfd_state = 1,
    application_reference = 2,
    definition = 3,
    resource = 4,
    service = 5,
    access = 6,
    object_list = 7,
    other = 8, // drive return codes: see the additional code
};

// The drive's error reply as an error enum. Its value is the parameter channel's data
// word, class << 24 | code << 16 | additional code, so any reply keeps all the drive said;
// named here: class 8 ("other") code 0 with the additional codes of SC01 p.66 (MTB for
// 0x1F-0x29), and the special return codes of classes 5 and 6 (SC01 p.46).
enum class device_errc : std::uint32_t {
    invalid_index = error_data(8, 0, 0x10),
    not_implemented = error_data(8, 0, 0x11),
    read_only = error_data(8, 0, 0x12),
    parameter_lock = error_data(8, 0, 0x13),
    factory_setting_active = error_data(8, 0, 0x14),
    value_too_large = error_data(8, 0, 0x15),
    value_too_small = error_data(8, 0, 0x16),
    option_missing = error_data(8, 0, 0x17),
    system_software = error_data(8, 0, 0x18),
    access_via_x13_only = error_data(8, 0, 0x19),
    access_via_diagnostic_only = error_data(8, 0, 0x1A),
    access_protected = error_data(8, 0, 0x1B),
    controller_inhibit_required = error_data(8, 0, 0x1C),
    invalid_value = error_data(8, 0, 0x1D),
    factory_setting_activated = error_data(8, 0, 0x1E),
    not_saved_in_eeprom = error_data(8, 0, 0x1F),
    output_stage_enabled = error_data(8, 0, 0x20),
    end_of_file = error_data(8, 0, 0x21),
    communication_order = error_data(8, 0, 0x22),
    ipos_stop_required = error_data(8, 0, 0x23),
    autosetup = error_data(8, 0, 0x24),
    encoder_nameplate = error_data(8, 0, 0x25),
    plc_state = error_data(8, 0, 0x29),
    illegal_service = error_data(5, 5, 0),        // service code in the management byte
    internal_communication = error_data(6, 2, 0), // repeat the service
    data_length = error_data(6, 8, 0),            // data length is not 4 bytes
};

constexpr const char* error_class_text(std::uint8_t c) noexcept {
    switch (c) {
    case 1: return "vfd state";
    case 2: return "application reference";
    case 3: return "definition";
    case 4: return "resource";
    case 5: return "service";
    case 6: return "access";
    case 7: return "object list";
    case 8: return "other";
    }
    return "unknown class";
}

constexpr const char* additional_code_text(std::uint16_t a) noexcept {
    switch (a) {
    case 0x00: return "no error";
    case 0x10: return "invalid parameter index";
    case 0x11: return "function/parameter not implemented";
    case 0x12: return "read access only";
    case 0x13: return "parameter lock is active";
    case 0x14: return "factory setting is active";
    case 0x15: return "parameter value too large";
    case 0x16: return "parameter value too small";
    case 0x17: return "option card required for this function/parameter is missing";
    case 0x18: return "error in system software";
    case 0x19: return "parameter access via RS-485 process interface on X13 only";
    case 0x1A: return "parameter access via RS-485 diagnostic interface only";
    case 0x1B: return "parameter has access protection";
    case 0x1C: return "controller inhibit required";
    case 0x1D: return "incorrect parameter value";
    case 0x1E: return "factory setting was activated";
    case 0x1F: return "parameter was not saved in EEPROM";
    case 0x20: return "parameter cannot be changed with enabled output stage";
    case 0x21: return "end of file";
    case 0x22: return "communication order";
    case 0x23: return "'IPOS stop' required";
    case 0x24: return "autosetup";
    case 0x25: return "encoder nameplate error";
    case 0x29: return "PLC state error";
    }
    return "unknown additional code";
}

// Special return codes of class 5 / 6 (SC01 p.46; MOVI-PLC manual p.61).
constexpr const char* special_code_text(std::uint8_t cls, std::uint8_t code) noexcept {
    if (cls == 5 && code == 5) return "illegal service code in the management byte";
    if (cls == 6 && code == 8) return "data length is not 4 bytes";
    if (cls == 6 && code == 2) return "internal communication error: repeat the service";
    return nullptr;
}

struct device_error_fields {
    std::uint8_t error_class;
    std::uint8_t code;
    std::uint16_t additional;
};
constexpr device_error_fields fields_of(int value) noexcept {
    const auto v = static_cast<std::uint32_t>(value);
    return {static_cast<std::uint8_t>(v >> 24), static_cast<std::uint8_t>(v >> 16),
            static_cast<std::uint16_t>(v)};
}

struct device_domain_t {
    // The meaning of the additional code, or of a special return code of class 5 / 6.
    static constexpr const char* message(int ev) noexcept {
        const device_error_fields f = fields_of(ev);
        const char* special =
            f.additional == 0 ? special_code_text(f.error_class, f.code) : nullptr;
        return special ? special : additional_code_text(f.additional);
    }
    // "drive error class C (class text), code N, additional code 0xAAAA: meaning".
    static std::size_t format(int ev, char* buf, std::size_t size) noexcept {
        const device_error_fields f = fields_of(ev);
        ferrule::detail::text_writer w(buf, size);
        w.put("drive error class ").put_decimal(f.error_class);
        w.put(" (").put(error_class_text(f.error_class)).put("), code ").put_decimal(f.code);
        w.put(", additional code 0x").put_hex(f.additional, 4).put(": ").put(message(ev));
        return w.size();
    }
};

inline constexpr error_domain device_domain{"movilink", &device_domain_t::message,
                                            &device_domain_t::format};

constexpr error make_error(device_errc e) noexcept {
    return {static_cast<int>(e), device_domain};
}

// The error for a parameter channel with the status bit set. The value is the
// channel's data word (class << 24 | code << 16 | additional), so it round-trips.
constexpr error make_device_error(std::uint32_t error_data_word) noexcept {
    // A data word of 0 would read as "no error"; class 0 is not defined, keep it visible.
    return make_error(
        static_cast<device_errc>(error_data_word == 0 ? 0x80000000u : error_data_word));
}
constexpr error make_device_error(const param_channel& p) noexcept {
    return make_device_error(p.data);
}

constexpr device_error_fields fields_of(error e) noexcept {
    return fields_of(e.value());
}

// Host bridge: device_domain's std::error_category.
inline const std::error_category& device_category() {
    return category_of(device_domain);
}
inline std::error_code make_error_code(device_errc e) noexcept {
    return make_error(e);
}

} // namespace ferrule::movilink

template <>
struct ferrule::is_error_enum<ferrule::movilink::device_errc> : std::true_type {};
template <>
struct std::is_error_code_enum<ferrule::movilink::device_errc> : std::true_type {};
