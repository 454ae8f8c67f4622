// MOVILINK wire constants. Sources (see docs/movilink.md):
//   SC01  SEW MOVIDRIVE Serial Communication manual, 11/2001, ch. 4
//   MDXB  SEW MOVIDRIVE MDX60B/61B Communication and Fieldbus Unit Profile, 04/2009
//   MTB   SEW MOVITRAC B communication and unit profile
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>

#include "ferrule/core/serial_format.hpp"

namespace ferrule::movilink {

using namespace std::chrono_literals;

// Start delimiters (SC01 p.19).
inline constexpr std::uint8_t sd1_request = 0x02;  // master -> inverter
inline constexpr std::uint8_t sd2_response = 0x1D; // inverter -> master

// 8E1 at 9600 baud (SC01 p.26-27); MOVIDRIVE B also runs 57.6 kBaud on XT (MDXB p.18).
inline constexpr serial_format default_format{9600, 8, parity::even, 1};

// Bus idle before a start delimiter (SC01 p.19, MDXB p.20).
inline constexpr duration start_pause = 3440us;
// Longest pause allowed between two characters of one telegram (SC01 p.27).
inline constexpr duration max_char_delay = 3430us;
// Longest time from the request's BCC to the response's SD2 on MOVIDRIVE (SC01 p.27).
inline constexpr duration response_timeout = 50ms;
// Idle after a group or broadcast request before the next SD1 (SC01 p.21-22).
inline constexpr duration broadcast_spacing = 25ms;

// PDU types (SC01 p.23-24, Fig. 18): bit 7 = acyclic. Only these values are documented;
// every other TYP is rejected.
enum class pdu_type : std::uint8_t {
    param_1pd = 0x00,
    pd1 = 0x01,
    param_2pd = 0x02,
    pd2 = 0x03,
    param_3pd = 0x04,
    pd3 = 0x05,
    param = 0x06,
    param_1pd_acyclic = 0x80,
    pd1_acyclic = 0x81,
    param_2pd_acyclic = 0x82,
    pd2_acyclic = 0x83,
    param_3pd_acyclic = 0x84,
    pd3_acyclic = 0x85,
    param_acyclic = 0x86,
};

inline constexpr std::uint8_t acyclic_bit = 0x80;
inline constexpr std::size_t param_channel_size = 8;
inline constexpr std::size_t max_pd_words = 3;
inline constexpr std::size_t max_telegram_size = 18; // PARAM + 3PD (SC01 p.23)

constexpr bool is_valid_pdu_type(std::uint8_t typ) noexcept {
    return (typ & 0x7Fu) <= 0x06u;
}
constexpr bool is_acyclic(pdu_type t) noexcept {
    return (static_cast<std::uint8_t>(t) & acyclic_bit) != 0;
}
constexpr bool has_param(pdu_type t) noexcept {
    const auto k = static_cast<std::uint8_t>(t) & 0x7Fu;
    return k == 0x00 || k == 0x02 || k == 0x04 || k == 0x06;
}
constexpr std::size_t pd_words(pdu_type t) noexcept {
    switch (static_cast<std::uint8_t>(t) & 0x7Fu) {
    case 0x00:
    case 0x01: return 1;
    case 0x02:
    case 0x03: return 2;
    case 0x04:
    case 0x05: return 3;
    default: return 0;
    }
}
constexpr std::size_t pdu_size(pdu_type t) noexcept {
    return (has_param(t) ? param_channel_size : 0) + 2 * pd_words(t);
}
// SD + ADR + TYP + PDU + BCC (SC01 p.23: telegram length = PDU length + 4).
constexpr std::size_t telegram_size(pdu_type t) noexcept {
    return pdu_size(t) + 4;
}

// The PD-only / PARAM+PD type with the given number of process-data words.
constexpr pdu_type pd_type(std::size_t words, bool with_param, bool acyclic) noexcept {
    std::uint8_t k = 0x06;
    if (words >= 1 && words <= 3)
        k = static_cast<std::uint8_t>(2 * (words - 1) + (with_param ? 0 : 1));
    return static_cast<pdu_type>(k | (acyclic ? acyclic_bit : 0));
}

// "PARAM + 3PD acyclic" and so on, for tools and traces.
constexpr const char* name(pdu_type t) noexcept {
    switch (static_cast<std::uint8_t>(t) & 0x7Fu) {
    case 0x00: return is_acyclic(t) ? "PARAM + 1PD acyclic" : "PARAM + 1PD cyclic";
    case 0x01: return is_acyclic(t) ? "1PD acyclic" : "1PD cyclic";
    case 0x02: return is_acyclic(t) ? "PARAM + 2PD acyclic" : "PARAM + 2PD cyclic";
    case 0x03: return is_acyclic(t) ? "2PD acyclic" : "2PD cyclic";
    case 0x04: return is_acyclic(t) ? "PARAM + 3PD acyclic" : "PARAM + 3PD cyclic";
    case 0x05: return is_acyclic(t) ? "3PD acyclic" : "3PD cyclic";
    case 0x06: return is_acyclic(t) ? "PARAM acyclic" : "PARAM cyclic";
    }
    return "undocumented TYP";
}

// Addressing (SC01 p.20-22).
enum class address_kind : std::uint8_t {
    single,         // 0-99: the addressed unit answers
    group,          // 100-199: multicast, no answer (100 = member of no group)
    undefined,      // 200-252: not assigned by the manual
    local,          // 253: unit-internal (IPOSplus MOVLNK), not used on RS-485
    point_to_point, // 254: every unit answers: never on a multi-drop bus
    broadcast,      // 255: no answer
};

inline constexpr std::uint8_t address_point_to_point = 254;
inline constexpr std::uint8_t address_broadcast = 255;

constexpr address_kind kind_of(std::uint8_t adr) noexcept {
    if (adr <= 99) return address_kind::single;
    if (adr <= 199) return address_kind::group;
    if (adr <= 252) return address_kind::undefined;
    if (adr == 253) return address_kind::local;
    if (adr == 254) return address_kind::point_to_point;
    return address_kind::broadcast;
}
constexpr const char* name(address_kind k) noexcept {
    switch (k) {
    case address_kind::single: return "single";
    case address_kind::group: return "group";
    case address_kind::undefined: return "undefined";
    case address_kind::local: return "local";
    case address_kind::point_to_point: return "point-to-point";
    case address_kind::broadcast: return "broadcast";
    }
    return "undefined";
}
constexpr bool expects_response(std::uint8_t adr) noexcept {
    const auto k = kind_of(adr);
    return k == address_kind::single || k == address_kind::point_to_point;
}

} // namespace ferrule::movilink
