// ferrule-sim memobus. host::memobus_server serves one register image (MW00000…MW65534,
// IW0000…IW4095) on one io_context thread, this one; each TCP connection or UDP master (an IP
// address) is a channel with the same offsets and write range. A timer on the same io_context
// moves the live registers, so the image is only ever touched from that thread:
//
//   IW00000  counts up every 100 ms
//   IW00001  seconds since the start
//
// stdout: the TCP address (IP:PORT; with --udp the UDP socket has the same port). stderr: a
// line for each burst of UDP commands refused for want of a channel, and on exit the server's
// counts and each channel's.
#include "memobus_sim.hpp"

#include <fmt/core.h>

#include <asio/io_context.hpp>
#include <asio/ip/address.hpp>
#include <asio/steady_timer.hpp>

#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "ferrule/host/memobus_server.hpp"
#include "ferrule/memobus/register_image.hpp"

namespace ferrule::sim_app {
namespace {

namespace mb = ferrule::memobus;
using image_type = mb::register_image<65535, 4096>;

struct memobus_sim_options {
    std::uint16_t port = 10001; // the Yaskawa sample's example port (§6)
    std::string bind = "127.0.0.1";
    bool udp = false;
    std::size_t channels = 4; // 218IFA (seeds/004); the 218IF has 10
    double idle_timeout_s = 60;
    double request_timeout_s = 2;
    std::uint16_t mw_offset = 0;
    std::uint16_t iw_offset = 0;
    std::uint16_t mb_offset = 0;
    std::uint16_t ib_offset = 0;
    std::string write_range = "0-65534";
    std::string data_order = "big";
};

// "LOW-HIGH" as MW words 0…65534, LOW <= HIGH.
bool parse_range(const std::string& s, std::uint16_t& low, std::uint16_t& high) {
    unsigned long a = 0;
    unsigned long b = 0;
    char dash = 0;
    char rest = 0;
    if (std::sscanf(s.c_str(), "%lu%c%lu%c", &a, &dash, &b, &rest) != 3 || dash != '-' || a > b ||
        b > 65534)
        return false;
    low = static_cast<std::uint16_t>(a);
    high = static_cast<std::uint16_t>(b);
    return true;
}

// Moves IW00000 and IW00001 every 100 ms, on the server's io_context.
class live_registers {
public:
    live_registers(asio::io_context& ctx, image_type& image) : timer_(ctx), image_(image) {
        tick();
    }

private:
    void tick() {
        timer_.expires_after(std::chrono::milliseconds(100));
        timer_.async_wait([this](std::error_code ec) {
            if (ec) return;
            ++ticks_;
            image_.set_iw(0, static_cast<std::uint16_t>(ticks_));
            image_.set_iw(1, static_cast<std::uint16_t>(ticks_ / 10));
            tick();
        });
    }

    asio::steady_timer timer_;
    image_type& image_;
    std::uint32_t ticks_ = 0;
};

ferrule::duration seconds(double s) {
    return std::chrono::duration_cast<ferrule::duration>(std::chrono::duration<double>(s));
}

// One line for the first UDP command refused, then none until `quiet` passes without a
// refusal: a master that resends, or several at once, make one line; the exit counts have all.
class refusal_log {
public:
    refusal_log(std::size_t channels, double idle_timeout_s)
        : channels_(channels), idle_timeout_s_(idle_timeout_s) {}

