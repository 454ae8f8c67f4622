// nanoMODBUS doing the job of examples/firmware/modbus_server: unit 17 on USART2 at 19200 8E1
// serves 32 coils, 32 discrete inputs, 64 holding and 32 input registers with FC 1-6, 15, 16,
// 23 and 43/14 (device identification "ferrule", "fw-server", "1.0"); the tables are this
// program's, as nanoMODBUS keeps none. Between requests the coils go to the outputs and the
// inputs to the discrete inputs and input registers. Every 20 requests served it reports the
// count, holding register 0 and the stack's high-water mark.
#include "platform.hpp"

namespace {
constexpr std::uint8_t unit = 17;

volatile std::uint32_t outputs = 0;
volatile std::uint32_t inputs = 0;
volatile std::uint16_t analog[32] = {};

std::uint32_t coils = 0;
std::uint32_t discrete = 0;
std::uint16_t holding[64] = {};
std::uint16_t input_registers[32] = {};

bool in_range(std::uint16_t address, std::uint16_t quantity, std::uint16_t size) {
    return address < size && quantity <= size - address;
}

nmbs_error read_bits(std::uint32_t table, std::uint16_t address, std::uint16_t quantity,
                     nmbs_bitfield out) {
    if (!in_range(address, quantity, 32)) return NMBS_EXCEPTION_ILLEGAL_DATA_ADDRESS;
    for (std::uint16_t i = 0; i < quantity; ++i)
        nmbs_bitfield_write(out, i, (table >> (address + i)) & 1u);
    return NMBS_ERROR_NONE;
}

nmbs_error read_coils(uint16_t address, uint16_t quantity, nmbs_bitfield out, uint8_t, void*) {
    return read_bits(coils, address, quantity, out);
}
nmbs_error read_discrete(uint16_t address, uint16_t quantity, nmbs_bitfield out, uint8_t, void*) {
    return read_bits(discrete, address, quantity, out);
}

nmbs_error read_words(const std::uint16_t* table, std::uint16_t size, std::uint16_t address,
                      std::uint16_t quantity, std::uint16_t* out) {
    if (!in_range(address, quantity, size)) return NMBS_EXCEPTION_ILLEGAL_DATA_ADDRESS;
    for (std::uint16_t i = 0; i < quantity; ++i) out[i] = table[address + i];
    return NMBS_ERROR_NONE;
}

nmbs_error read_holding(uint16_t address, uint16_t quantity, uint16_t* out, uint8_t, void*) {
    return read_words(holding, 64, address, quantity, out);
}
nmbs_error read_input(uint16_t address, uint16_t quantity, uint16_t* out, uint8_t, void*) {
    return read_words(input_registers, 32, address, quantity, out);
}

nmbs_error write_coil(uint16_t address, bool value, uint8_t, void*) {
    if (address >= 32) return NMBS_EXCEPTION_ILLEGAL_DATA_ADDRESS;
    coils = value ? coils | 1u << address : coils & ~(1u << address);
    return NMBS_ERROR_NONE;
}

nmbs_error write_coils(uint16_t address, uint16_t quantity, const nmbs_bitfield in, uint8_t,
                       void*) {
    if (!in_range(address, quantity, 32)) return NMBS_EXCEPTION_ILLEGAL_DATA_ADDRESS;
    for (std::uint16_t i = 0; i < quantity; ++i)
        coils = nmbs_bitfield_read(in, i) ? coils | 1u << (address + i)
                                          : coils & ~(1u << (address + i));
    return NMBS_ERROR_NONE;
}

nmbs_error write_register(uint16_t address, uint16_t value, uint8_t, void*) {
    if (address >= 64) return NMBS_EXCEPTION_ILLEGAL_DATA_ADDRESS;
    holding[address] = value;
    return NMBS_ERROR_NONE;
}

nmbs_error write_registers(uint16_t address, uint16_t quantity, const uint16_t* in, uint8_t,
                           void*) {
    if (!in_range(address, quantity, 64)) return NMBS_EXCEPTION_ILLEGAL_DATA_ADDRESS;
    for (std::uint16_t i = 0; i < quantity; ++i) holding[address + i] = in[i];
    return NMBS_ERROR_NONE;
}

// Basic device identification: objects 0-2 (Application Protocol §6.21).
nmbs_error device_identification(uint8_t object_id,
                                 char buffer[NMBS_DEVICE_IDENTIFICATION_STRING_LENGTH]) {
    static constexpr const char* objects[] = {"ferrule", "fw-server", "1.0"};
    if (object_id > 2) return NMBS_EXCEPTION_ILLEGAL_DATA_ADDRESS;
    const char* s = objects[object_id];
    std::size_t n = 0;
    for (; s[n]; ++n) buffer[n] = s[n];
    buffer[n] = '\0';
    return NMBS_ERROR_NONE;
}

nmbs_error device_identification_map(nmbs_bitfield_256 map) {
    for (std::uint8_t id = 0; id < 3; ++id) nmbs_bitfield_set(map, id);
    return NMBS_ERROR_NONE;
}
} // namespace

int main() {
    board::init(bench::format);
    const nmbs_platform_conf platform = bench::usart2_platform();
    nmbs_callbacks callbacks;
    nmbs_callbacks_create(&callbacks);
    callbacks.read_coils = read_coils;
    callbacks.read_discrete_inputs = read_discrete;
    callbacks.read_holding_registers = read_holding;
    callbacks.read_input_registers = read_input;
    callbacks.write_single_coil = write_coil;
    callbacks.write_single_register = write_register;
    callbacks.write_multiple_coils = write_coils;
    callbacks.write_multiple_registers = write_registers;
    callbacks.read_device_identification = device_identification;
    callbacks.read_device_identification_map = device_identification_map;
    nmbs_t nmbs;
    if (nmbs_server_create(&nmbs, unit, &platform, &callbacks) != NMBS_ERROR_NONE)
        board::report("create failed");
    nmbs_set_read_timeout(&nmbs, 10);
    nmbs_set_byte_timeout(&nmbs, 10);
    for (std::uint32_t served = 0;;) {
        // A poll that read nothing returns NMBS_ERROR_TIMEOUT; anything else was a request.
        if (nmbs_server_poll(&nmbs) != NMBS_ERROR_TIMEOUT && ++served % 20 == 0)
            board::report("served=", served, " hr0=", holding[0],
                          " stack=", board::stack_high_water());
        outputs = coils;
        discrete = inputs;
        for (std::size_t i = 0; i < 32; ++i) input_registers[i] = analog[i];
    }
}
