// ferrule-sim: simulated devices on a pseudo-terminal (and Modbus TCP). Prints the device
// path to open (and keeps a symlink with --link); runs until interrupted.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <asio/io_context.hpp>
#include <asio/ip/address.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "ferrule/host/modbus_tcp_server.hpp"
#include "ferrule/host/pty_server.hpp"
#include "ferrule/dimetix/sim/sensor.hpp"
#include "ferrule/lecom/constants.hpp"
#include "ferrule/lecom/sim/station.hpp"
#include "ferrule/movilink/sim/station.hpp"
#include "memobus_sim.hpp"
#include "modbus_sim.hpp"
#include "profibus_gateway_sim.hpp"

namespace {

std::atomic<bool> stop{false};
extern "C" void on_signal(int) {
    stop = true;
}

struct sim_options {
    std::vector<unsigned> addresses;
    // MOVILINK drives
    unsigned warning = 0;
    unsigned fault = 0;
    // Dimetix sensors
    double distance_mm = 1234.5;
    double noise_mm = 0;
    double slope_mm_s = 0;
    unsigned measurement_ms = 100;
    int error = 0;
    // LECOM drives
    std::string family = "4900";
    bool bare_replies = false;
    unsigned trip = 0;
    // Modbus VFDs
    std::optional<std::uint16_t> tcp_port;
    bool tcp_only = false;
    std::size_t tcp_connections = 64;
    double idle_timeout_s = 60;
    double request_timeout_s = 2;
    std::string link;
    double drop = 0;
    double corrupt = 0;
    unsigned delay_ms = 0;
    unsigned seed = 1;
};

ferrule::host::pty_faults faults(const sim_options& o) {
    ferrule::host::pty_faults f;
    f.drop_percent = o.drop;
    f.corrupt_percent = o.corrupt;
    f.extra_delay = std::chrono::milliseconds(o.delay_ms);
    f.seed = o.seed;
    return f;
}

// `prepare(stations)` runs once the pty is open, before serving. `also` is a line printed on
// stdout after the device path (ferrule-sim modbus: the TCP server's address).
template <class Station, class Prepare>
int serve(const sim_options& o, std::deque<Station>& stations, const char* what, Prepare prepare,
          const std::string& also = {}) {
    ferrule::host::pty_server<Station> server(faults(o));
    if (auto ec = server.open()) {
        fmt::print(stderr, "ferrule-sim: openpty: {}\n", ec.message());
        return 3;
    }
    for (auto& st : stations) server.add(st);
    if (!o.link.empty()) {
        if (auto ec = server.link(o.link)) {
            fmt::print(stderr, "ferrule-sim: --link: {}\n",
                       ferrule::host::link_refusal(o.link, ec));
            return 2;
        }
    }
    prepare(stations);
    fmt::print("{}\n", o.link.empty() ? server.path() : o.link);
    if (!also.empty()) fmt::print("{}\n", also);
    fmt::print(stderr, "ferrule-sim: {} on {}{}{}; Ctrl-C to stop\n", what, server.path(),
               o.link.empty() ? "" : " (link ", o.link.empty() ? "" : o.link + ")");
    std::fflush(stdout);
    server.run(stop);
    const auto& s = server.stats();
    fmt::print(stderr, "ferrule-sim: {} bytes in, {} replies, {} dropped, {} corrupted\n",
               s.bytes_in, s.replies, s.dropped, s.corrupted);
    return 0;
}

void add_common(CLI::App& sub, sim_options& o, const char* address_help,
                const std::string& address_names = "--address,-a") {
    sub.add_option(address_names, o.addresses, address_help);
    sub.add_option("--link", o.link,
                   "also create this symlink to the pty where nothing is (or a stale link); "
                   "removed on exit");
    sub.add_option("--drop", o.drop, "percent of replies never sent")
        ->check(CLI::Range(0.0, 100.0));
    sub.add_option("--corrupt", o.corrupt, "percent of replies with a damaged byte")
        ->check(CLI::Range(0.0, 100.0));
    sub.add_option("--delay", o.delay_ms, "extra delay of every reply in ms");
    sub.add_option("--seed", o.seed, "seed of the fault pattern");
}

// The first unit's drive over TCP on an asio thread until `stop`; its address on `listening`.
class tcp_side {
public:
    tcp_side(ferrule::modbus::sim::vfd& drive, std::mutex& lock, const sim_options& o)
        : model_(drive, lock), server_(ctx_.get_executor(), model_, tcp_options(o)) {}
    ~tcp_side() {
        if (thread_.joinable()) thread_.join();
    }

