// modbus_tcp_server on loopback: many clients at once, a stalled client, the connection
// limit, the idle timeout, the request deadline and bad MBAP headers. The server runs on its
// own io_context thread; the clients are ferrule's blocking Modbus TCP clients, or blocking
// sockets that send bytes of their own.
#include <catch2/catch.hpp>

#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/read.hpp>
#include <asio/write.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "ferrule/host/async_driver.hpp"
#include "ferrule/host/modbus_tcp_server.hpp"
#include "ferrule/host/serial_stream.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/memory_model.hpp"

namespace {

using namespace ferrule;
using namespace std::chrono_literals;
namespace mb = ferrule::modbus;
using model_type = mb::memory_model<8, 8, 16, 8>;

// The server and its thread; the model's holding registers are 100 + i.
struct running_server {
    asio::io_context ctx;
    model_type model;
    host::modbus_tcp_server<model_type> server;
    std::thread thread;

    explicit running_server(host::modbus_tcp_server_options o = {})
        : server(ctx.get_executor(), model, o) {
        for (std::size_t i = 0; i < 16; ++i)
            model.holding_registers()[i] = static_cast<std::uint16_t>(100 + i);
        REQUIRE_FALSE(server.listen({asio::ip::make_address("127.0.0.1"), 0}));
        thread = std::thread([this] { ctx.run(); });
    }
    ~running_server() {
        asio::post(ctx, [this] { server.close(); });
        ctx.stop();
        thread.join();
    }
};

struct tcp_client {
    asio::io_context ctx;
    asio::ip::tcp::socket socket{ctx};
    host::tcp_stream line{ctx, socket};
    mb::client session{config()};

    explicit tcp_client(std::uint16_t port) {
        socket.connect({asio::ip::make_address("127.0.0.1"), port});
    }
    static mb::client_config config() {
        mb::client_config c;
        c.rtu = false;
        c.response_timeout = 2s;
        return c;
    }
    std::error_code read(std::array<std::uint16_t, 4>& out) {
        return mb::read_holding_registers(line, session, 1, 0, out);
    }
    // True when the server has closed the connection (a read ends with EOF).
    bool closed_by_server() {
        std::array<std::uint8_t, 8> b{};
        const auto r = line.read_some(b, line.now() + 2s);
        return r.bytes == 0 && r.ec && r.ec != ferrule::error(errc::timeout);
    }

    void send(std::span<const std::uint8_t> bytes) {
        asio::write(socket, asio::buffer(bytes.data(), bytes.size()));
    }

    // What the server sends until it closes the connection; nothing when it has not closed
    // it by `deadline`.
    std::optional<std::vector<std::uint8_t>> read_until_closed(time_point deadline) {
        std::vector<std::uint8_t> got;
        for (;;) {
            std::array<std::uint8_t, 256> b{};
            const auto r = line.read_some(b, deadline);
            if (r.ec == ferrule::error(errc::timeout)) return std::nullopt;
            if (r.bytes == 0) return got;
            got.insert(got.end(), b.begin(), b.begin() + static_cast<std::ptrdiff_t>(r.bytes));
        }
    }

    // Waits up to `wait` for the server to close the connection, dropping what it sends.
    bool closed_within(duration wait) { return read_until_closed(line.now() + wait).has_value(); }

    // Sends `bytes` one at a time, `interval` apart, round and round, until the server closes
    // the connection; false when it has not by `deadline`. The wait between two bytes is a
    // wait for the close.
    bool drip_until_closed(std::span<const std::uint8_t> bytes, duration interval,
                           time_point deadline) {
        for (std::size_t i = 0; before(line.now(), deadline); ++i) {
            std::error_code ec;
            asio::write(socket, asio::buffer(&bytes[i % bytes.size()], 1), ec);
            if (ec || closed_within(interval)) return true;
        }
        return false;
    }
};

// FC 3, one holding register from `address`, unit 1, with transaction `t`.
std::array<std::uint8_t, 12> read_request(std::uint16_t t, std::uint8_t address = 0) {
    return {static_cast<std::uint8_t>(t >> 8),
            static_cast<std::uint8_t>(t),
            0,
            0,
            0,
            6,
            1,
            3,
            0,
            address,
            0,
            1};
}

// Counts the connections the server reports closing or refusing, by reason.
struct close_reports {
    std::array<std::atomic<int>, 5> by_reason{};

    std::function<void(const asio::ip::tcp::endpoint&, host::close_reason)> hook() {
        return [this](const asio::ip::tcp::endpoint&, host::close_reason why) {
            ++by_reason[static_cast<std::size_t>(why)];
        };
    }
    int operator[](host::close_reason why) const {
        return by_reason[static_cast<std::size_t>(why)].load();
    }
};

} // namespace

