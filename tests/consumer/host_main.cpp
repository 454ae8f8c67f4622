// A consumer of ferrule::host: exit code 0 iff a pseudo-terminal opens (libutil's openpty)
// and asio opens its device as a serial port with ferrule's options (the warnings a pty
// gives about baud, parity and RS-485 are expected and ignored).
#include <ferrule/host/pseudo_terminal.hpp>
#include <ferrule/host/serial_port.hpp>

#include <asio/io_context.hpp>
#include <asio/serial_port.hpp>

int main() {
    ferrule::host::pseudo_terminal pty;
    if (pty.open()) return 1;
    asio::io_context io;
    asio::serial_port port(io);
    if (ferrule::host::open_serial(port, pty.path(), ferrule::host::serial_options{},
                                   [](std::string_view) {}))
        return 2;
    return port.is_open() ? 0 : 3;
}
