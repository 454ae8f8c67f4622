// Host drivers on real pseudo-terminals: opening a port (what a pty refuses is warned about,
// not fatal), the blocking serial_stream, and async_driver with a callback, a future and a
// coroutine, many callers queued on one bus, and reopen after the device disappears.
#include <catch2/catch.hpp>

#include <asio/co_spawn.hpp>
#include <asio/detached.hpp>
#include <asio/io_context.hpp>
#include <asio/serial_port.hpp>
#include <asio/use_awaitable.hpp>
#include <asio/use_future.hpp>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "ferrule/host/async_driver.hpp"
#include "ferrule/host/pty_server.hpp"
#include "ferrule/host/serial_port.hpp"
#include "ferrule/host/serial_stream.hpp"
#include "ferrule/movilink/access.hpp"
#include "ferrule/movilink/sim/station.hpp"

using namespace std::chrono_literals;
namespace ml = ferrule::movilink;
namespace host = ferrule::host;
namespace ix = ml::sim::parameter_index;

namespace {

ml::slave_config on_pty(std::uint8_t address) {
    ml::slave_config c;
    c.address = address;
    c.format.baud = host::pty_line_baud;
    return c;
}

// Two simulated drives on a pty, served by a background thread.
struct sim_line {
    ml::sim::station drive1{on_pty(1)};
    ml::sim::station drive2{on_pty(2)};
    host::pty_server<ml::sim::station> server;
    std::atomic<bool> stop{false};
    std::thread thread;

    explicit sim_line(const std::string& link = {}) {
        REQUIRE_FALSE(server.open());
        if (!link.empty()) REQUIRE_FALSE(server.link(link));
        server.add(drive1);
        server.add(drive2);
        thread = std::thread([this] { server.run(stop); });
    }
    ~sim_line() {
        stop = true;
        thread.join();
    }
};

std::vector<std::string> open_port(asio::serial_port& port, const std::string& path,
                                   const ferrule::serial_format& f, std::error_code& ec) {
    std::vector<std::string> warnings;
    host::serial_options o;
    o.format = f;
    o.rs485 = true;
    ec = host::open_serial(port, path, o, [&](std::string_view w) { warnings.emplace_back(w); });
    return warnings;
}

bool contains(const std::vector<std::string>& v, const std::string& part) {
    for (const auto& s : v)
        if (s.find(part) != std::string::npos) return true;
    return false;
}

using transact_result = std::pair<std::error_code, std::uint32_t>;

auto read_param(std::uint8_t address, std::uint16_t index) {
    return [=](ml::master& m) {
        return m.start_parameter(address, ml::pdu_type::param_acyclic,
                                 ml::param_channel::make(ml::service::read, index));
    };
}
const auto param_value = [](ml::master& m) { return m.reply().param.data; };

} // namespace

TEST_CASE("open_serial on a pty: 7E1 and RS-485 are refused, warned about, and the port works",
          "[asio][serial]") {
    sim_line line;
    asio::io_context ctx;
    asio::serial_port port(ctx);
    std::error_code ec;
    const auto warnings =
        open_port(port, line.server.path(), {19200, 7, ferrule::parity::even, 1}, ec);
    REQUIRE_FALSE(ec);
    CHECK(contains(warnings, "does not take 7 data bits"));
    CHECK(contains(warnings, "parity"));
    CHECK(contains(warnings, "no RS-485 mode"));
    CHECK(contains(warnings, "low-latency"));

    // Opened again (the pty was set up before): the same, no error.
    port.close();
    const auto again = open_port(port, line.server.path(), ml::default_format, ec);
    REQUIRE_FALSE(ec);
    CHECK(contains(again, "parity"));

    host::serial_stream stream(ctx, port);
    ml::master m;
    const auto v = ml::read_parameter(stream, m, 2, ix::p810_rs485_address);
    REQUIRE(v);
    CHECK(*v == 2);
}

TEST_CASE("open errors are explained to the user", "[asio][serial]") {
    asio::io_context ctx;
    asio::serial_port port(ctx);
    const auto ec = host::open_serial(port, "/dev/ferrule-no-such-port", {});
    CHECK(ec == std::errc::no_such_file_or_directory);
    CHECK(host::open_error_message("/dev/ferrule-no-such-port", ec).find("no such port") !=
          std::string::npos);
    const auto denied = host::open_error_message(
        "/dev/ttyUSB0", std::make_error_code(std::errc::permission_denied));
    CHECK(denied.find("dialout") != std::string::npos);
    CHECK_FALSE(port.is_open());
}

TEST_CASE("serial_stream times out at the deadline when nothing arrives", "[asio][serial]") {
    sim_line line;
    asio::io_context ctx;
    asio::serial_port port(ctx);
    std::error_code ec;
    open_port(port, line.server.path(), ml::default_format, ec);
    REQUIRE_FALSE(ec);
    host::serial_stream stream(ctx, port);
    std::array<std::uint8_t, 16> buf{};
    const auto t0 = stream.now();
    const auto r = stream.read_some(buf, t0 + 30ms);
    CHECK(r.bytes == 0);
    CHECK(r.ec == ferrule::errc::timeout);
    CHECK(stream.now() - t0 >= 30ms);
    CHECK(stream.now() - t0 < 1s);
}