TEST_CASE("modbus tcp server answers several clients while one stalls in a half request",
          "[asio][modbus]") {
    running_server s;
    tcp_client stalled(s.server.port());
    const std::array<std::uint8_t, 3> half_mbap{0x00, 0x01, 0x00};
    asio::write(stalled.socket, asio::buffer(half_mbap));

    tcp_client a(s.server.port());
    tcp_client b(s.server.port());
    std::array<std::uint16_t, 4> regs{};
    for (int i = 0; i < 20; ++i) {
        REQUIRE_FALSE(a.read(regs));
        CHECK(regs == std::array<std::uint16_t, 4>{100, 101, 102, 103});
        REQUIRE_FALSE(b.read(regs));
    }
    CHECK(s.server.stats().replies == 40);
}

// Modbus TCP lets a client send requests without waiting for each reply (Implementation
// Guide §3.1.2): 200 requests in one write, 2 400 bytes, come back as 200 replies in order.
TEST_CASE("modbus tcp server answers every request of a client that sends many at once",
          "[asio][modbus]") {
    const auto processing = GENERATE(0ms, 1ms);
    host::modbus_tcp_server_options o;
    o.processing_time = processing;
    running_server s(o);
    asio::io_context ctx;
    asio::ip::tcp::socket socket(ctx);
    socket.connect({asio::ip::make_address("127.0.0.1"), s.server.port()});
    constexpr int requests = 200;
    std::vector<std::uint8_t> out;
    for (int t = 0; t < requests; ++t) {
        // MBAP: transaction t, protocol 0, length 6, unit 1; FC 3, register t % 16, count 1
        const std::array<std::uint8_t, 12> r{0, static_cast<std::uint8_t>(t),      0, 0, 0, 6, 1, 3,
                                             0, static_cast<std::uint8_t>(t % 16), 0, 1};
        out.insert(out.end(), r.begin(), r.end());
    }
    asio::write(socket, asio::buffer(out));
    std::vector<std::uint8_t> in(requests * 11);
    asio::read(socket, asio::buffer(in));
    for (int t = 0; t < requests; ++t) {
        const std::uint8_t* reply = in.data() + t * 11;
        INFO("reply " << t);
        REQUIRE(reply[1] == t);
        REQUIRE(reply[5] == 5);
        REQUIRE(reply[7] == 3);
        REQUIRE((reply[9] << 8 | reply[10]) == 100 + t % 16);
    }
}

// Requests that arrive one at a time while the reply before them is still held back
// (processing_time): each arrives when the connection is not asking for bytes, and must still
// be read once it asks (the server watches its sockets edge-triggered).
TEST_CASE("modbus tcp server answers requests that arrive while a reply is held back",
          "[asio][modbus]") {
    host::modbus_tcp_server_options o;
    o.processing_time = 30ms;
    running_server s(o);
    asio::io_context ctx;
    asio::ip::tcp::socket socket(ctx);
    socket.connect({asio::ip::make_address("127.0.0.1"), s.server.port()});
    socket.set_option(asio::ip::tcp::no_delay(true));
    constexpr int requests = 4;
    for (int t = 0; t < requests; ++t) {
        const std::array<std::uint8_t, 12> r{0, static_cast<std::uint8_t>(t), 0, 0, 0, 6, 1, 3,
                                             0, static_cast<std::uint8_t>(t), 0, 1};
        asio::write(socket, asio::buffer(r));
        std::this_thread::sleep_for(10ms);
    }
    // Every reply within a second, or the test fails instead of waiting for ever.
    socket.non_blocking(true);
    std::vector<std::uint8_t> in(requests * 11);
    std::size_t got = 0;
    const auto until = std::chrono::steady_clock::now() + 1s;
    while (got < in.size() && std::chrono::steady_clock::now() < until) {
        std::error_code ec;
        got += socket.read_some(asio::buffer(in.data() + got, in.size() - got), ec);
        if (ec == asio::error::would_block)
            std::this_thread::sleep_for(1ms);
        else
            REQUIRE_FALSE(ec);
    }
    REQUIRE(got == in.size());
    for (int t = 0; t < requests; ++t) {
        INFO("reply " << t);
        CHECK(in[t * 11 + 1] == t);
        CHECK((in[t * 11 + 9] << 8 | in[t * 11 + 10]) == 100 + t);
    }
    CHECK(s.server.stats().replies == requests);
}

