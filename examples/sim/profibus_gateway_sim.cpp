// ferrule-sim profibus-gateway: gateway::core on its two lines, run by host::serve_gateway()
// from one thread. The simulated drives, when there are any, run on
// their own pty in a pty_server thread, exactly as `ferrule-sim modbus` serves them; the
// gateway opens that pty as its drive port, so the simulated and a real drive line take the
// same path through the code.
//
// A pty has no wire time and no baud rate: DP answers go out min_TSDR (11 tbit at --dp-baud)
// after a request has been read, and the Modbus client waits no t3.5 before a request on the
// internal pty (inter_frame_gap 0, as the modbus simulator and the CLI's --gap 0 do).
#include "profibus_gateway_sim.hpp"

#include <unistd.h>

#include <fmt/core.h>

#include <asio/io_context.hpp>
#include <asio/serial_port.hpp>

#include <array>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <ctime>
#include <deque>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "../common/hex.hpp"
#include "ferrule/host/pty_server.hpp"
#include "ferrule/host/serial_port.hpp"
#include "ferrule/host/serial_stream.hpp"
#include "ferrule/host/serve_gateway.hpp"
#include "ferrule/gateway/gateway.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/sim/station.hpp"
#include "ferrule/profibus/services.hpp"

namespace ferrule::sim_app {
namespace {

namespace mb = ferrule::modbus;
namespace pb = ferrule::profibus;

struct gateway_options {
    std::string link;
    unsigned address = 8;
    unsigned ident = 0x0815;
    std::uint32_t dp_baud = 19'200;
    std::string mode = "transparent";
    std::string cfg = "24 14";
    bool status_word = false;
    unsigned drive_unit = 1;
    std::string drive_port;
    std::uint32_t drive_baud = 19'200;
    std::string dp_port;
};

using tools::hex;
using tools::parse_hex;

// Simulated VFDs on their own pty, served by a thread until the object goes.
class simulated_drives {
public:
    explicit simulated_drives(unsigned unit) {
        mb::server_config cfg;
        cfg.units = mb::unit_set{static_cast<std::uint8_t>(unit)};
        // A pty has no wire time: frames end after t3.5 of a fast line (1.75 ms).
        cfg.format = {host::pty_line_baud, 8, parity::even, 1};
        drives_.emplace_back(cfg);
        for (auto& d : drives_) server_.add(d);
    }
    simulated_drives(const simulated_drives&) = delete;
    simulated_drives& operator=(const simulated_drives&) = delete;
    ~simulated_drives() {
        done_ = true;
        if (thread_.joinable()) thread_.join();
    }

