// ferrule-sim: simulated devices on a pseudo-terminal. Prints the device path to open
// (and keeps a symlink with --link); runs until interrupted.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <deque>
#include <vector>

#include "ferrule/asio/pty_server.hpp"
#include "ferrule/movilink/sim_station.hpp"

namespace {

std::atomic<bool> stop{false};
extern "C" void on_signal(int) {
    stop = true;
}

struct sim_options {
    std::vector<unsigned> addresses;
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

template <class Station>
int serve(const sim_options& o, std::deque<Station>& stations, const char* what) {
    ferrule::host::pty_server<Station> server(faults(o));
    if (auto ec = server.open()) {
        fmt::print(stderr, "ferrule-sim: openpty: {}\n", ec.message());
        return 3;
    }
    for (auto& st : stations) server.add(st);
    if (!o.link.empty()) {
        if (auto ec = server.link(o.link)) {
            fmt::print(stderr, "ferrule-sim: --link {}: {}\n", o.link, ec.message());
            return 3;
        }
    }
    fmt::print("{}\n", o.link.empty() ? server.path() : o.link);
    fmt::print(stderr, "ferrule-sim: {} on {}{}{}; Ctrl-C to stop\n", what, server.path(),
               o.link.empty() ? "" : " (link ", o.link.empty() ? "" : o.link + ")");
    std::fflush(stdout);
    server.run(stop);
    const auto& s = server.stats();
    fmt::print(stderr, "ferrule-sim: {} bytes in, {} replies, {} dropped, {} corrupted\n",
               s.bytes_in, s.replies, s.dropped, s.corrupted);
    return 0;
}

void add_common(CLI::App& sub, sim_options& o, const char* address_help) {
    sub.add_option("--address,-a", o.addresses, address_help);
    sub.add_option("--link", o.link, "also create this symlink to the pty (removed on exit)");
    sub.add_option("--drop", o.drop, "percent of replies never sent")
        ->check(CLI::Range(0.0, 100.0));
    sub.add_option("--corrupt", o.corrupt, "percent of replies with a damaged byte")
        ->check(CLI::Range(0.0, 100.0));
    sub.add_option("--delay", o.delay_ms, "extra delay of every reply in ms");
    sub.add_option("--seed", o.seed, "seed of the fault pattern");
}

} // namespace

int main(int argc, char** argv) {
    CLI::App app{"ferrule-sim: simulated drives and sensors on a pseudo-terminal"};
    app.require_subcommand(1);
    sim_options o;
    int rc = 0;

    auto* ml = app.add_subcommand("movilink", "SEW MOVITRAC B drives on one MOVILINK line");
    add_common(*ml, o, "RS-485 address (0-99); repeat for several drives on the line (default 1)");
    ml->callback([&] {
        if (o.addresses.empty()) o.addresses.push_back(1);
        std::deque<ferrule::movilink::sim::station> drives;
        for (unsigned a : o.addresses) {
            ferrule::movilink::slave_config cfg;
            cfg.format.baud = ferrule::host::pty_line_baud;
            cfg.address = static_cast<std::uint8_t>(a);
            drives.emplace_back(cfg);
        }
        rc = serve(o, drives, "MOVITRAC B simulation");
    });

    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }
    return rc;
}