    std::error_code listen(std::uint16_t port) {
        return server_.listen({asio::ip::make_address("127.0.0.1"), port});
    }
    std::string address() const { return fmt::format("127.0.0.1:{}", server_.port()); }
    void run() {
        while (!stop) ctx_.run_for(std::chrono::milliseconds(50));
        server_.close();
        const auto& s = server_.stats();
        fmt::print(stderr,
                   "ferrule-sim: TCP: {} connections ({} refused, {} idle closed, {} request "
                   "timeouts, {} bad MBAP headers), {} replies\n",
                   s.accepted.load(), s.refused.load(), s.idle_closed.load(),
                   s.request_timeouts.load(), s.bad_headers.load(), s.replies.load());
    }
    void start() {
        thread_ = std::thread([this] { run(); });
    }

private:
    static ferrule::duration seconds(double s) {
        return std::chrono::duration_cast<ferrule::duration>(std::chrono::duration<double>(s));
    }
    static ferrule::host::modbus_tcp_server_options tcp_options(const sim_options& o) {
        ferrule::host::modbus_tcp_server_options t;
        t.max_connections = o.tcp_connections;
        t.idle_timeout = seconds(o.idle_timeout_s);
        t.request_timeout = seconds(o.request_timeout_s);
        t.processing_time = std::chrono::milliseconds(o.delay_ms);
        t.on_close = [](const asio::ip::tcp::endpoint& client, ferrule::host::close_reason why) {
            if (why != ferrule::host::close_reason::unframeable) return;
            fmt::print(stderr,
                       "ferrule-sim: TCP: closed {}:{}: an MBAP header that no Modbus request "
                       "starts with (protocol id not 0, or length outside 2-254)\n",
                       client.address().to_string(), client.port());
        };
        return t;
    }
    asio::io_context ctx_;
    ferrule::sim_app::locked_vfd model_;
    ferrule::host::modbus_tcp_server<ferrule::sim_app::locked_vfd> server_;
    std::thread thread_;
};

int serve_modbus(sim_options& o) {
    namespace mb = ferrule::modbus;
    if (o.addresses.empty()) o.addresses.push_back(1);
    if (o.tcp_only && !o.tcp_port) throw CLI::ValidationError("--tcp-only", "needs --tcp PORT");
    std::mutex lock;
    std::deque<ferrule::sim_app::locked_station> drives;
    for (unsigned a : o.addresses) {
        for (const auto& d : drives)
            if (d.station.session.config().units.contains(static_cast<std::uint8_t>(a)))
                throw CLI::ValidationError("--unit", fmt::format("{} is given twice", a));
        mb::server_config cfg;
        cfg.units = mb::unit_set{static_cast<std::uint8_t>(a)};
        // A pty has no wire time: frames end after t3.5 of a fast line (1.75 ms).
        cfg.format = {ferrule::host::pty_line_baud, 8, ferrule::parity::even, 1};
        drives.emplace_back(cfg, lock);
    }
    std::optional<tcp_side> tcp;
    if (o.tcp_port) {
        tcp.emplace(drives.front().station.drive(), lock, o);
        if (auto ec = tcp->listen(*o.tcp_port)) {
            fmt::print(stderr, "ferrule-sim: --tcp {}: {}\n", *o.tcp_port, ec.message());
            return 3;
        }
        fmt::print(stderr, "ferrule-sim: Modbus TCP server on {} (unit {}'s VFD, any unit id)\n",
                   tcp->address(), o.addresses.front());
        if (o.tcp_only) {
            fmt::print("{}\n", tcp->address());
            std::fflush(stdout);
            tcp->run();
            return 0;
        }
        tcp->start();
    }
    const int rc = serve(
        o, drives, "simulated Modbus VFDs (RTU)", [](auto&) {},
        tcp ? tcp->address() : std::string());
    stop = true; // the TCP thread ends with the pty, also when the pty could not open
    return rc;
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"ferrule-sim: simulated drives and sensors on a pseudo-terminal"};
    app.require_subcommand(1);
    sim_options o;
    int rc = 0;

