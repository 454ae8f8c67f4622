// LECOM codes and values as people write them: `C0046`, `C0039/3` (subcode: extended
// addressing), values as on the wire (`35.4`, `H0900`, `S82EV`, `O0A1B`).
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "ferrule/lecom/code.hpp"
#include "ferrule/lecom/value.hpp"

namespace ferrule::cli {

// "C46", "c0046", "46" (standard addressing up to 6229), "C39/3" or "C1002/0" (extended),
// "!03EA00" (the wire form). `extended` forces extended addressing.
std::optional<lecom::code_address> parse_code_arg(std::string_view text, bool extended);

// C0046, C0039/3 (extended addressing shows its subcode).
std::string code_text(const lecom::code_address& c);

// The value as the drive sends it: 35.4, H0900, S"82EV", O0A1B.
std::string value_text(const lecom::value& v);

// VD, VH, VS, VO as words: decimal, hex, string, octets.
std::string format_name(lecom::value_format f);

} // namespace ferrule::cli
