// The examples' console: USART3 at 115200 8N1, written by polling.
#include "board.hpp"

namespace board {
namespace {
void put(char c) {
    auto& u = usart<usart3_base>();
    while (!(u.sr & sr_txe)) {
    }
    u.dr = static_cast<std::uint8_t>(c);
}
} // namespace

void console_init() {
    init<usart3_base>({115200, 8, ferrule::parity::none, 1});
}

void print(const char* text) {
    while (*text) put(*text++);
}

void print_uint(std::uint32_t value) {
    char digits[10];
    int n = 0;
    do {
        digits[n++] = static_cast<char>('0' + value % 10);
        value /= 10;
    } while (value);
    while (n) put(digits[--n]);
}

void print_int(std::int32_t value) {
    if (value < 0) put('-');
    print_uint(value < 0 ? 0u - static_cast<std::uint32_t>(value)
                         : static_cast<std::uint32_t>(value));
}

void print_hex(std::uint32_t value) {
    print("0x");
    for (int shift = 28; shift >= 0; shift -= 4) put("0123456789ABCDEF"[(value >> shift) & 0xFu]);
}

} // namespace board