    auto* ml = app.add_subcommand("movilink", "SEW MOVITRAC B drives on one MOVILINK line");
    add_common(*ml, o, "RS-485 address (0-99); repeat for several drives on the line (default 1)");
    ml->add_option("--warning", o.warning,
                   "every drive signals this warning number, ready and running (1-255)")
        ->check(CLI::Range(1, 255));
    ml->add_option("--fault", o.fault, "every drive starts in this fault number (1-255)")
        ->check(CLI::Range(1, 255));
    ml->callback([&] {
        if (o.addresses.empty()) o.addresses.push_back(1);
        std::deque<ferrule::movilink::sim::station> drives;
        for (unsigned a : o.addresses) {
            ferrule::movilink::slave_config cfg;
            cfg.format.baud = ferrule::host::pty_line_baud;
            cfg.address = static_cast<std::uint8_t>(a);
            drives.emplace_back(cfg);
        }
        rc = serve(o, drives, "MOVITRAC B simulation", [&](auto& all) {
            for (auto& d : all) {
                d.drive.inject_warning(static_cast<std::uint8_t>(o.warning));
                d.drive.inject_fault(static_cast<std::uint8_t>(o.fault));
            }
        });
    });

    auto* dx = app.add_subcommand("dimetix", "Dimetix D-Series laser distance sensors on one line");
    add_common(*dx, o, "sensor ID (0-99); repeat for several sensors on the line (default 0)");
    dx->add_option("--distance", o.distance_mm, "distance in mm (at start, for --slope)")
        ->capture_default_str();
    dx->add_option("--slope", o.slope_mm_s, "distance change in mm/s");
    dx->add_option("--noise", o.noise_mm, "uniform noise in +-mm");
    dx->add_option("--measurement-time", o.measurement_ms,
                   "ms per measurement (the sensor: 50-4000)")
        ->capture_default_str();
    dx->add_option("--error", o.error, "the first measurement fails with this code (e.g. 255)");
    dx->callback([&] {
        if (o.addresses.empty()) o.addresses.push_back(0);
        namespace dsim = ferrule::dimetix::sim;
        std::deque<dsim::d_series> sensors;
        for (unsigned a : o.addresses) {
            dsim::d_series_config cfg;
            cfg.id = static_cast<std::uint8_t>(a);
            cfg.distance = static_cast<std::int32_t>(o.distance_mm * 10);
            cfg.slope = static_cast<std::int32_t>(o.slope_mm_s * 10);
            cfg.shape = o.slope_mm_s != 0 ? dsim::profile::ramp : dsim::profile::constant;
            cfg.noise = static_cast<std::int32_t>(o.noise_mm * 10);
            cfg.seed = o.seed + a;
            cfg.measurement_time = std::chrono::milliseconds(o.measurement_ms);
            sensors.emplace_back(cfg);
        }
        rc = serve(o, sensors, "Dimetix D-Series simulation", [&](auto& all) {
            // Power-up: each sensor sends its startup string gN? when it is ready (S1 §8.1.5).
            for (auto& s : all) {
                s.power_on(ferrule::host::steady_now());
                if (o.error) s.inject_error(o.error);
            }
        });
    });

