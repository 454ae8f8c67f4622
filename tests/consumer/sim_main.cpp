// A consumer of ferrule::sim: exit code 0 iff the Modbus client starts a simulated VFD with
// the paper's command (register 0xC800 = 0x0025) and reads its control word back.
#include <ferrule/modbus/access.hpp>
#include <ferrule/modbus/sim/bus.hpp>
#include <ferrule/sim/mock_serial.hpp>

#include <array>
#include <cstdint>

namespace mb = ferrule::modbus;

int main() {
    mb::sim::bus<1> bus;
    if (!bus.add(mb::server_config{})) return 1;
    ferrule::mock_serial line(mb::client_config{}.format, &bus);
    mb::client c;
    if (mb::write_register(line, c, 1, mb::sim::vfd_register::control_word, 0x0025)) return 2;
    std::array<std::uint16_t, 1> control{};
    if (mb::read_holding_registers(line, c, 1, mb::sim::vfd_register::control_word, control))
        return 3;
    return control[0] == 0x0025 ? 0 : 4;
}
