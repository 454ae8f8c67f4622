// The 8-byte MOVILINK parameter channel (SC01 p.29-34; MTB "management byte").
//   byte 0      management: service (bits 0-3), data length (4-5), handshake (6), status (7)
//   byte 1      subindex (SC01 calls it reserved = 0)
//   bytes 2-3   index, high byte first
//   bytes 4-7   data, MSB first; on error: class, code, additional code high, low
#pragma once

#include <cstdint>

#include "ferrule/core/bytes.hpp"

namespace ferrule::movilink {

enum class service : std::uint8_t {
    none = 0x0,
    read = 0x1,
    write = 0x2,          // non-volatile (EEPROM): not for cyclic writes (SC01 p.31)
    write_volatile = 0x3, // RAM only
    read_minimum = 0x4,
    read_maximum = 0x5,
    read_default = 0x6,
    read_scale = 0x7,
    read_attribute = 0x8,
};

// The manual's name of a service (SC01 p.29), for tools and traces.
constexpr const char* name(service s) noexcept {
    switch (s) {
    case service::none: return "no service";
    case service::read: return "read";
    case service::write: return "write";
    case service::write_volatile: return "write volatile";
    case service::read_minimum: return "read minimum";
    case service::read_maximum: return "read maximum";
    case service::read_default: return "read default";
    case service::read_scale: return "read scale";
    case service::read_attribute: return "read attribute";
    }
    return "unknown service";
}

inline constexpr std::uint8_t mgmt_service_mask = 0x0F;
inline constexpr std::uint8_t mgmt_length_shift = 4;
inline constexpr std::uint8_t mgmt_length_4_bytes = 0x30; // all SEW parameters are 32-bit
inline constexpr std::uint8_t mgmt_handshake = 0x40;
inline constexpr std::uint8_t mgmt_status_error = 0x80;

struct param_channel {
    std::uint8_t management = 0;
    std::uint8_t subindex = 0;
    std::uint16_t index = 0;
    std::uint32_t data = 0;

    static constexpr param_channel make(service s, std::uint16_t index, std::uint32_t data = 0,
                                        std::uint8_t subindex = 0) noexcept {
        return {static_cast<std::uint8_t>(static_cast<std::uint8_t>(s) | mgmt_length_4_bytes),
                subindex, index, data};
    }

    constexpr service svc() const noexcept {
        return static_cast<service>(management & mgmt_service_mask);
    }
    // Data length in bytes, 1-4 (bits 4-5 = length - 1).
    constexpr unsigned data_length() const noexcept {
        return ((management >> mgmt_length_shift) & 0x3u) + 1u;
    }
    constexpr bool handshake() const noexcept { return (management & mgmt_handshake) != 0; }
    constexpr bool is_error() const noexcept { return (management & mgmt_status_error) != 0; }
    constexpr void set_handshake(bool on) noexcept {
        management = static_cast<std::uint8_t>(on ? (management | mgmt_handshake)
                                                  : (management & ~mgmt_handshake));
    }

    // Error response fields (valid when is_error()).
    constexpr std::uint8_t error_class() const noexcept {
        return static_cast<std::uint8_t>(data >> 24);
    }
    constexpr std::uint8_t error_code() const noexcept {
        return static_cast<std::uint8_t>(data >> 16);
    }
    constexpr std::uint16_t additional_code() const noexcept {
        return static_cast<std::uint16_t>(data);
    }

    constexpr void store(std::uint8_t* p) const noexcept {
        p[0] = management;
        p[1] = subindex;
        store_be16(p + 2, index);
        store_be32(p + 4, data);
    }
    static constexpr param_channel load(const std::uint8_t* p) noexcept {
        return {p[0], p[1], load_be16(p + 2), load_be32(p + 4)};
    }

    friend constexpr bool operator==(const param_channel&, const param_channel&) = default;
};

// Error response data word: class, code, additional code (SC01 p.30).
constexpr std::uint32_t error_data(std::uint8_t error_class, std::uint8_t code,
                                   std::uint16_t additional) noexcept {
    return (std::uint32_t{error_class} << 24) | (std::uint32_t{code} << 16) | additional;
}

} // namespace ferrule::movilink
