// Modbus as the CLI shows it: typed register values (--as, --word-order), function names,
// exception meanings, device identification object names.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/registers.hpp"

namespace ferrule::cli {

enum class value_type : std::uint8_t { u16, i16, u32, i32, f32, hex };

std::optional<value_type> parse_value_type(const std::string& s);
std::optional<modbus::word_order> parse_word_order(const std::string& s);
// Registers per value: 2 for u32, i32 and float, else 1.
unsigned registers_per_value(value_type t);

// The value at regs[0] (and regs[1] for 32 bits) as text and as a JSON-ready number.
std::string value_text(value_type t, std::span<const std::uint16_t> regs, modbus::word_order o);
double value_number(value_type t, std::span<const std::uint16_t> regs, modbus::word_order o);

// "1500", "-3", "0x0025", "12.5" as the registers of one value of type `t`; nullopt when it
// does not fit. Integers are decimal or 0x hex (parse_integer()); `hex` takes the digits alone too.
std::optional<std::vector<std::uint16_t>> parse_value(value_type t, const std::string& s,
                                                      modbus::word_order o);

// What parse_value() takes for `t`: "0-65535", "-32768 to 32767", …
std::string value_range(value_type t);

// "read holding registers" for FC 3 …; "function 0x41" for one outside the set.
std::string function_name(std::uint8_t fc);

// An error as the CLI prints it: "exception 02: illegal data address: …" for a server's
// exception, else the error's message.
std::string error_text(std::error_code ec);

// FC 43/14 object names (AP §6.21): 0 VendorName … 6 UserApplicationName.
std::string object_name(std::uint8_t id);

} // namespace ferrule::cli
