// Dimetix device errors: the answer `gN@Ezzz` kept as a ferrule::error of device_domain whose
// value is the code zzz, with the manual's meaning as the message (S1 §8.6 p.53-54). Codes the
// D-Series table does not list but older generations or other sources use are marked as such
// (dimetix.md §7.2); any other code is kept as it came, "not documented".
#pragma once

#include "ferrule/core/error.hpp"

namespace ferrule::dimetix {

// What the sensor answered with `gN@Ezzz`, as an error enum whose value is zzz.
enum class device_errc : int {
    // D-Series, S1 §8.6 p.53-54.
    no_error = 0,  // in the error stack (an error of it is empty)
    boot_up = 200, // error stack marker
    wrong_command = 203,
    not_tracking = 210,
    tracking_time_too_short = 211,
    tracking_active = 212,
    serial_communication = 220,
    distance_overflow = 230,
    not_displayable = 233,
    distance_out_of_range = 234,
    di1_do1_conflict = 236,
    temperature_too_high = 252,
    temperature_too_low = 253,
    signal_too_low = 255,
    signal_too_high = 256,
    signal_to_noise_too_low = 257,
    supply_voltage_too_high = 258,
    supply_voltage_too_low = 259,
    signal_unstable = 260,
    distance_jump = 261,
    signal_jump = 262,
    laser_output_disturbance = 284,
    optics_disturbance = 290,
    ethernet_module_busy = 400,
    ethernet_module_missing = 401,
    measurement_module_download = 402,
    // Older generations / other sources only (dimetix.md §7.2).
    digital_input_mode = 231,
    do1_is_input = 232,
    bad_signal = 254,
    too_much_light_moving = 263,
    too_much_light_reflective = 264,
    target_acceleration = 330,
    target_speed = 331,
    measuring_time_too_short = 360,
    measuring_time_too_long = 361,
};

struct device_domain_t {
    // "@Ezzz: " and the manual's description.
    static std::size_t format(int code, char* buf, std::size_t size) noexcept {
        ferrule::detail::text_writer w(buf, size);
        w.put("@E").put_decimal(static_cast<unsigned>(code)).put(": ").put(message(code));
        return w.size();
    }

    // The manual's description and remedy; nullptr-free, unknown codes say so.
    static constexpr const char* message(int code) noexcept {
        switch (static_cast<device_errc>(code)) {
        // D-Series, S1 §8.6 p.53-54.
        case device_errc::no_error: return "no error";
        case device_errc::boot_up: return "boot-up event of the sensor (error stack marker)";
        case device_errc::wrong_command: return "wrong command, parameter or syntax";
        case device_errc::not_tracking: return "sensor not in tracking mode: start tracking first";
        case device_errc::tracking_time_too_short:
            return "tracking measurement time too short: increase it";
        case device_errc::tracking_active:
            return "command cannot be executed while tracking is active: send sNc first";
        case device_errc::serial_communication:
            return "error in the serial communication: check baud rate, parity, stop bits";
        case device_errc::distance_overflow:
            return "distance value overflow caused by the user configuration (offset, gain)";
        case device_errc::not_displayable:
            return "number cannot be displayed: check the output format (sNuo)";
        case device_errc::distance_out_of_range: return "distance not in the measurement range";
        case device_errc::di1_do1_conflict: return "conflict in the DI1/DO1 configuration";
        case device_errc::temperature_too_high: return "temperature too high";
        case device_errc::temperature_too_low:
            return "temperature too low (heated types: wait for the heater)";
        case device_errc::signal_too_low:
            return "received signal too low or distance not in range: use a more "
                   "reflective target";
        case device_errc::signal_too_high:
            return "received signal too high: less reflective target, avoid mirrors";
        case device_errc::signal_to_noise_too_low:
            return "signal-to-noise ratio too low: background light too strong";
        case device_errc::supply_voltage_too_high: return "power supply voltage too high";
        case device_errc::supply_voltage_too_low: return "power supply voltage too low";
        case device_errc::signal_unstable: return "signal too unstable for a distance measurement";
        case device_errc::distance_jump:
            return "distance jump higher than the set limit (sNafi+1): restart measurement";
        case device_errc::signal_jump:
            return "signal jump higher than the set limit (sNafi+3): restart measurement";
        case device_errc::laser_output_disturbance:
            return "signal disturbance in the laser output part: clean the output glass";
        case device_errc::optics_disturbance:
            return "signal disturbance in the sensor optics: clean the optics";
        case device_errc::ethernet_module_busy:
            return "industrial Ethernet module firmware download: module busy";
        case device_errc::ethernet_module_missing:
            return "industrial Ethernet firmware download: no module connected";
        case device_errc::measurement_module_download:
            return "measurement module firmware download not possible";
        // Older generations / other sources only (dimetix.md §7.2).
        case device_errc::digital_input_mode:
            return "older generations: wrong mode for digital input read, activate DI1";
        case device_errc::do1_is_input:
            return "older generations: DO1 cannot be set while configured as input";
        case device_errc::bad_signal:
            return "older generations: bad signal, measurement takes too long";
        case device_errc::too_much_light_moving:
            return "older generations: too much light or distance jump (moving target)";
        case device_errc::too_much_light_reflective:
            return "older generations: too much light, reflective target";
        case device_errc::target_acceleration:
            return "older generations: target acceleration too strong (moving target)";
        case device_errc::target_speed: return "older generations: target speed too high";
        case device_errc::measuring_time_too_short:
            return "older generations: configured measuring time too short";
        case device_errc::measuring_time_too_long:
            return "older generations: configured measuring time too long";
        }
        return "error code not documented for the D-Series";
    }
};

inline constexpr error_domain device_domain{"dimetix", &device_domain_t::message,
                                            &device_domain_t::format};

constexpr error make_error(device_errc e) noexcept {
    return {static_cast<int>(e), device_domain};
}

// The error of an answer `gN@Ezzz` (code = zzz, e.g. 255).
constexpr error make_device_error(int code) noexcept {
    return {code, device_domain};
}

// Host bridge: device_domain's std::error_category.
inline const std::error_category& device_category() {
    return category_of(device_domain);
}
inline std::error_code make_error_code(device_errc e) noexcept {
    return make_error(e);
}

} // namespace ferrule::dimetix

template <>
struct ferrule::is_error_enum<ferrule::dimetix::device_errc> : std::true_type {};
template <>
struct std::is_error_code_enum<ferrule::dimetix::device_errc> : std::true_type {};
