// An in-memory data model (data_model.hpp): four tables of fixed size, each at its own base
// address, and the three mandatory device identification objects (Modbus Application
// Protocol V1.1b3 §6.21). What the tables mean is the application's: it reads and sets them
// between requests, the server reads and writes them for the client.
//
//   * a request for addresses outside a table gets illegal_data_address (§7: exception 02;
//     §6.1-§6.4: "starting address + quantity" must lie in the device's range)
//   * a table of size 0 answers every request with illegal_data_address
//   * FC 1 / 5 / 15 use the coils, FC 2 the discrete inputs, FC 3 / 6 / 16 / 23 the holding
//     registers, FC 4 the input registers (§4.3)
//
// Bits are kept packed, eight to a byte, so a table of 2000 coils costs 250 bytes.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "ferrule/core/bytes.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/data_model.hpp"

namespace ferrule::modbus {

// Where each table starts (its first address on the wire).
struct memory_map {
    std::uint16_t coils = 0;
    std::uint16_t discrete_inputs = 0;
    std::uint16_t holding_registers = 0;
    std::uint16_t input_registers = 0;
};

// Device identification objects 0-2 (§6.21, basic category): the texts must outlive the
// model (string literals, typically).
struct device_identity {
    std::string_view vendor_name = "ferrule";
    std::string_view product_code = "memory_model";
    std::string_view revision = "1.0";
};

template <std::size_t NCoils, std::size_t NDiscrete, std::size_t NHolding, std::size_t NInput>
class memory_model {
    static_assert(NCoils <= 65536 && NDiscrete <= 65536 && NHolding <= 65536 && NInput <= 65536,
                  "a Modbus table has at most 65536 entries");

public:
    constexpr memory_model() = default;
    constexpr explicit memory_model(const memory_map& map, const device_identity& id = {}) noexcept
        : map_(map), id_(id) {}

    // --- data_model ------------------------------------------------------------------------
    std::uint8_t read_bits(function fc, std::uint16_t address, std::uint16_t quantity,
                           std::span<std::uint8_t> out) const noexcept {
        const bool coils = fc == function::read_coils;
        const std::size_t first = coils ? map_.coils : map_.discrete_inputs;
        const std::size_t size = coils ? NCoils : NDiscrete;
        if (!within(address, quantity, first, size)) return illegal_address;
        if (out.size() < (quantity + 7u) / 8u) return device_failure;
        const auto& table = coils ? std::span<const std::uint8_t>(coils_)
                                  : std::span<const std::uint8_t>(discrete_);
        for (std::size_t i = 0; i < quantity; ++i) {
            const std::size_t at = address - first + i;
            if (bit(table, at)) out[i / 8] = static_cast<std::uint8_t>(out[i / 8] | 1u << i % 8);
        }
        return 0;
    }

    std::uint8_t read_registers(function fc, std::uint16_t address, std::uint16_t quantity,
                                std::span<std::uint8_t> out) const noexcept {
        const bool holding = fc == function::read_holding_registers;
        const std::size_t first = holding ? map_.holding_registers : map_.input_registers;
        const std::size_t size = holding ? NHolding : NInput;
        if (!within(address, quantity, first, size)) return illegal_address;
        if (out.size() < 2u * quantity) return device_failure;
        const auto table = holding ? std::span<const std::uint16_t>(holding_)
                                   : std::span<const std::uint16_t>(input_);
        for (std::size_t i = 0; i < quantity; ++i)
            store_be16(out.data() + 2 * i, table[address - first + i]);
        return 0;
    }

    std::uint8_t write_coils(std::uint16_t address, std::uint16_t quantity,
                             std::span<const std::uint8_t> packed) noexcept {
        if (!within(address, quantity, map_.coils, NCoils)) return illegal_address;
        if (packed.size() < (quantity + 7u) / 8u) return device_failure;
        for (std::size_t i = 0; i < quantity; ++i)
            set_bit(coils_, address - map_.coils + i, (packed[i / 8] >> i % 8) & 1u);
        return 0;
    }

    std::uint8_t write_registers(std::uint16_t address, std::uint16_t quantity,
                                 std::span<const std::uint8_t> data) noexcept {
        if (!within(address, quantity, map_.holding_registers, NHolding)) return illegal_address;
        if (data.size() < 2u * quantity) return device_failure;
        for (std::size_t i = 0; i < quantity; ++i)
            holding_[address - map_.holding_registers + i] = load_be16(data.data() + 2 * i);
        return 0;
    }

    std::string_view device_id(std::uint8_t object_id) const noexcept {
        switch (object_id) {
        case 0: return id_.vendor_name;
        case 1: return id_.product_code;
        case 2: return id_.revision;
        default: return {};
        }
    }

    // --- the application's side: tables by index (address - the table's base) -------------
    bool coil(std::size_t i) const noexcept { return bit(coils_, i); }
    void set_coil(std::size_t i, bool v) noexcept { set_bit(coils_, i, v); }
    bool discrete_input(std::size_t i) const noexcept { return bit(discrete_, i); }
    void set_discrete_input(std::size_t i, bool v) noexcept { set_bit(discrete_, i, v); }
    std::span<std::uint16_t, NHolding> holding_registers() noexcept { return holding_; }
    std::span<const std::uint16_t, NHolding> holding_registers() const noexcept { return holding_; }
    std::span<std::uint16_t, NInput> input_registers() noexcept { return input_; }
    std::span<const std::uint16_t, NInput> input_registers() const noexcept { return input_; }

    const memory_map& map() const noexcept { return map_; }
    const device_identity& identity() const noexcept { return id_; }

private:
    static constexpr std::uint8_t illegal_address = code_of(exception_code::illegal_data_address);
    static constexpr std::uint8_t device_failure = code_of(exception_code::server_device_failure);

    // [address, address + quantity) inside [first, first + size)?
    static constexpr bool within(std::size_t address, std::size_t quantity, std::size_t first,
                                 std::size_t size) noexcept {
        return quantity > 0 && address >= first && address - first + quantity <= size;
    }
    static bool bit(std::span<const std::uint8_t> table, std::size_t i) noexcept {
        return (table[i / 8] >> i % 8) & 1u;
    }
    static void set_bit(std::span<std::uint8_t> table, std::size_t i, bool v) noexcept {
        const auto mask = static_cast<std::uint8_t>(1u << i % 8);
        table[i / 8] = static_cast<std::uint8_t>(v ? table[i / 8] | mask : table[i / 8] & ~mask);
    }

    memory_map map_{};
    device_identity id_{};
    std::array<std::uint8_t, (NCoils + 7) / 8> coils_{};
    std::array<std::uint8_t, (NDiscrete + 7) / 8> discrete_{};
    std::array<std::uint16_t, NHolding> holding_{};
    std::array<std::uint16_t, NInput> input_{};
};

static_assert(data_model<memory_model<8, 8, 8, 8>>);

} // namespace ferrule::modbus