TEST_CASE("modbus tcp server closes connections beyond its limit", "[asio][modbus]") {
    host::modbus_tcp_server_options o;
    o.max_connections = 2;
    running_server s(o);
    tcp_client a(s.server.port());
    tcp_client b(s.server.port());
    std::array<std::uint16_t, 4> regs{};
    REQUIRE_FALSE(a.read(regs)); // both are accepted before the third arrives
    REQUIRE_FALSE(b.read(regs));
    tcp_client c(s.server.port());
    CHECK(c.closed_by_server());
    CHECK(s.server.stats().refused == 1);
    REQUIRE_FALSE(a.read(regs)); // the others go on
}

TEST_CASE("modbus tcp server closes an idle connection", "[asio][modbus]") {
    host::modbus_tcp_server_options o;
    o.idle_timeout = 200ms;
    running_server s(o);
    tcp_client a(s.server.port());
    std::array<std::uint16_t, 4> regs{};
    REQUIRE_FALSE(a.read(regs));
    CHECK(a.closed_by_server());
    CHECK(s.server.stats().idle_closed == 1);
    tcp_client again(s.server.port()); // a new connection is served as usual
    CHECK_FALSE(again.read(regs));
}

TEST_CASE("modbus client: many callers share one connection through async_driver, in turn",
          "[asio][modbus]") {
    running_server s;
    asio::io_context ctx;
    asio::ip::tcp::socket socket(ctx);
    socket.connect({asio::ip::make_address("127.0.0.1"), s.server.port()});
    mb::client_config cfg;
    cfg.rtu = false;
    mb::client c(cfg);
    host::async_driver<asio::ip::tcp::socket, mb::client> drv(socket, c);

    // Each caller reads its own register; an interleaved request would get another caller's
    // value or a stale transaction id.
    constexpr int callers = 16;
    std::vector<std::pair<std::error_code, std::uint16_t>> results(callers);
    const auto read_one = [&](int i) {
        mb::request r;
        r.function = mb::function::read_holding_registers;
        r.address = static_cast<std::uint16_t>(i % 16);
        r.quantity = 1;
        drv.async_transact([r](mb::client& cl) { return cl.start(1, r); },
                           [](mb::client& cl) { return mb::register_at(cl.reply().data, 0); },
                           [&results, i](std::error_code e, std::uint16_t v) {
                               results[static_cast<std::size_t>(i)] = {e, v};
                           });
    };
    std::vector<std::thread> threads;
    for (int i = 0; i < callers / 2; ++i) threads.emplace_back([&, i] { read_one(i); });
    for (int i = callers / 2; i < callers; ++i) read_one(i);
    for (auto& t : threads) t.join();
    ctx.run();

    for (int i = 0; i < callers; ++i) {
        INFO("caller " << i);
        CHECK_FALSE(results[static_cast<std::size_t>(i)].first);
        CHECK(results[static_cast<std::size_t>(i)].second == 100 + i % 16);
    }
    CHECK(c.stats().succeeded == callers);
}

// A client that sends a byte now and then kept its connection for ever while any byte reset
// the idle timeout: four of them held every connection. A request must be complete
// request_timeout after its first byte.
TEST_CASE("modbus tcp server closes clients that drip bytes on every connection, and serves "
          "a new one",
          "[asio][modbus]") {
    close_reports reports;
    host::modbus_tcp_server_options o;
    o.max_connections = 4;
    o.idle_timeout = 500ms;
    o.request_timeout = 200ms;
    o.on_close = reports.hook();
    running_server s(o);

    // Each drips a well-formed request, a byte every 100 ms: 1.2 s for the 12 bytes.
    std::vector<std::unique_ptr<tcp_client>> drippers;
    for (int i = 0; i < 4; ++i) drippers.push_back(std::make_unique<tcp_client>(s.server.port()));
    std::atomic<int> closed{0};
    std::vector<std::thread> threads;
    const time_point deadline = host::steady_now() + 3s;
    for (auto& d : drippers)
        threads.emplace_back([&, c = d.get()] {
            if (c->drip_until_closed(read_request(1), 100ms, deadline)) ++closed;
        });
    for (auto& t : threads) t.join();
    CHECK(closed == 4);
    CHECK(s.server.stats().request_timeouts == 4);
    CHECK(reports[host::close_reason::request_timeout] == 4);
    CHECK(s.server.stats().idle_closed == 0);

    tcp_client fifth(s.server.port());
    std::array<std::uint16_t, 4> regs{};
    CHECK_FALSE(fifth.read(regs));
    CHECK(regs == std::array<std::uint16_t, 4>{100, 101, 102, 103});
}