    void operator()(const asio::ip::udp::endpoint& from) {
        const auto now = std::chrono::steady_clock::now();
        if (!last_ || now - *last_ >= quiet) {
            const std::string freed =
                idle_timeout_s_ == 0
                    ? std::string("--idle-timeout 0: a silent one is never freed")
                    : fmt::format("a silent one is freed after {} s", idle_timeout_s_);
            fmt::print(stderr,
                       "ferrule-sim: MEMOBUS: no free channel for UDP master {}:{}: all {} in use "
                       "({}); its commands are dropped, the rest of this burst only counted\n",
                       from.address().to_string(), from.port(), channels_, freed);
        }
        last_ = now;
    }

private:
    static constexpr std::chrono::seconds quiet{5};
    std::size_t channels_;
    double idle_timeout_s_;
    std::optional<std::chrono::steady_clock::time_point> last_;
};

void print_stats(const host::memobus_server<image_type>& server) {
    const auto& s = server.stats();
    fmt::print(stderr,
               "ferrule-sim: MEMOBUS: {} TCP connections ({} refused, {} idle closed, {} request "
               "timeouts), {} UDP masters ({} moved to a new port, {} commands refused for want "
               "of a channel, {} datagrams of no master ignored), {} replies\n",
               s.accepted.load(), s.refused.load(), s.idle_closed.load(), s.request_timeouts.load(),
               s.udp_peers.load(), s.udp_moved.load(), s.udp_refused.load(), s.udp_ignored.load(),
               s.replies.load());
    for (std::size_t i = 0; i < server.max_channels(); ++i) {
        const auto c = server.channel_stats(i);
        fmt::print(stderr,
                   "ferrule-sim: channel {}: {} masters, {} requests, {} answered, errors {} SFC "
                   "/ {} address / {} count, {} general, {} ignored, {} malformed, {} bytes in, "
                   "{} bytes out\n",
                   i + 1, c.opened, c.requests, c.responses, c.sfc_errors, c.address_errors,
                   c.count_errors, c.general, c.ignored, c.malformed, c.bytes_in, c.bytes_out);
    }
}

int serve_memobus(const memobus_sim_options& o, const std::atomic<bool>& stop) {
    host::memobus_server_options so;
    so.max_channels = o.channels;
    so.idle_timeout = seconds(o.idle_timeout_s);
    so.request_timeout = seconds(o.request_timeout_s);
    so.channel.mw_offset = o.mw_offset;
    so.channel.iw_offset = o.iw_offset;
    so.channel.mb_offset = o.mb_offset;
    so.channel.ib_offset = o.ib_offset;
    if (!parse_range(o.write_range, so.channel.write_low, so.channel.write_high))
        throw CLI::ValidationError("--write-range", "LOW-HIGH, MW words 0-65534");
    so.channel.order =
        o.data_order == "little" ? mb::data_order::little_endian : mb::data_order::big_endian;
    std::error_code ec;
    const auto address = asio::ip::make_address(o.bind, ec);
    if (ec) throw CLI::ValidationError("--bind", "not an IP address");

    refusal_log refusals(o.channels, o.idle_timeout_s);
    so.on_udp_refused = [&refusals](const asio::ip::udp::endpoint& from) { refusals(from); };

    asio::io_context ctx;
    const auto image = std::make_unique<image_type>();
    host::memobus_server<image_type> server(ctx.get_executor(), *image, so);
    if ((ec = server.listen({address, o.port}))) {
        fmt::print(stderr, "ferrule-sim: --port {}: {}\n", o.port, ec.message());
        return 3;
    }
    if (o.udp && (ec = server.open_udp({address, server.port()}))) {
        fmt::print(stderr, "ferrule-sim: --udp on port {}: {}\n", server.port(), ec.message());
        return 3;
    }
    live_registers live(ctx, *image);
    fmt::print("{}:{}\n", o.bind, server.port());
    fmt::print(
        stderr,
        "ferrule-sim: simulated MP2310 (Extended MEMOBUS) on {}:{} TCP{}, channels for {} masters; "
        "IW00000 counts every 100 ms; Ctrl-C to stop\n",
        o.bind, server.port(), o.udp ? " and UDP" : "", o.channels);
    std::fflush(stdout);
    while (!stop) ctx.run_for(std::chrono::milliseconds(50));
    server.close();
    print_stats(server);
    return 0;
}

} // namespace

void add_memobus(CLI::App& app, const std::atomic<bool>& stop, int& rc) {
    auto* sub = app.add_subcommand(
        "memobus", "a simulated Yaskawa MP2310 / 218IFA serving Extended MEMOBUS over TCP / UDP");
    auto o = std::make_shared<memobus_sim_options>();
    sub->add_option("--port", o->port, "TCP port (0: any free port)")->capture_default_str();
    sub->add_option("--bind", o->bind, "local IP address to serve on")->capture_default_str();
    sub->add_flag("--udp", o->udp, "also serve UDP on the same port");
    sub->add_option("--channels", o->channels,
                    "transmission buffer channels: masters at once (218IFA 4, 218IF 10)")
        ->check(CLI::Range(1, 20))
        ->capture_default_str();
    sub->add_option("--idle-timeout", o->idle_timeout_s,
                    "s without a complete request after which a master's channel is freed "
                    "(0: never)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    sub->add_option("--request-timeout", o->request_timeout_s,
                    "s from a TCP request's first byte by which it must be complete, or the "
                    "master's channel is freed (0: never)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    sub->add_option("--mw-offset", o->mw_offset, "hold register offset in words (PARAM11)");
    sub->add_option("--iw-offset", o->iw_offset, "input register offset in words (PARAM10)");
    sub->add_option("--mb-offset", o->mb_offset, "coil offset in MW words (PARAM08)");
    sub->add_option("--ib-offset", o->ib_offset, "input relay offset in IW words (PARAM09)");
    sub->add_option("--write-range", o->write_range, "MW words writes may touch, LOW-HIGH")
        ->capture_default_str();
    sub->add_option("--data-order", o->data_order,
                    "byte order of register data in SFC 03 / 04 / 06 / 10 (uncertain)")
        ->check(CLI::IsMember({"big", "little"}))
        ->capture_default_str();
    sub->callback([o, &stop, &rc] { rc = serve_memobus(*o, stop); });
}

} // namespace ferrule::sim_app
