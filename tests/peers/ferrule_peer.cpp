// ferrule's side of the Modbus peer tests (tests/peers/peers_test.py): the same modes as
// libmodbus_peer.c, so each real peer meets ferrule in both roles.
//
//   ferrule_peer rtu-server TTY UNIT          serve the peer map on a serial line (19200 8N1)
//   ferrule_peer tcp-server PORT              serve it on 127.0.0.1:PORT (many clients)
//   ferrule_peer rtu-client TTY UNIT [--extras]   check a server of the peer map
//   ferrule_peer tcp-client PORT UNIT [--extras]
//
// The peer map is described in libmodbus_peer.c. --extras adds the checks a peer server may
// not support: diagnostics (FC 8) and device identification (FC 43/14). Each check prints
// "ok NAME" or "FAIL NAME: why"; the last line is "N passed, M failed".
#include <asio/io_context.hpp>
#include <asio/signal_set.hpp>

#include <array>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "ferrule/host/modbus_tcp_server.hpp"
#include "ferrule/host/serial_port.hpp"
#include "ferrule/host/serial_stream.hpp"
#include "ferrule/host/serve.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/memory_model.hpp"
#include "ferrule/modbus/server.hpp"

namespace {

namespace mb = ferrule::modbus;
using namespace std::chrono_literals;

constexpr std::size_t map_size = 100;
constexpr ferrule::serial_format line_format{19200, 8, ferrule::parity::none, 1};

// The peer map, and exception 04 for a write of 0xDEAD to holding register 99.
class peer_model {
public:
    peer_model() : mem_({}, {"ferrule", "FR-PEER", "1.0"}) {
        for (std::size_t i = 0; i < map_size; ++i) {
            mem_.set_coil(i, i % 3 == 0);
            mem_.set_discrete_input(i, i % 2 == 1);
            mem_.holding_registers()[i] = static_cast<std::uint16_t>(0x1000 + i);
            mem_.input_registers()[i] = static_cast<std::uint16_t>(0x2000 + i);
        }
    }
    std::uint8_t read_bits(mb::function fc, std::uint16_t a, std::uint16_t q,
                           std::span<std::uint8_t> out) {
        return mem_.read_bits(fc, a, q, out);
    }
    std::uint8_t read_registers(mb::function fc, std::uint16_t a, std::uint16_t q,
                                std::span<std::uint8_t> out) {
        return mem_.read_registers(fc, a, q, out);
    }
    std::uint8_t write_coils(std::uint16_t a, std::uint16_t q, std::span<const std::uint8_t> in) {
        return mem_.write_coils(a, q, in);
    }
    std::uint8_t write_registers(std::uint16_t a, std::uint16_t q,
                                 std::span<const std::uint8_t> in) {
        const std::size_t at99 = 99u - a;
        if (a <= 99 && 99u < a + q && in[2 * at99] == 0xDE && in[2 * at99 + 1] == 0xAD)
            return mb::code_of(mb::exception_code::server_device_failure);
        return mem_.write_registers(a, q, in);
    }
    std::string_view device_id(std::uint8_t id) { return mem_.device_id(id); }

private:
    mb::memory_model<map_size, map_size, map_size, map_size> mem_;
};

int serve_rtu(const std::string& path, std::uint8_t unit) {
    asio::io_context ctx;
    asio::serial_port port(ctx);
    ferrule::host::serial_options so;
    so.format = line_format;
    if (auto ec = ferrule::host::open_serial(port, path, so, [](std::string_view) {})) {
        std::fprintf(stderr, "%s\n", ferrule::host::open_error_message(path, ec).c_str());
        return 3;
    }
    ferrule::host::serial_stream line(ctx, port);
    mb::server_config cfg;
    cfg.units = mb::unit_set{unit};
    cfg.format = line_format;
    mb::server<peer_model> server(cfg);
    static std::atomic<bool> stop{false};
    std::signal(SIGTERM, [](int) { stop = true; });
    std::printf("ready\n");
    std::fflush(stdout);
    if (auto ec = ferrule::host::serve(line, server, stop)) {
        std::fprintf(stderr, "serve: %s\n", ec.message().c_str());
        return 3;
    }
    return 0;
}

int serve_tcp(std::uint16_t port) {
    asio::io_context ctx;
    peer_model model;
    ferrule::host::modbus_tcp_server<peer_model> server(ctx.get_executor(), model);
    if (auto ec = server.listen({asio::ip::make_address("127.0.0.1"), port})) {
        std::fprintf(stderr, "listen: %s\n", ec.message().c_str());
        return 3;
    }
    asio::signal_set signals(ctx, SIGTERM, SIGINT);
    signals.async_wait([&](std::error_code, int) {
        server.close();
        ctx.stop();
    });
    std::printf("ready\n");
    std::fflush(stdout);
    ctx.run();
    return 0;
}

int passed = 0, failed = 0;

void check(const char* name, bool ok, std::error_code ec = {}) {
    ok ? ++passed : ++failed;
    if (ok)
        std::printf("ok %s\n", name);
    else
        std::printf("FAIL %s: %s\n", name, ec ? ec.message().c_str() : "wrong values");
    std::fflush(stdout);
}

template <class Stream>
int client(Stream& line, mb::client& c, std::uint8_t unit, bool extras, bool rtu) {
    std::array<bool, 20> bits{};
    std::array<std::uint16_t, 10> regs{};
    auto ec = mb::read_coils(line, c, unit, 0, bits);
    bool ok = !ec;
    for (std::size_t i = 0; ok && i < bits.size(); ++i) ok = bits[i] == (i % 3 == 0);
    check("FC1 read coils 0-19", ok, ec);
    ec = mb::read_discrete_inputs(line, c, unit, 3, bits);
    ok = !ec;
    for (std::size_t i = 0; ok && i < bits.size(); ++i) ok = bits[i] == ((i + 3) % 2 == 1);
    check("FC2 read discrete inputs 3-22", ok, ec);
    ec = mb::read_holding_registers(line, c, unit, 0, regs);
    ok = !ec;
    for (std::size_t i = 0; ok && i < regs.size(); ++i) ok = regs[i] == 0x1000 + i;
    check("FC3 read holding registers 0-9", ok, ec);
    ec = mb::read_input_registers(line, c, unit, 90, regs);
    ok = !ec;
    for (std::size_t i = 0; ok && i < regs.size(); ++i) ok = regs[i] == 0x2000 + 90 + i;
    check("FC4 read input registers 90-99", ok, ec);

    std::array<bool, 1> one{};
    ec = mb::write_coil(line, c, unit, 10, true);
    if (!ec) ec = mb::read_coils(line, c, unit, 10, one);
    check("FC5 write coil 10 on, read back", !ec && one[0], ec);
    std::array<std::uint16_t, 1> reg{};
    ec = mb::write_register(line, c, unit, 5, 0x1234);
    if (!ec) ec = mb::read_holding_registers(line, c, unit, 5, reg);
    check("FC6 write register 5, read back", !ec && reg[0] == 0x1234, ec);
    const std::array<bool, 10> pattern{true,  true, false, true, false,
                                       false, true, false, true, true};
    std::array<bool, 10> back{};
    ec = mb::write_coils(line, c, unit, 20, pattern);
    if (!ec) ec = mb::read_coils(line, c, unit, 20, back);
    check("FC15 write coils 20-29, read back", !ec && back == pattern, ec);
    const std::array<std::uint16_t, 5> values{1, 2, 0xFFFF, 0x8000, 42};
    std::array<std::uint16_t, 5> vback{};
    ec = mb::write_registers(line, c, unit, 30, values);
    if (!ec) ec = mb::read_holding_registers(line, c, unit, 30, vback);
    check("FC16 write registers 30-34, read back", !ec && vback == values, ec);
    const std::array<std::uint16_t, 2> w{0xAAAA, 0x5555};
    std::array<std::uint16_t, 4> rw{};
    ec = mb::read_write_registers(line, c, unit, 39, rw, 40, w);
    check("FC23 write 40-41 and read 39-42 in one request",
          !ec && rw == std::array<std::uint16_t, 4>{0x1000 + 39, 0xAAAA, 0x5555, 0x1000 + 42}, ec);

    ec = mb::read_holding_registers(line, c, unit, 100, reg);
    check("exception 02: read holding register 100",
          ec == ferrule::error(mb::device_errc::illegal_data_address), ec);

    if (extras) {
        const auto echo = mb::diagnostics(line, c, unit, mb::diag_sub::return_query_data, 0xA537);
        check("FC8 sub-function 0 echoes the data", echo && *echo == 0xA537, echo.error());
        if (rtu) {
            const auto n = mb::diagnostics(line, c, unit, mb::diag_sub::bus_message_count);
            check("FC8 sub-function 11 bus message count", n && *n > 0, n.error());
        }
        const auto id = mb::read_device_identification(line, c, unit);
        bool found = false;
        if (id) {
            auto rest = id->data;
            mb::device_id_object o;
            while (mb::next_device_id_object(rest, o))
                if (o.id == 0)
                    found = std::string_view(reinterpret_cast<const char*>(o.value.data()),
                                             o.value.size()) == "ferrule";
        }
        check("FC43/14 device identification", id && found, id.error());
    }

    if (rtu) { // a broadcast is executed and not answered; the client keeps the turnaround
        ec = mb::write_register(line, c, mb::broadcast_address, 50, 0x0777);
        if (!ec) ec = mb::read_holding_registers(line, c, unit, 50, reg);
        check("broadcast write register 50, read back from the unit", !ec && reg[0] == 0x0777, ec);
    }
    std::printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

int rtu_client(const std::string& path, std::uint8_t unit, bool extras) {
    asio::io_context ctx;
    asio::serial_port port(ctx);
    ferrule::host::serial_options so;
    so.format = line_format;
    if (auto ec = ferrule::host::open_serial(port, path, so, [](std::string_view) {})) {
        std::fprintf(stderr, "%s\n", ferrule::host::open_error_message(path, ec).c_str());
        return 3;
    }
    ferrule::host::serial_stream line(ctx, port);
    mb::client_config cfg;
    cfg.format = line_format;
    cfg.inter_frame_gap = mb::t35(line_format);
    mb::client c(cfg);
    return client(line, c, unit, extras, true);
}

int tcp_client(std::uint16_t port, std::uint8_t unit, bool extras) {
    asio::io_context ctx;
    asio::ip::tcp::socket socket(ctx);
    std::error_code ec;
    socket.connect({asio::ip::make_address("127.0.0.1"), port}, ec);
    if (ec) {
        std::fprintf(stderr, "connect: %s\n", ec.message().c_str());
        return 3;
    }
    ferrule::host::tcp_stream line(ctx, socket);
    mb::client_config cfg;
    cfg.rtu = false;
    mb::client c(cfg);
    return client(line, c, unit, extras, false);
}

} // namespace

int main(int argc, char** argv) {
    const std::string mode = argc > 1 ? argv[1] : "";
    const bool extras = std::string_view(argv[argc - 1]) == "--extras";
    const auto unit = static_cast<std::uint8_t>(argc > 3 ? std::atoi(argv[3]) : 1);
    if (mode == "rtu-server" && argc > 3) return serve_rtu(argv[2], unit);
    if (mode == "tcp-server" && argc > 2)
        return serve_tcp(static_cast<std::uint16_t>(std::atoi(argv[2])));
    if (mode == "rtu-client" && argc > 3) return rtu_client(argv[2], unit, extras);
    if (mode == "tcp-client" && argc > 3)
        return tcp_client(static_cast<std::uint16_t>(std::atoi(argv[2])), unit, extras);
    std::fprintf(stderr,
                 "usage: %s rtu-server TTY UNIT | tcp-server PORT | rtu-client TTY UNIT "
                 "[--extras] | tcp-client PORT UNIT [--extras]\n",
                 argv[0]);
    return 2;
}
