// Yaskawa Extended MEMOBUS over Ethernet (218IF / 218IFA / 218IFD, MP2000 / MP3000):
// constants of the 218 header and of the MFC 0x20 messages. Facts and their sources:
// protocols/memobus.md (cited by section); [S1] is the MP3000 Series User's Manual,
// "Details on Protocols", [S2] the MP920 Communications Module manual, Appendix B.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ferrule::memobus {

// 218 header, byte 0 (§2).
enum class command_type : std::uint8_t {
    command = 0x11,  // a MEMOBUS request
    response = 0x19, // a MEMOBUS response
    general = 0x12,  // general-purpose message: raw MW data, never answered (§5)
};

inline constexpr std::size_t header_size = 12; // the 218 header
inline constexpr std::size_t length_size = 2;  // the MEMOBUS length, little-endian (§3.1)

// Main function codes (§3.1, §4).
inline constexpr std::uint8_t mfc_extended = 0x20;
inline constexpr std::uint8_t mfc_32bit = 0x43; // MP3000 only

// Sub-function codes of MFC 0x20 (§3.4).
enum class sfc : std::uint8_t {
    read_coils = 0x01,
    read_input_relays = 0x02,
    read_holding_registers = 0x03,
    read_input_registers = 0x04,
    write_coil = 0x05,
    write_holding_register = 0x06,
    loopback = 0x08,
    read_holding_registers_ext = 0x09,
    read_input_registers_ext = 0x0A,
    write_holding_registers_ext = 0x0B,
    read_holding_registers_random = 0x0D,
    write_holding_registers_random = 0x0E,
    write_coils = 0x0F,
    write_holding_registers = 0x10,
};

// An error response has SFC | 0x80 and one error code byte (§3.5).
inline constexpr std::uint8_t error_flag = 0x80;

// The "extended" SFCs 09…0E have a spare byte after the CPU byte and little-endian fields;
// the MEMOBUS-compatible ones (01…08, 0F, 10) have none (§3.3).
constexpr bool is_extended(sfc f) noexcept {
    const auto v = static_cast<std::uint8_t>(f);
    return v >= 0x09 && v <= 0x0E;
}

// Limits per request, binary mode (§3.4, §10.5): MP3000 MSG-SNDE figures, and the MP920's
// for 0F and 10, the only ones known for them.
inline constexpr std::uint16_t max_read_bits = 2000;           // 01, 02
inline constexpr std::uint16_t max_read_registers = 125;       // 03, 04
inline constexpr std::uint16_t max_read_registers_ext = 2044;  // 09, 0A, 0D
inline constexpr std::uint16_t max_write_registers_ext = 2043; // 0B
inline constexpr std::uint16_t max_write_random = 1022;        // 0E
inline constexpr std::uint16_t max_write_bits = 800;           // 0F
inline constexpr std::uint16_t max_write_registers = 100;      // 10

// The longest message: 218 header, length, MFC SFC CPU spare count, 2044 words (§10.1).
inline constexpr std::size_t max_body = 6 + 2 * std::size_t{max_read_registers_ext};
inline constexpr std::size_t max_message = header_size + length_size + max_body;

// CPU byte: destination CPU in bits 7…4, source in 3…0 (§3.2). A PC talking to an MP2000 /
// MP3000 sends destination 1, source 0, as Yaskawa's sample does.
constexpr std::uint8_t cpu_byte(unsigned destination, unsigned source) noexcept {
    return static_cast<std::uint8_t>((destination & 0x0F) << 4 | (source & 0x0F));
}
inline constexpr std::uint8_t default_cpu = cpu_byte(1, 0);
// The response swaps the nibbles (§3.2).
constexpr std::uint8_t swap_nibbles(std::uint8_t b) noexcept {
    return static_cast<std::uint8_t>(b << 4 | b >> 4);
}

// Byte order of register data in the MEMOBUS-compatible SFCs (03/04 replies, 06/10 values):
// big-endian in HSL and FieldLink and like Modbus; the extracted manual figures suggest
// little-endian. Uncertain (§3.3, §11.1), so it is an option; big-endian is the default.
// Addresses and counts of those SFCs are big-endian either way (the manual's worked example).
enum class data_order : std::uint8_t { big_endian, little_endian };

} // namespace ferrule::memobus