    std::error_code start() {
        if (auto ec = server_.open()) return ec;
        thread_ = std::thread([this] { server_.run(done_); });
        return {};
    }
    const std::string& path() const noexcept { return server_.path(); }

private:
    std::deque<mb::sim::station> drives_;
    host::pty_server<mb::sim::station> server_{};
    std::atomic<bool> done_{false};
    std::thread thread_;
};

// The DP line: the simulator's end of a pty, or a serial port given with --dp-port.
struct dp_line {
    int fd = -1;
    const host::pseudo_terminal* pty = nullptr;
    void operator()(std::span<const std::uint8_t> bytes) const {
        if (pty) {
            (void)pty->write(bytes); // no reader: lost, as on an open line
            return;
        }
        std::size_t off = 0;
        while (off < bytes.size()) {
            const ssize_t n = ::write(fd, bytes.data() + off, bytes.size() - off);
            if (n <= 0) return; // the port failed: the telegram is lost
            off += static_cast<std::size_t>(n);
        }
    }
};

int serve_gateway(const gateway_options& o, const std::atomic<bool>& stop) {
    std::vector<std::uint8_t> cfg_bytes;
    if (!parse_hex(o.cfg, cfg_bytes))
        throw CLI::ValidationError("--cfg", "configuration identifiers as hex bytes, e.g. 24 14");
    const auto sizes = pb::cfg_io_sizes(cfg_bytes);
    if (!sizes || sizes->inputs > pb::slave::max_io || sizes->outputs > pb::slave::max_io)
        throw CLI::ValidationError("--cfg", "not a valid DP configuration of at most 246 bytes "
                                            "each way");

    std::unique_ptr<simulated_drives> sim;
    std::string drive_path = o.drive_port;
    if (drive_path.empty()) {
        sim = std::make_unique<simulated_drives>(o.drive_unit);
        if (auto ec = sim->start()) {
            fmt::print(stderr, "ferrule-sim: openpty: {}\n", ec.message());
            return 3;
        }
        drive_path = sim->path();
    }

    gateway::config gc;
    gc.dp.baud = o.dp_baud;
    gc.dp.address = static_cast<std::uint8_t>(o.address);
    gc.dp.ident = static_cast<std::uint16_t>(o.ident);
    gc.dp.cfg = cfg_bytes;
    gc.modbus.format = {o.drive_baud, 8, parity::even, 1};
    gc.modbus.inter_frame_gap = sim ? duration::zero() : mb::t35(gc.modbus.format);
    gc.mode = gateway::mode::transparent;
    gc.drive = static_cast<std::uint8_t>(o.drive_unit);
    gc.status_word = o.status_word;

    asio::io_context ctx;
    asio::serial_port port(ctx);
    host::serial_options so;
    so.format = gc.modbus.format;
    // The internal pty takes no baud rate or parity; only a port the user gave is worth a word.
    const auto warn = [&](std::string_view text) {
        if (!sim) fmt::print(stderr, "ferrule-sim: warning: {}\n", text);
    };
    if (auto ec = host::open_serial(port, drive_path, so, warn)) {
        fmt::print(stderr, "ferrule-sim: --drive-port: {}\n",
                   host::open_error_message(drive_path, ec));
        return 3;
    }
    host::serial_stream drive(ctx, port);

    // The DP side: a pty for a master on this machine, or a real port (--dp-port).
    host::pseudo_terminal pty;
    asio::serial_port dp_port(ctx);
    dp_line dp;
    std::string dp_name;
    if (o.dp_port.empty()) {
        if (auto ec = pty.open()) {
            fmt::print(stderr, "ferrule-sim: openpty: {}\n", ec.message());
            return 3;
        }
        if (!o.link.empty()) {
            if (auto ec = pty.link(o.link)) {
                fmt::print(stderr, "ferrule-sim: --link: {}\n", host::link_refusal(o.link, ec));
                return 2;
            }
        }
        dp = {pty.fd(), &pty};
        dp_name = pty.path() + (o.link.empty() ? "" : " (link " + o.link + ")");
        fmt::print("{}\n", o.link.empty() ? pty.path() : o.link);
    } else {
        host::serial_options dso;
        dso.format = pb::format(o.dp_baud);
        const auto dp_warn = [](std::string_view text) {
            fmt::print(stderr, "ferrule-sim: warning: {}\n", text);
        };
        if (auto ec = host::open_serial(dp_port, o.dp_port, dso, dp_warn)) {
            fmt::print(stderr, "ferrule-sim: --dp-port: {}\n",
                       host::open_error_message(o.dp_port, ec));
            return 3;
        }
        dp = {dp_port.native_handle(), nullptr};
        dp_name = o.dp_port;
        fmt::print("{}\n", o.dp_port);
    }
    gateway::core gw(gc);
    std::fflush(stdout);
    fmt::print(stderr,
               "ferrule-sim: PROFIBUS-DP gateway, slave {} (ident 0x{:04X}, cfg {}: {} bytes out, "
               "{} in{}) on {}; transparent to Modbus unit {} on {}{}; Ctrl-C to stop\n",
               o.address, o.ident, hex(cfg_bytes), sizes->outputs, sizes->inputs,
               o.status_word ? ", status word first" : "", dp_name, o.drive_unit, drive_path,
               sim ? " (a simulated VFD)" : "");
    const bool stopped = host::serve_gateway(gw, dp.fd, dp, drive, port.native_handle(), stop);
    if (!stopped) fmt::print(stderr, "ferrule-sim: the drive line {} hung up\n", drive_path);

    const auto& d = gw.dp().stats();
    const auto& s = gw.stats();
    fmt::print(stderr,
               "ferrule-sim: DP: {} requests, {} data exchanges, {} Prm faults, {} Cfg faults; "
               "Modbus: {} commands, {} delivered, {} failed, {} exceptions, {} overflowed\n",
               d.requests, d.data_exchanges, d.prm_faults, d.cfg_faults, s.commands, s.delivered,
               s.failed, s.exceptions, s.overflowed);
    return stopped ? 0 : 3;
}

} // namespace

void add_profibus_gateway(CLI::App& app, const std::atomic<bool>& stop, int& rc) {
    auto o = std::make_shared<gateway_options>();
    auto* sub = app.add_subcommand(
        "profibus-gateway",
        "a PROFIBUS-DP slave on a pty that passes Modbus requests to a drive line (transparent "
        "mode): simulated VFDs, or --drive-port");
    sub->add_option("--link", o->link,
                    "also create this symlink to the DP pty where nothing is (or a stale link); "
                    "removed on exit");
    sub->add_option("--address,-a", o->address, "DP station address (0-126)")
        ->check(CLI::Range(0, 126))
        ->capture_default_str();
    sub->add_option("--ident", o->ident,
                    "Ident_Number (0x0001-0xFFFE), as in examples/gateway/ferrule_gateway.gsd")
        ->check(CLI::Range(0x0001, 0xFFFE))
        ->default_str("0x0815");
    sub->add_option("--dp-baud", o->dp_baud, "DP baud rate (sets the reply delay min_TSDR)")
        ->check(CLI::IsMember({9'600, 19'200, 45'450, 93'750, 187'500, 500'000, 1'500'000,
                               3'000'000, 6'000'000, 12'000'000}))
        ->capture_default_str();
    sub->add_option("--mode", o->mode, "transparent: the DP outputs carry a Modbus request PDU")
        ->check(CLI::IsMember({"transparent"}))
        ->capture_default_str();
    sub->add_option("--cfg", o->cfg,
                    "configuration identifiers (Chk_Cfg), hex; the GSD's modules: 24 14 = 5 bytes "
                    "out, 5 in")
        ->capture_default_str();
    sub->add_flag("--status-word", o->status_word,
                  "the first two input bytes are the gateway's status word (GSD: the status "
                  "word modules)");
    sub->add_option("--drive-unit", o->drive_unit, "Modbus unit of the drive (1-247)")
        ->check(CLI::Range(1, 247))
        ->capture_default_str();
    sub->add_option("--drive-port", o->drive_port,
                    "the drive line: a serial port or a `ferrule-sim modbus` pty (default: a "
                    "simulated VFD on an internal pty)");
    sub->add_option("--dp-port", o->dp_port,
                    "the DP line: a serial port (an RS-485 adapter on a DP bus) instead of a pty; "
                    "the host meets max TSDR at 9.6 and 19.2 kbit/s")
        ->excludes("--link");
    sub->add_option("--drive-baud", o->drive_baud, "drive line baud rate (8E1)")
        ->check(CLI::IsMember({1'200, 2'400, 4'800, 9'600, 19'200, 38'400, 57'600, 115'200}))
        ->capture_default_str();
    sub->callback([o, &stop, &rc] { rc = serve_gateway(*o, stop); });
}

} // namespace ferrule::sim_app
