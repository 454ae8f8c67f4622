// nanoMODBUS doing the job of examples/firmware/modbus_client: an RTU client on USART2 at
// 19200 8E1 reads four holding registers of each of units 1…3 in turn (FC 3) and writes a
// setpoint register of unit 1 (FC 6) when it changes; a transaction without an answer is tried up
// to three times (ferrule's example: retries 2), 100 ms response timeout. Every 30 reads it reports
// its counts, unit 1's first register, the last transaction's nmbs_error (2: the
// server's exception 2) and the stack's high-water mark.
#include "platform.hpp"

namespace {
constexpr std::uint8_t units = 3;
constexpr std::uint16_t registers = 4;
constexpr std::uint16_t setpoint_register = 0x0010;
constexpr int attempts = 3;

volatile std::uint16_t values[units][registers] = {};
volatile std::uint8_t online = 0;
volatile std::uint16_t setpoint = 0;
volatile bool setpoint_failed = false;

nmbs_error last_error = NMBS_ERROR_NONE;

template <class Transaction>
bool with_retries(Transaction t) {
    // Resent only when no answer came (nmbs_error < 0); an exception answer is final, as for
    // ferrule's client.
    for (int i = 0; i < attempts; ++i)
        if ((last_error = t()) >= NMBS_ERROR_NONE) break;
    return last_error == NMBS_ERROR_NONE;
}
} // namespace

int main() {
    board::init(bench::format);
    const nmbs_platform_conf platform = bench::usart2_platform();
    nmbs_t nmbs;
    if (nmbs_client_create(&nmbs, &platform) != NMBS_ERROR_NONE) board::report("create failed");
    nmbs_set_read_timeout(&nmbs, 100);
    nmbs_set_byte_timeout(&nmbs, 10);
    std::uint16_t written = 0;
    std::uint32_t reads = 0, good = 0;
    for (std::uint8_t unit = 1;; unit = static_cast<std::uint8_t>(unit % units + 1)) {
        const std::uint16_t sending = setpoint;
        if (sending != written) {
            nmbs_set_destination_rtu_address(&nmbs, 1);
            setpoint_failed = !with_retries(
                [&] { return nmbs_write_single_register(&nmbs, setpoint_register, sending); });
            written = sending;
        }
        nmbs_set_destination_rtu_address(&nmbs, unit);
        std::uint16_t r[registers];
        const bool ok =
            with_retries([&] { return nmbs_read_holding_registers(&nmbs, 0, registers, r); });
        const std::uint8_t bit = static_cast<std::uint8_t>(1u << (unit - 1));
        online = static_cast<std::uint8_t>(ok ? online | bit : online & ~bit);
        if (ok)
            for (std::size_t i = 0; i < registers; ++i) values[unit - 1][i] = r[i];
        good += ok;
        if (++reads % 30 == 0)
            board::report("reads=", reads, " ok=", good, " r0=", values[0][0],
                          " error=", static_cast<int>(last_error),
                          " stack=", board::stack_high_water());
    }
}
