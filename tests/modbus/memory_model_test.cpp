// modbus::memory_model: the four tables at their base addresses, packing of bits, range
// checks (Modbus Application Protocol V1.1b3 §6.1-§6.4, §7) and the device identification
// objects (§6.21).
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <span>

#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/data_model.hpp"
#include "ferrule/modbus/memory_model.hpp"

using namespace ferrule::modbus;

namespace {

constexpr std::uint8_t illegal_address = code_of(exception_code::illegal_data_address);

using model = memory_model<20, 10, 8, 4>;

model make() {
    memory_map map;
    map.coils = 100;
    map.discrete_inputs = 200;
    map.holding_registers = 0x1000;
    map.input_registers = 0;
    return model(map, {"ACME", "PX-1", "2.3"});
}

} // namespace

TEST_CASE("modbus server memory model: coils are packed LSB first from the base address",
          "[modbus][memory_model]") {
    model m = make();
    m.set_coil(0, true);
    m.set_coil(2, true);
    m.set_coil(9, true);
    m.set_coil(19, true);
    std::array<std::uint8_t, 3> out{};
    REQUIRE(m.read_bits(function::read_coils, 100, 20, out) == 0);
    CHECK(out == std::array<std::uint8_t, 3>{0x05, 0x02, 0x08});

    std::array<std::uint8_t, 2> part{};
    REQUIRE(m.read_bits(function::read_coils, 102, 9, part) == 0);
    CHECK(part == std::array<std::uint8_t, 2>{0x81, 0x00}); // coil 102 and coil 109

    const std::array<std::uint8_t, 2> packed{0xCD, 0x01}; // AP §6.11 example: 10 coils
    REQUIRE(m.write_coils(110, 10, packed) == 0);
    CHECK(m.coil(10));
    CHECK_FALSE(m.coil(11));
    CHECK(m.coil(12));
    CHECK(m.coil(18));
    CHECK_FALSE(m.coil(19)); // overwritten with 0 (bit 9 of 0x01CD is 0)
}

TEST_CASE("modbus server memory model: discrete inputs are read with FC 2 only",
          "[modbus][memory_model]") {
    model m = make();
    m.set_discrete_input(9, true);
    std::array<std::uint8_t, 2> out{};
    REQUIRE(m.read_bits(function::read_discrete_inputs, 200, 10, out) == 0);
    CHECK(out == std::array<std::uint8_t, 2>{0x00, 0x02});
    std::array<std::uint8_t, 1> one{};
    CHECK(m.read_bits(function::read_discrete_inputs, 210, 1, one) == illegal_address);
    CHECK(m.read_bits(function::read_discrete_inputs, 199, 1, one) == illegal_address);
}

TEST_CASE("modbus server memory model: registers are big-endian, holding and input apart",
          "[modbus][memory_model]") {
    model m = make();
    m.input_registers()[3] = 0xBEEF;
    const std::array<std::uint8_t, 4> data{0x12, 0x34, 0xAB, 0xCD};
    REQUIRE(m.write_registers(0x1006, 2, data) == 0);
    CHECK(m.holding_registers()[6] == 0x1234);
    CHECK(m.holding_registers()[7] == 0xABCD);

    std::array<std::uint8_t, 4> out{};
    REQUIRE(m.read_registers(function::read_holding_registers, 0x1006, 2, out) == 0);
    CHECK(out == data);
    std::array<std::uint8_t, 2> in{};
    REQUIRE(m.read_registers(function::read_input_registers, 3, 1, in) == 0);
    CHECK(in == std::array<std::uint8_t, 2>{0xBE, 0xEF});
}

TEST_CASE("modbus server memory model: outside a table is illegal data address",
          "[modbus][memory_model]") {
    model m = make();
    std::array<std::uint8_t, 250> out{};
    CHECK(m.read_bits(function::read_coils, 99, 1, out) == illegal_address);
    CHECK(m.read_bits(function::read_coils, 110, 11, out) == illegal_address);
    CHECK(m.read_bits(function::read_coils, 110, 10, out) == 0);
    CHECK(m.read_registers(function::read_holding_registers, 0x1000, 9, out) == illegal_address);
    CHECK(m.read_registers(function::read_holding_registers, 0xFFFF, 1, out) == illegal_address);
    CHECK(m.read_registers(function::read_input_registers, 4, 1, out) == illegal_address);
    const std::array<std::uint8_t, 2> v{0, 1};
    CHECK(m.write_registers(0x0FFF, 1, v) == illegal_address);
    CHECK(m.write_coils(120, 1, v) == illegal_address);
    // A failed write changes nothing.
    CHECK(m.write_registers(0x1007, 2, std::array<std::uint8_t, 4>{1, 2, 3, 4}) == illegal_address);
    CHECK(m.holding_registers()[7] == 0);

    memory_model<0, 0, 0, 0> empty;
    CHECK(empty.read_bits(function::read_coils, 0, 1, out) == illegal_address);
    CHECK(empty.read_registers(function::read_input_registers, 0, 1, out) == illegal_address);
}

TEST_CASE("modbus server memory model: device identification objects 0-2",
          "[modbus][memory_model]") {
    const model m = make();
    CHECK(m.device_id(0) == "ACME");
    CHECK(m.device_id(1) == "PX-1");
    CHECK(m.device_id(2) == "2.3");
    CHECK(m.device_id(3).empty());
    CHECK(memory_model<1, 1, 1, 1>{}.device_id(0) == "ferrule");
    static_assert(data_model<model>);
}
