// LECOM-A/B (Lenze, "LECOM-AB V2.0") constants: control characters, addresses, timing and
// the serial formats of the drive families.
//
// Sources (protocols/lecom.md §0): S1 Lenze EDB2102EN appendix 8.3, S2 SMVector LECOM
// module CMVLC401A, S3 8200 motec EDB82MV752 §5.2.
#pragma once

#include <chrono>
#include <cstdint>
#include <string_view>

#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule::lecom {

// Control characters (S1 p.8-21/8-23; S1 p.8-16 misprints EOT as 02).
inline constexpr std::uint8_t stx = 0x02;
inline constexpr std::uint8_t etx = 0x03;
inline constexpr std::uint8_t eot = 0x04;
inline constexpr std::uint8_t enq = 0x05;
inline constexpr std::uint8_t ack = 0x06;
inline constexpr std::uint8_t nak = 0x15;
inline constexpr std::uint8_t fault_mark = '?';    // reply text of a checksum / parity fault
inline constexpr std::uint8_t extended_mark = '!'; // extended code address `!CCCCSS`

// --- addresses (S1 p.6-3, p.8-20, p.8-24) ------------------------------------------------
// Two decimal digits. 00 reaches every drive, x0 the group x1…x9; neither answers.
inline constexpr std::uint8_t broadcast_address = 0;
inline constexpr std::uint8_t max_address = 99;

constexpr bool is_valid_address(std::uint8_t a) noexcept {
    return a <= max_address;
}
// A drive's own address (C0009): 01…99 except 10, 20, … 90.
constexpr bool is_unit_address(std::uint8_t a) noexcept {
    return a <= max_address && a % 10 != 0;
}
// 00 and x0: SEND only, never answered (S1 p.8-24).
constexpr bool is_group_address(std::uint8_t a) noexcept {
    return a <= max_address && a % 10 == 0;
}
// Does drive `unit` act on a telegram to `target`?
constexpr bool addresses(std::uint8_t target, std::uint8_t unit) noexcept {
    return target == unit || target == broadcast_address ||
           (is_group_address(target) && target / 10 == unit / 10);
}

// Drives on one RS-485 segment (32 stations with the master) and with repeaters (S3).
inline constexpr unsigned max_drives_per_segment = 31;
inline constexpr unsigned max_drives_with_repeaters = 90;

// --- timing (S1 §8.3.5, S3) ----------------------------------------------------------------
// Controller processing time t3 of the 8200 motec for read and write codes (S3).
inline constexpr duration processing_time = std::chrono::milliseconds(20);
// "approx. twice as long as the maximum response time" (S1 §8.3.5): (request + reply +
// 20 ms) × 2 at 9600 Bd is about 100 ms (lecom.md §1.12).
inline constexpr duration response_timeout = std::chrono::milliseconds(100);

// --- serial formats (lecom.md §3) ---------------------------------------------------------
// LECOM itself is 7-bit ASCII; the character frame depends on the drive family.
struct profile {
    std::string_view name;
    serial_format format;
    std::string_view why;
};

// The 4900 DC drive system of the LECOM paper ran 9600 Bd, 8 data bits, even parity.
inline constexpr profile lenze_4900{"lenze-4900",
                                    {9600, 8, parity::even, 1},
                                    "4900 DC drives as run in the field (LECOM paper: 9600 8E1)"};
// The 8200 / 2102 documents state 7E1 (S3: "Transfer character format 7E1"), and S3's
// timing table implies 10-bit characters.
inline constexpr profile lenze_8200{
    "lenze-8200", {9600, 7, parity::even, 1}, "8200 / 9300 with the 2102 module (S3: 7E1)"};

inline constexpr profile profiles[] = {lenze_4900, lenze_8200};

// The profile named `name`, or nullptr.
constexpr const profile* find_profile(std::string_view name) noexcept {
    for (const profile& p : profiles)
        if (p.name == name) return &p;
    return nullptr;
}

inline constexpr serial_format default_format = lenze_4900.format;

} // namespace ferrule::lecom