    auto* lc = app.add_subcommand("lecom", "Lenze drives (4900 DC, 8200) on one LECOM-B line");
    add_common(*lc, o,
               "unit address C0009 (1-99 except 10, 20 ... 90); repeat or give a list for "
               "several drives on the line (default 1)");
    lc->get_option("--address")
        ->delimiter(',')
        ->check(CLI::Validator(
            [](std::string& s) -> std::string {
                const int a = std::atoi(s.c_str());
                return ferrule::lecom::is_unit_address(static_cast<std::uint8_t>(a)) && a <= 99
                           ? ""
                           : "not a unit address: 1-99 except 10, 20 ... 90 (S1 p.6-3)";
            },
            "ADDRESS"));
    lc->add_option("--family", o.family, "drive family: code table and C0200")
        ->check(CLI::IsMember({"4900", "8200"}))
        ->capture_default_str();
    lc->add_flag("--bare-replies", o.bare_replies,
                 "4900 style: bare EOT for an unknown code, bare NAK for a checksum fault");
    lc->add_option("--trip", o.trip, "start with this fault number in C0067 (reset: C0043 = 0)")
        ->check(CLI::Range(1, 65535));
    lc->callback([&] {
        if (o.addresses.empty()) o.addresses.push_back(1);
        namespace lsim = ferrule::lecom::sim;
        // LECOM frames telegrams by their characters, not by gaps: a pty needs no line baud.
        std::deque<lsim::station> drives;
        for (unsigned a : o.addresses) {
            for (const auto& d : drives)
                if (d.session.address() == a)
                    throw CLI::ValidationError("--address", fmt::format("{} is given twice", a));
            ferrule::lecom::slave_config cfg;
            cfg.address = static_cast<std::uint8_t>(a);
            cfg.bare_replies = o.bare_replies;
            lsim::drive_config drive;
            drive.family = o.family == "8200" ? lsim::drive_family::lenze_8200
                                              : lsim::drive_family::lenze_4900;
            drives.emplace_back(cfg, drive);
        }
        const std::string what = fmt::format("Lenze {} LECOM simulation", o.family);
        rc = serve(o, drives, what.c_str(), [&](auto& all) {
            if (o.trip)
                for (auto& d : all) d.drive.trip(static_cast<std::uint16_t>(o.trip));
        });
    });

    auto* mbs = app.add_subcommand(
        "modbus", "simulated VFDs as a Modbus RTU server on a pty and/or a Modbus TCP server");
    add_common(*mbs, o,
               "unit id (1-247) of a simulated VFD; repeat for several on the line (default 1)",
               "--unit,--address,-a");
    mbs->get_option("--unit")->check(CLI::Range(1, 247));
    mbs->add_option("--tcp", o.tcp_port,
                    "also serve the first unit's VFD as a Modbus TCP server on 127.0.0.1:PORT (0: "
                    "any free port)");
    mbs->add_flag("--tcp-only", o.tcp_only, "serve only over TCP, no pty (needs --tcp)");
    mbs->add_option("--connections", o.tcp_connections,
                    "TCP clients at once; one more is accepted and closed at once")
        ->check(CLI::Range(1, 1024))
        ->capture_default_str();
    mbs->add_option("--idle-timeout", o.idle_timeout_s,
                    "s without a complete request after which a TCP client is closed (0: never)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    mbs->add_option("--request-timeout", o.request_timeout_s,
                    "s from a request's first byte by which it must be complete, or the TCP "
                    "client is closed (0: never)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    mbs->callback([&] { rc = serve_modbus(o); });

    ferrule::sim_app::add_profibus_gateway(app, stop, rc);
    ferrule::sim_app::add_memobus(app, stop, rc);

    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }
    return rc;
}
