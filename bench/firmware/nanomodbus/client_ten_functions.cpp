// nanoMODBUS doing the job of examples/firmware/modbus_client_functions: an RTU client on
// USART2 at 19200 8E1 goes round a scan list on unit 1 with the ten function codes both
// libraries have (FC 1-4, 5, 6, 15, 16, 23 and 43/14 basic device identification); a transaction
// without an answer is tried once more (ferrule's example: retries 1), 100 ms response timeout.
// Every 30 transactions it reports its counts and the stack's high-water mark.
#include "platform.hpp"

namespace {
volatile std::uint16_t coils_in = 0;
volatile std::uint16_t inputs = 0;
volatile std::uint16_t holding[8] = {};
volatile std::uint16_t measured[8] = {};
volatile std::uint16_t coils_out = 0;
volatile bool alarm = false;
volatile std::uint16_t setpoint = 0;
volatile std::uint16_t outputs[4] = {};
volatile std::uint8_t vendor_length = 0;
volatile std::uint32_t failures = 0;

nmbs_error entry(nmbs_t& nmbs, std::size_t i) {
    nmbs_bitfield bits{};
    std::uint16_t regs[8];
    nmbs_error e;
    switch (i) {
    case 0:
        e = nmbs_read_coils(&nmbs, 0, 16, bits);
        if (e == NMBS_ERROR_NONE) coils_in = static_cast<std::uint16_t>(bits[0] | bits[1] << 8);
        return e;
    case 1:
        e = nmbs_read_discrete_inputs(&nmbs, 0, 16, bits);
        if (e == NMBS_ERROR_NONE) inputs = static_cast<std::uint16_t>(bits[0] | bits[1] << 8);
        return e;
    case 2:
    case 3:
        e = i == 2 ? nmbs_read_holding_registers(&nmbs, 0, 8, regs)
                   : nmbs_read_input_registers(&nmbs, 0, 8, regs);
        if (e == NMBS_ERROR_NONE)
            for (std::size_t k = 0; k < 8; ++k) (i == 2 ? holding : measured)[k] = regs[k];
        return e;
    case 4: return nmbs_write_single_coil(&nmbs, 32, alarm);
    case 5: return nmbs_write_single_register(&nmbs, 16, setpoint);
    case 6:
        bits[0] = static_cast<std::uint8_t>(coils_out);
        bits[1] = static_cast<std::uint8_t>(coils_out >> 8);
        return nmbs_write_multiple_coils(&nmbs, 16, 16, bits);
    case 7:
    case 8:
        for (std::size_t k = 0; k < 4; ++k) regs[k] = outputs[k];
        if (i == 7) return nmbs_write_multiple_registers(&nmbs, 20, 4, regs);
        {
            std::uint16_t read[8];
            e = nmbs_read_write_registers(&nmbs, 0, 8, read, 20, 4, regs);
            if (e == NMBS_ERROR_NONE)
                for (std::size_t k = 0; k < 8; ++k) holding[k] = read[k];
        }
        return e;
    default: {
        char vendor[32], product[32], revision[32];
        e = nmbs_read_device_identification_basic(&nmbs, vendor, product, revision, 32);
        if (e == NMBS_ERROR_NONE) {
            std::uint8_t n = 0;
            while (n < 32 && vendor[n]) ++n;
            vendor_length = n;
        }
        return e;
    }
    }
}
} // namespace

int main() {
    board::init(bench::format);
    const nmbs_platform_conf platform = bench::usart2_platform();
    nmbs_t nmbs;
    if (nmbs_client_create(&nmbs, &platform) != NMBS_ERROR_NONE) board::report("create failed");
    nmbs_set_read_timeout(&nmbs, 100);
    nmbs_set_byte_timeout(&nmbs, 10);
    nmbs_set_destination_rtu_address(&nmbs, 1);
    for (std::uint32_t n = 1;; ++n) {
        const std::size_t i = (n - 1) % 10;
        nmbs_error e = entry(nmbs, i);
        if (e < NMBS_ERROR_NONE) e = entry(nmbs, i); // no answer: once more
        if (e != NMBS_ERROR_NONE) failures = failures + 1;
        if (n % 30 == 0)
            board::report("transactions=", n, " failed=", failures,
                          " vendor_length=", vendor_length, " stack=", board::stack_high_water());
    }
}
