// Names of PROFIBUS-DP bits (protocols/modbus_profibus.md §B.5) as `ferrule profibus` and
// `ferrule decode profibus` print them.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace ferrule::cli::profibus_text {

struct flag {
    std::uint8_t bit;
    const char* name;
};

// Slave_Diag Station_Status_1, _2, _3; Set_Prm Station_Status; Global_Control command.
extern const std::span<const flag> station_status_1;
extern const std::span<const flag> station_status_2;
extern const std::span<const flag> station_status_3;
extern const std::span<const flag> prm_status;
extern const std::span<const flag> control_command;

// The names of the bits set in `b`, in the order of `flags`, then the others as "bit n".
std::vector<std::string> bit_names(std::uint8_t b, std::span<const flag> flags);
// "a, b, c"; "-" for none.
std::string join(const std::vector<std::string>& names);

} // namespace ferrule::cli::profibus_text