// Bytes of a request that never completes do not keep a connection open past the idle
// timeout, counted from the last complete request (here with no request deadline at all).
TEST_CASE("modbus tcp server counts the idle timeout from the last complete request",
          "[asio][modbus]") {
    host::modbus_tcp_server_options o;
    o.idle_timeout = 500ms;
    o.request_timeout = duration::zero();
    running_server s(o);
    tcp_client c(s.server.port());
    std::array<std::uint16_t, 4> regs{};
    REQUIRE_FALSE(c.read(regs));
    const time_point answered = host::steady_now();
    CHECK(c.drip_until_closed(read_request(2), 100ms, answered + 3s));
    CHECK(host::steady_now() - answered >= 450ms); // 500 ms from the request, read before
    CHECK(s.server.stats().idle_closed == 1);
    CHECK(s.server.stats().request_timeouts == 0);
}

// A client whose requests come in two parts is not closed while each part follows in time,
// for longer than both limits.
TEST_CASE("modbus tcp server keeps a client whose requests are slow but complete in time",
          "[asio][modbus]") {
    host::modbus_tcp_server_options o;
    o.idle_timeout = 600ms;
    o.request_timeout = 300ms;
    running_server s(o);
    tcp_client c(s.server.port());
    const time_point start = host::steady_now();
    for (std::uint16_t t = 1; t <= 8; ++t) {
        const auto r = read_request(t, static_cast<std::uint8_t>(t));
        c.send(std::span(r).first(5));
        REQUIRE_FALSE(c.closed_within(50ms));
        c.send(std::span(r).subspan(5));
        std::array<std::uint8_t, 11> reply{};
        std::size_t got = 0;
        while (got < reply.size()) {
            const auto n = c.line.read_some(std::span(reply).subspan(got), c.line.now() + 2s);
            REQUIRE_FALSE(n.ec);
            got += n.bytes;
        }
        CHECK(reply[1] == t);
        CHECK((reply[9] << 8 | reply[10]) == 100 + t);
        REQUIRE_FALSE(c.closed_within(200ms));
    }
    CHECK(host::steady_now() - start > 1s);
    CHECK(s.server.stats().replies == 8);
    CHECK(s.server.stats().request_timeouts + s.server.stats().idle_closed == 0);
}

// A server that resynchronised one byte at a time after eight zero bytes took the requests
// behind them for the rest of a frame and never answered them; the client only timed out.
// A header that no request starts with ends the connection, once the requests before it are
// answered. Neither timeout can end it within the checks' deadline.
TEST_CASE("modbus tcp server closes a connection at an MBAP header no request starts with",
          "[asio][modbus]") {
    close_reports reports;
    host::modbus_tcp_server_options o;
    o.idle_timeout = 60s;
    o.request_timeout = 10s;
    o.processing_time = GENERATE(0ms, 20ms);
    o.on_close = reports.hook();
    running_server s(o);
    using bytes = std::vector<std::uint8_t>;
    const auto append = [](bytes& to, std::span<const std::uint8_t> b) {
        to.insert(to.end(), b.begin(), b.end());
    };

    // Eight zero bytes, then requests: no reply, the connection closed.
    tcp_client zeros(s.server.port());
    bytes out(8, 0);
    for (std::uint16_t t = 1; t <= 6; ++t) append(out, read_request(t));
    zeros.send(out);
    const auto after_zeros = zeros.read_until_closed(host::steady_now() + 1s);
    REQUIRE(after_zeros);
    CHECK(after_zeros->empty());

    // Two requests, four stray zero bytes, a request (transaction 1: with the zeros a header
    // of length 1): the two answered, then the close.
    tcp_client stray(s.server.port());
    out.clear();
    append(out, read_request(7, 7));
    append(out, read_request(8, 8));
    append(out, bytes(4, 0));
    append(out, read_request(1));
    stray.send(out);
    const auto after_stray = stray.read_until_closed(host::steady_now() + 1s);
    REQUIRE(after_stray);
    REQUIRE(after_stray->size() == 22);
    CHECK((*after_stray)[1] == 7);
    CHECK(((*after_stray)[9] << 8 | (*after_stray)[10]) == 107);
    CHECK((*after_stray)[12] == 8);
    CHECK(((*after_stray)[20] << 8 | (*after_stray)[21]) == 108);

    CHECK(s.server.stats().bad_headers == 2);
    CHECK(reports[host::close_reason::unframeable] == 2);
    CHECK(s.server.stats().replies == 2);
    tcp_client again(s.server.port()); // the client reconnects and is served
    std::array<std::uint16_t, 4> regs{};
    CHECK_FALSE(again.read(regs));
}
