// `ferrule decode`: what the per-protocol decoders share.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace ferrule::cli {

struct decode_options {
    std::string protocol;
    std::vector<std::string> hex;
    std::string file;
    bool json = false;
};

// Bytes that form no telegram, with the reason.
void print_skipped(const decode_options& o, std::size_t offset, std::span<const std::uint8_t> b,
                   const std::string& reason);

// Each returns the exit code: 0 when every byte belonged to a good telegram, else 1.
int decode_lecom(const decode_options& o, std::span<const std::uint8_t> bytes);
int decode_modbus_rtu(const decode_options& o, std::span<const std::uint8_t> bytes);
int decode_modbus_tcp(const decode_options& o, std::span<const std::uint8_t> bytes);
int decode_profibus(const decode_options& o, std::span<const std::uint8_t> bytes);
int decode_memobus(const decode_options& o, std::span<const std::uint8_t> bytes);

} // namespace ferrule::cli
