// Indices of the drive parameters ferrule's tools and simulator use, named as in the
// manual's parameter list (SC01 §7.2; protocols/movilink.md §3.5). They are MOVIDRIVE's and
// assumed equal on MOVITRAC B (movilink.md §8.3): check a drive's own list.
#pragma once

#include <cstdint>

namespace ferrule::movilink {

namespace parameter_index {
inline constexpr std::uint16_t p076_firmware_basic_unit = 8300;
inline constexpr std::uint16_t p070_unit_type = 8301;
inline constexpr std::uint16_t p870_po1_description = 8304;
inline constexpr std::uint16_t p871_po2_description = 8305;
inline constexpr std::uint16_t p872_po3_description = 8306;
inline constexpr std::uint16_t p873_pi1_description = 8307;
inline constexpr std::uint16_t p874_pi2_description = 8308;
inline constexpr std::uint16_t p875_pi3_description = 8309;
inline constexpr std::uint16_t p010_inverter_status = 8310;
inline constexpr std::uint16_t p000_speed = 8318;
inline constexpr std::uint16_t p002_frequency = 8319;
inline constexpr std::uint16_t p004_output_current = 8321;
inline constexpr std::uint16_t p008_dc_link_voltage = 8325;
inline constexpr std::uint16_t p009_output_current_a = 8326;
inline constexpr std::uint16_t p014_heat_sink_temperature = 8327;
inline constexpr std::uint16_t p094_po1_setpoint = 8455;
inline constexpr std::uint16_t p095_po2_setpoint = 8456;
inline constexpr std::uint16_t p096_po3_setpoint = 8457;
inline constexpr std::uint16_t p097_pi1_actual_value = 8458;
inline constexpr std::uint16_t p098_pi2_actual_value = 8459;
inline constexpr std::uint16_t p099_pi3_actual_value = 8460;
inline constexpr std::uint16_t p810_rs485_address = 8597;
inline constexpr std::uint16_t p811_rs485_group_address = 8598;
inline constexpr std::uint16_t p812_rs485_timeout_delay = 8599;
inline constexpr std::uint16_t p876_po_data_enable = 8622;
} // namespace parameter_index

} // namespace ferrule::movilink