TEST_CASE("async_driver: callback, future and coroutine completion tokens", "[asio][async]") {
    sim_line line;
    asio::io_context ctx;
    asio::serial_port port(ctx);
    std::error_code ec;
    open_port(port, line.server.path(), ml::default_format, ec);
    REQUIRE_FALSE(ec);
    ml::master m;
    host::async_driver<asio::serial_port, ml::master> drv(port, m);

    transact_result by_callback{};
    drv.async_transact(read_param(1, ix::p810_rs485_address), param_value,
                       [&](std::error_code e, std::uint32_t v) {
                           by_callback = {e, v};
                       });

    transact_result by_coroutine{};
    asio::co_spawn(
        ctx,
        [&]() -> asio::awaitable<void> {
            by_coroutine.second = co_await drv.async_transact(read_param(2, ix::p810_rs485_address),
                                                              param_value, asio::use_awaitable);
        },
        [&](std::exception_ptr e) {
            if (e) by_coroutine.first = std::make_error_code(std::errc::io_error);
        });

    std::thread runner([&] { ctx.run(); });
    auto fut = drv.async_transact(read_param(1, ix::p014_heat_sink_temperature), param_value,
                                  asio::use_future);
    const std::uint32_t by_future = fut.get();
    runner.join();

    CHECK_FALSE(by_callback.first);
    CHECK(by_callback.second == 1);
    CHECK_FALSE(by_coroutine.first);
    CHECK(by_coroutine.second == 2);
    CHECK(by_future == 20);
}

TEST_CASE("async_driver queues many callers on one bus, never interleaving them", "[asio][async]") {
    sim_line line;
    asio::io_context ctx;
    asio::serial_port port(ctx);
    std::error_code ec;
    open_port(port, line.server.path(), ml::default_format, ec);
    REQUIRE_FALSE(ec);
    ml::master m;
    host::async_driver<asio::serial_port, ml::master> drv(port, m);

    constexpr int callers = 24;
    std::vector<transact_result> results(callers);
    // Half from other threads, half from the io_context's own: all start at once.
    std::vector<std::thread> threads;
    for (int i = 0; i < callers / 2; ++i)
        threads.emplace_back([&, i] {
            const auto address = static_cast<std::uint8_t>(1 + i % 2);
            drv.async_transact(read_param(address, ix::p810_rs485_address), param_value,
                               [&, i](std::error_code e, std::uint32_t v) {
                                   results[i] = {e, v};
                               });
        });
    for (int i = callers / 2; i < callers; ++i) {
        const auto address = static_cast<std::uint8_t>(1 + i % 2);
        drv.async_transact(read_param(address, ix::p810_rs485_address), param_value,
                           [&, i](std::error_code e, std::uint32_t v) {
                               results[i] = {e, v};
                           });
    }
    for (auto& t : threads) t.join();
    ctx.run();

    for (int i = 0; i < callers; ++i) {
        INFO("caller " << i);
        CHECK_FALSE(results[i].first);
        CHECK(results[i].second == static_cast<std::uint32_t>(1 + i % 2));
    }
    CHECK(m.stats().transactions == callers);
    CHECK(m.stats().resends == 0);
    // Interleaved requests would have reached the drives as broken telegrams.
    CHECK(line.drive1.session.stats().malformed == 0);
    CHECK(line.drive1.session.stats().bad_checksum == 0);
    CHECK(line.drive1.session.stats().requests + line.drive2.session.stats().requests == callers);
}

TEST_CASE("async_driver reopens the port after the device disappears and comes back",
          "[asio][async]") {
    const std::string link = "/tmp/ferrule-test-reopen-" + std::to_string(::getpid());
    asio::io_context ctx;
    asio::serial_port port(ctx);
    ml::master m;
    host::async_driver<asio::serial_port, ml::master> drv(port, m);
    int reopens = 0;
    drv.set_reopen(
        [&](asio::serial_port& p) {
            std::error_code ignore;
            p.close(ignore);
            ++reopens;
            std::error_code e;
            open_port(p, link, ml::default_format, e);
            return e;
        },
        20ms);

    const auto transact = [&] {
        transact_result r{};
        drv.async_transact(read_param(2, ix::p810_rs485_address), param_value,
                           [&](std::error_code e, std::uint32_t v) {
                               r = {e, v};
                           });
        ctx.restart();
        ctx.run();
        return r;
    };

    auto first = std::make_unique<sim_line>(link);
    std::error_code ec;
    open_port(port, link, ml::default_format, ec);
    REQUIRE_FALSE(ec);
    CHECK(transact() == transact_result{{}, 2});

    first.reset(); // the adapter is unplugged: the pty and the link are gone
    const auto lost = transact();
    CHECK(lost.first);
    CHECK(lost.first != ferrule::errc::timeout);

    // Plugged in again under the same name, a few reopen attempts later.
    std::thread replug([&] {
        std::this_thread::sleep_for(100ms);
        first = std::make_unique<sim_line>(link);
    });
    std::this_thread::sleep_for(10ms);
    transact_result back{};
    drv.async_transact(read_param(2, ix::p810_rs485_address), param_value,
                       [&](std::error_code e, std::uint32_t v) {
                           back = {e, v};
                       });
    ctx.restart();
    ctx.run();
    replug.join();
    CHECK(back == transact_result{{}, 2});
    CHECK(reopens >= 2);
}
