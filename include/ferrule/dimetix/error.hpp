// Dimetix device errors: the answer `gN@Ezzz` kept as a std::error_code whose value is the
// code zzz, with the manual's meaning as the message (S1 §8.6 p.53-54). Codes the D-Series
// table does not list but older generations or other sources use are marked as such
// (dimetix.md §7.2); any other code is kept as it came, "not documented".
#pragma once

#include <string>
#include <system_error>

namespace ferrule::dimetix {

class device_category_t final : public std::error_category {
public:
    const char* name() const noexcept override { return "dimetix"; }
    std::string message(int ev) const override {
        // Built without snprintf, which would pull printf into firmware.
        std::string m = "@E" + std::to_string(ev) + ": ";
        m += describe(ev);
        return m;
    }

    // The manual's description and remedy; nullptr-free, unknown codes say so.
    static const char* describe(int code) noexcept {
        switch (code) {
        // D-Series, S1 §8.6 p.53-54.
        case 0: return "no error";
        case 200: return "boot-up event of the sensor (error stack marker)";
        case 203: return "wrong command, parameter or syntax";
        case 210: return "sensor not in tracking mode: start tracking first";
        case 211: return "tracking measurement time too short: increase it";
        case 212: return "command cannot be executed while tracking is active: send sNc first";
        case 220: return "error in the serial communication: check baud rate, parity, stop bits";
        case 230: return "distance value overflow caused by the user configuration (offset, gain)";
        case 233: return "number cannot be displayed: check the output format (sNuo)";
        case 234: return "distance not in the measurement range";
        case 236: return "conflict in the DI1/DO1 configuration";
        case 252: return "temperature too high";
        case 253: return "temperature too low (heated types: wait for the heater)";
        case 255:
            return "received signal too low or distance not in range: use a more "
                   "reflective target";
        case 256: return "received signal too high: less reflective target, avoid mirrors";
        case 257: return "signal-to-noise ratio too low: background light too strong";
        case 258: return "power supply voltage too high";
        case 259: return "power supply voltage too low";
        case 260: return "signal too unstable for a distance measurement";
        case 261: return "distance jump higher than the set limit (sNafi+1): restart measurement";
        case 262: return "signal jump higher than the set limit (sNafi+3): restart measurement";
        case 284: return "signal disturbance in the laser output part: clean the output glass";
        case 290: return "signal disturbance in the sensor optics: clean the optics";
        case 400: return "industrial Ethernet module firmware download: module busy";
        case 401: return "industrial Ethernet firmware download: no module connected";
        case 402: return "measurement module firmware download not possible";
        // Older generations / other sources only (dimetix.md §7.2).
        case 231: return "older generations: wrong mode for digital input read, activate DI1";
        case 232: return "older generations: DO1 cannot be set while configured as input";
        case 254: return "older generations: bad signal, measurement takes too long";
        case 263: return "older generations: too much light or distance jump (moving target)";
        case 264: return "older generations: too much light, reflective target";
        case 330: return "older generations: target acceleration too strong (moving target)";
        case 331: return "older generations: target speed too high";
        case 360: return "older generations: configured measuring time too short";
        case 361: return "older generations: configured measuring time too long";
        }
        return "error code not documented for the D-Series";
    }
};

inline const std::error_category& device_category() noexcept {
    static const device_category_t instance;
    return instance;
}

// The error_code of an answer `gN@Ezzz` (code = zzz, e.g. 255).
inline std::error_code make_device_error(int code) noexcept {
    return {code, device_category()};
}

} // namespace ferrule::dimetix
