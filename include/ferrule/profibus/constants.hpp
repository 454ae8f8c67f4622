// PROFIBUS-DP constants at the telegram level (FDL, EN 50170 / IEC 61158 type 3) and the
// DP-V0 services on top of it. Sources: protocols/modbus_profibus.md §B (Felser PROFIBUS
// manual; PNO specification excerpts; pyprofibus), cited by section below.
#pragma once

#include <cstdint>

#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/time.hpp"

namespace ferrule::profibus {

// Start delimiters, end delimiter and the short acknowledgement (§B.2).
inline constexpr std::uint8_t sd1 = 0x10; // no data: 10 DA SA FC FCS 16
inline constexpr std::uint8_t sd2 = 0x68; // variable: 68 LE LEr 68 DA SA FC DU… FCS 16
inline constexpr std::uint8_t sd3 = 0xA2; // 8 data bytes: A2 DA SA FC DU(8) FCS 16
inline constexpr std::uint8_t sd4 = 0xDC; // token: DC DA SA
inline constexpr std::uint8_t sc = 0xE5;  // short acknowledgement
inline constexpr std::uint8_t ed = 0x16;

// SD2 length byte LE counts DA, SA, FC and the data unit: 4…249 (§B.2).
inline constexpr std::size_t sd2_min_le = 4;
inline constexpr std::size_t sd2_max_le = 249;
inline constexpr std::size_t sd3_data = 8;
// The longest telegram: SD2 with LE 249.
inline constexpr std::size_t max_telegram = sd2_max_le + 6;
// Data unit without SAP bytes at most 246 (249 - DA, SA, FC).
inline constexpr std::size_t max_data = sd2_max_le - 3;

// Station addresses: 0…126; 127 broadcast (Global_Control); 126 the default address of a
// slave whose address is set over the bus (§B.3).
inline constexpr std::uint8_t broadcast_address = 127;
inline constexpr std::uint8_t default_address = 126;
inline constexpr std::uint8_t max_station_address = 126;
// Bit 7 of DA / SA: a SAP byte (address extension) follows in the data unit (§B.3).
inline constexpr std::uint8_t address_extension = 0x80;
inline constexpr std::uint8_t sap_mask = 0x3F;

// The function code byte (§B.3). Requests have bit 6 set; FCB bit 5, FCV bit 4.
inline constexpr std::uint8_t fc_request = 0x40;
inline constexpr std::uint8_t fc_fcb = 0x20;
inline constexpr std::uint8_t fc_fcv = 0x10;
inline constexpr std::uint8_t fc_function_mask = 0x0F;

enum class request_fn : std::uint8_t {
    time_event = 0x0,
    sda_low = 0x3,
    sdn_low = 0x4,
    sda_high = 0x5,
    sdn_high = 0x6, // send data with no acknowledge: Global_Control
    msrd = 0x7,
    fdl_status = 0x9,
    srd_low = 0xC,
    srd_high = 0xD, // send and request data: every DP-V0 service with a reply
    ident = 0xE,
    lsap_status = 0xF,
};

// Response function codes, bits 3…0 (bits 5…4: station type, 00 = slave).
enum class response_fn : std::uint8_t {
    ok = 0x0,
    user_error = 0x1,       // UE
    no_resource = 0x2,      // RR
    sap_not_active = 0x3,   // RS
    data_low = 0x8,         // DL: the normal DP reply
    no_response_data = 0x9, // NR
    data_high = 0xA,        // DH: new diagnosis waits, the master fetches Slave_Diag
    rdl = 0xC,
    rdh = 0xD,
};

// Station type in a response, bits 5…4 (§B.3).
inline constexpr std::uint8_t station_slave = 0x00;

// DP-V0 service access points (§B.4). The master's SSAP in every DP-V0 request is 62.
enum class sap : std::uint8_t {
    set_slave_address = 55,
    read_inputs = 56,
    read_outputs = 57,
    global_control = 58,
    get_cfg = 59,
    slave_diag = 60,
    set_prm = 61,
    chk_cfg = 62,
};
inline constexpr std::uint8_t master_sap = 62; // MS0

// Slave_Diag bytes (§B.5).
namespace diag {
// Station_Status_1
inline constexpr std::uint8_t station_non_existent = 0x01; // set by the master
inline constexpr std::uint8_t station_not_ready = 0x02;
inline constexpr std::uint8_t cfg_fault = 0x04;
inline constexpr std::uint8_t ext_diag = 0x08;
inline constexpr std::uint8_t not_supported = 0x10;
inline constexpr std::uint8_t invalid_slave_response = 0x20; // set by the master
inline constexpr std::uint8_t prm_fault = 0x40;
inline constexpr std::uint8_t master_lock = 0x80; // set by the master
// Station_Status_2
inline constexpr std::uint8_t prm_req = 0x01;
inline constexpr std::uint8_t stat_diag = 0x02;
inline constexpr std::uint8_t always_one = 0x04;
inline constexpr std::uint8_t wd_on = 0x08;
inline constexpr std::uint8_t freeze_mode = 0x10;
inline constexpr std::uint8_t sync_mode = 0x20;
inline constexpr std::uint8_t deactivated = 0x80; // set by the master
// Station_Status_3
inline constexpr std::uint8_t ext_diag_overflow = 0x80;
// Diag.Master_Add before a master has parameterized the slave.
inline constexpr std::uint8_t no_master = 0xFF;
inline constexpr std::size_t standard_size = 6;
// Extended diagnosis block header, bits 7…6 (§B.7).
inline constexpr std::uint8_t block_device = 0x00;
inline constexpr std::uint8_t block_identifier = 0x40;
inline constexpr std::uint8_t block_channel = 0x80;
} // namespace diag

// Set_Prm Station_Status bits (§B.5).
namespace prm {
inline constexpr std::uint8_t lock_req = 0x80;
inline constexpr std::uint8_t unlock_req = 0x40;
inline constexpr std::uint8_t sync_req = 0x20;
inline constexpr std::uint8_t freeze_req = 0x10;
inline constexpr std::uint8_t wd_on = 0x08;
// Station_Status, WD_Fact_1, WD_Fact_2, min_TSDR, Ident_Hi, Ident_Lo, Group_Ident
inline constexpr std::size_t standard_size = 7;
} // namespace prm

// Global_Control Control_Command bits (§B.5).
namespace control {
inline constexpr std::uint8_t clear_data = 0x02;
inline constexpr std::uint8_t unfreeze = 0x04;
inline constexpr std::uint8_t freeze = 0x08;
inline constexpr std::uint8_t unsync = 0x10;
inline constexpr std::uint8_t sync = 0x20;
} // namespace control

// The UART character: 8 data bits, even parity, 1 stop bit — 11 bits (§B.1).
constexpr serial_format format(std::uint32_t baud) noexcept {
    return {baud, 8, parity::even, 1};
}

// Bit times (§B.1): the station delay of a responder lies between min TSDR (11 tbit, or the
// master's Set_Prm value) and max TSDR; the idle time before a request is at least 33 tbit.
inline constexpr unsigned min_tsdr_bits = 11;
inline constexpr unsigned syn_bits = 33;

constexpr duration bit_times(std::uint32_t baud, std::uint64_t bits) noexcept {
    return ceil_seconds(bits, baud);
}

// max TSDR in bit times by baud rate (Felser "time ratios", §B.1).
constexpr unsigned max_tsdr_bits(std::uint32_t baud) noexcept {
    if (baud <= 187'500) return 60;
    if (baud <= 500'000) return 100;
    if (baud <= 1'500'000) return 150;
    if (baud <= 3'000'000) return 250;
    if (baud <= 6'000'000) return 450;
    return 800;
}

} // namespace ferrule::profibus
