// Smallest useful consumer of ferrule: exit code 0 iff the Modbus CRC of "123456789"
// is the published check value 0x4B37.
#include <ferrule/core/checksum.hpp>

#include <cstdint>
#include <span>

int main() {
    const std::uint8_t check[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
    const std::uint16_t crc = ferrule::crc16_modbus(std::span<const std::uint8_t>(check));
    return crc == 0x4B37 ? 0 : 1;
}
