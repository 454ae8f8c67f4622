// memobus_server on loopback: many masters at once, each on its own channel, while others
// misbehave; the channel limit, the idle timeout, the request deadline, per-channel offsets,
// and UDP peers. The
// server runs on its own io_context thread; each master is a blocking socket on its own
// thread, building requests with encode_command and checking replies with parse_response.
#include <catch2/catch.hpp>

#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/ip/udp.hpp>
#include <asio/write.hpp>

#include <poll.h>

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "ferrule/host/memobus_server.hpp"
#include "ferrule/host/serial_stream.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/register_image.hpp"

namespace {

using namespace ferrule;
using namespace std::chrono_literals;
namespace mb = ferrule::memobus;
using image_type = mb::register_image<8192, 64>;
using octets = std::vector<std::uint8_t>;

struct running_server {
    asio::io_context ctx;
    image_type image;
    host::memobus_server<image_type> server;
    std::thread thread;

    explicit running_server(host::memobus_server_options o = {})
        : server(ctx.get_executor(), image, std::move(o)) {
        REQUIRE_FALSE(server.listen({asio::ip::make_address("127.0.0.1"), 0}));
        REQUIRE_FALSE(server.open_udp({asio::ip::make_address("127.0.0.1"), 0}));
        thread = std::thread([this] { ctx.run(); });
    }
    ~running_server() {
        asio::post(ctx, [this] { server.close(); });
        ctx.stop();
        thread.join();
    }
};

mb::request make(mb::sfc f, std::uint16_t address, std::uint16_t count) {
    mb::request r;
    r.function = f;
    r.address = address;
    r.count = count;
    return r;
}

// A master on one TCP connection: strict request / response, serial 0…255 and round again.
struct tcp_master {
    asio::io_context ctx;
    asio::ip::tcp::socket socket{ctx};
    host::tcp_stream line{ctx, socket};
    std::uint8_t serial = 0;
    octets reply;

    explicit tcp_master(std::uint16_t port) {
        socket.connect({asio::ip::make_address("127.0.0.1"), port});
    }

    void send(std::span<const std::uint8_t> bytes) {
        asio::write(socket, asio::buffer(bytes.data(), bytes.size()));
    }

    // `n` bytes, or false at the deadline or when the connection ends.
    bool read_exactly(std::uint8_t* to, std::size_t n, time_point deadline) {
        for (std::size_t got = 0; got < n;) {
            const auto r = line.read_some({to + got, n - got}, deadline);
            if (r.ec || r.bytes == 0) return false;
            got += r.bytes;
        }
        return true;
    }

    // One whole message, framed by its total length (§2).
    bool read_message(time_point deadline) {
        reply.assign(mb::header_size, 0);
        if (!read_exactly(reply.data(), mb::header_size, deadline)) return false;
        const std::size_t total = mb::load_header(reply.data()).total;
        if (total < mb::header_size) return false;
        reply.resize(total);
        return read_exactly(reply.data() + mb::header_size, total - mb::header_size, deadline);
    }

    // Sends `r` and checks that the reply is a response with its serial; its body's response.
    result<mb::response> transact(const mb::request& r) {
        std::array<std::uint8_t, mb::max_message> out{};
        const auto n = mb::encode_command(r, serial, out);
        if (!n) return n.error();
        send({out.data(), *n});
        if (!read_message(line.now() + 2s)) return errc::timeout;
        if (reply[0] != 0x19 || reply[1] != serial) return errc::malformed;
        ++serial;
        return mb::parse_response(r, std::span<const std::uint8_t>(reply).subspan(mb::header_size));
    }

    // True when the server has closed the connection (a read ends with EOF).
    bool closed_by_server() {
        std::array<std::uint8_t, 8> b{};
        const auto r = line.read_some(b, line.now() + 2s);
        return r.bytes == 0 && r.ec && r.ec != ferrule::error(errc::timeout);
    }

    // Waits up to `wait` for the server to close the connection, dropping what it sends.
    bool closed_within(duration wait) {
        const time_point deadline = line.now() + wait;
        for (;;) {
            std::array<std::uint8_t, 256> b{};
            const auto r = line.read_some(b, deadline);
            if (r.ec == ferrule::error(errc::timeout)) return false;
            if (r.bytes == 0) return true;
        }
    }

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

// Writes a block of its own with SFC 0B and reads it back with SFC 09, `rounds` times;
// false at the first reply that is missing, late, another's or wrong.
bool exercise(tcp_master& m, std::uint16_t base, std::uint16_t tag, int rounds) {
    constexpr std::uint16_t n = 32;
    std::array<std::uint16_t, n> values{};
    for (int round = 0; round < rounds; ++round) {
        for (std::uint16_t k = 0; k < n; ++k)
            values[k] = static_cast<std::uint16_t>(tag << 8 ^ round << 5 ^ k);
        auto w = make(mb::sfc::write_holding_registers_ext, base, n);
        w.words = values;
        if (!m.transact(w)) return false;
        const auto r = m.transact(make(mb::sfc::read_holding_registers_ext, base, n));
        if (!r) return false;
        for (std::uint16_t k = 0; k < n; ++k)
            if (mb::word_at(r->function, r->raw, k) != values[k]) return false;
    }
    return true;
}

// A UDP master: one socket on an ephemeral port of `from` (any of 127.0.0.0/8 on loopback:
// the server knows a UDP master by its address).
struct udp_master {
    asio::io_context ctx;
    asio::ip::udp::socket socket;
    asio::ip::udp::endpoint server;
    std::uint8_t serial = 0;
    std::array<std::uint8_t, mb::max_message + 1> reply{};

    explicit udp_master(std::uint16_t port, const char* from = "127.0.0.1")
        : socket(ctx, asio::ip::udp::endpoint(asio::ip::make_address(from), 0)),
          server(asio::ip::make_address("127.0.0.1"), port) {}

    std::error_code send(const mb::request& r) {
        std::array<std::uint8_t, mb::max_message> out{};
        const auto n = mb::encode_command(r, serial, out);
        if (!n) return n.error();
        socket.send_to(asio::buffer(out.data(), *n), server);
        return {};
    }

    result<mb::response> transact(const mb::request& r, std::chrono::milliseconds timeout = 2s) {
        if (const auto ec = send(r)) return ferrule::from_error_code(ec);
        ::pollfd p{socket.native_handle(), POLLIN, 0};
        if (::poll(&p, 1, static_cast<int>(timeout.count())) != 1) return errc::timeout;
        asio::ip::udp::endpoint from;
        const std::size_t got = socket.receive_from(asio::buffer(reply), from);
        const auto h = mb::parse_message({reply.data(), got});
        if (!h || h->type != mb::command_type::response || h->serial != serial)
            return errc::malformed;
        ++serial;
        return mb::parse_response(
            r, std::span<const std::uint8_t>(reply.data(), got).subspan(mb::header_size));
    }
};

} // namespace

TEST_CASE("memobus server: many masters at once, each on its own channel, while others "
          "misbehave",
          "[asio][memobus]") {
    const int masters = GENERATE(4, 16, 64);
    constexpr int misbehaving = 3;
    constexpr int rounds = 20;
    host::memobus_server_options o;
    o.max_channels = static_cast<std::size_t>(masters + misbehaving);
    o.request_timeout = duration::zero(); // the misbehaving stay for the whole run
    running_server s(o);

    // Half a header, then silence.
    tcp_master half(s.server.port());
    const std::array<std::uint8_t, 5> half_header{0x11, 0x00, 0x00, 0x00, 0x00};
    half.send(half_header);
    // A header announcing 65535 bytes: the decoder drops it rather than wait for 64 KiB.
    tcp_master huge(s.server.port());
    const std::array<std::uint8_t, 12> huge_header{0x11, 0x01, 0, 0, 0, 0, 0xFF, 0xFF, 0, 0, 0, 0};
    huge.send(huge_header);
    // Garbage, all of it, and more of it while the masters work.
    tcp_master garbage(s.server.port());
    std::array<std::uint8_t, 1000> noise{};
    for (std::size_t i = 0; i < noise.size(); ++i)
        noise[i] = static_cast<std::uint8_t>(0xA5 ^ i * 7);
    garbage.send(noise);
    std::atomic<bool> done{false};
    std::thread noisy([&] {
        while (!done) {
            garbage.send(noise);
            std::this_thread::sleep_for(1ms);
        }
    });

    std::vector<std::unique_ptr<tcp_master>> ms;
    for (int i = 0; i < masters; ++i) ms.push_back(std::make_unique<tcp_master>(s.server.port()));
    std::atomic<int> ok{0};
    const auto start = std::chrono::steady_clock::now();
    std::vector<std::thread> threads;
    for (int i = 0; i < masters; ++i)
        threads.emplace_back([&, i] {
            if (exercise(*ms[static_cast<std::size_t>(i)], static_cast<std::uint16_t>(64 * i),
                         static_cast<std::uint16_t>(i), rounds))
                ++ok;
        });
    for (auto& t : threads) t.join();
    const auto took = std::chrono::steady_clock::now() - start;
    done = true;
    noisy.join();
    CHECK(ok == masters);
    CHECK(took < 4s);
    CHECK(s.server.stats().replies == static_cast<std::uint64_t>(masters * rounds * 2));
    CHECK(s.server.stats().refused == 0);

    // The one that sent 65535 resynchronised: a good request after it is answered.
    const auto r = huge.transact(make(mb::sfc::read_holding_registers_ext, 0, 4));
    CHECK(r);
    CHECK(huge.serial == 1);

    // Every master's requests went to its channel and to no other.
    std::uint64_t requests = 0;
    std::uint64_t malformed = 0;
    for (std::size_t i = 0; i < s.server.max_channels(); ++i) {
        const auto c = s.server.channel_stats(i);
        CHECK(c.open);
        CHECK(c.opened == 1);
        CHECK(c.requests == c.responses);
        requests += c.requests;
        malformed += c.malformed;
        if (i >= misbehaving) CHECK(c.requests == rounds * 2);
    }
    CHECK(requests == static_cast<std::uint64_t>(masters * rounds * 2 + 1));
    CHECK(malformed >= 2); // the 65535 header and the garbage
}

TEST_CASE("memobus server: a master that sends many requests at once gets every reply in "
          "order",
          "[asio][memobus]") {
    running_server s;
    tcp_master m(s.server.port());
    constexpr int requests = 300;
    octets out;
    for (int t = 0; t < requests; ++t) {
        std::array<std::uint8_t, mb::max_message> one{};
        const auto n = mb::encode_command(make(mb::sfc::read_holding_registers_ext, 0, 100),
                                          static_cast<std::uint8_t>(t), one);
        REQUIRE(n);
        out.insert(out.end(), one.begin(), one.begin() + static_cast<std::ptrdiff_t>(*n));
    }
    m.send(out);
    for (int t = 0; t < requests; ++t) {
        INFO("reply " << t);
        REQUIRE(m.read_message(m.line.now() + 2s));
        CHECK(m.reply[1] == static_cast<std::uint8_t>(t));
        CHECK(m.reply.size() == 220);
    }
}

TEST_CASE("memobus server: refuses a connection beyond max_channels", "[asio][memobus]") {
    host::memobus_server_options o;
    o.max_channels = 4;
    running_server s(o);
    std::vector<std::unique_ptr<tcp_master>> ms;
    for (int i = 0; i < 4; ++i) {
        ms.push_back(std::make_unique<tcp_master>(s.server.port()));
        REQUIRE(ms.back()->transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    }
    tcp_master fifth(s.server.port());
    CHECK(fifth.closed_by_server());
    CHECK(s.server.stats().refused == 1);
    CHECK(s.server.open_channels() == 4);
    // The others go on; one leaves, and its channel serves the next.
    CHECK(ms[0]->transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    ms[1].reset();
    const auto until = std::chrono::steady_clock::now() + 2s;
    while (s.server.open_channels() == 4 && std::chrono::steady_clock::now() < until)
        std::this_thread::sleep_for(1ms);
    tcp_master again(s.server.port());
    CHECK(again.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    CHECK(s.server.channel_stats(1).opened == 2);
}

TEST_CASE("memobus server: closes a silent channel after idle_timeout", "[asio][memobus]") {
    host::memobus_server_options o;
    o.idle_timeout = 200ms;
    running_server s(o);
    tcp_master a(s.server.port());
    REQUIRE(a.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    CHECK(a.closed_by_server());
    CHECK(s.server.stats().idle_closed == 1);
    tcp_master again(s.server.port()); // a new connection is served as usual
    CHECK(again.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
}

// Four masters sending a byte every 2 s held every channel of a 218IFA through a whole run
// while any byte reset the idle timeout. A message must be complete request_timeout after its
// first byte.
TEST_CASE("memobus server: masters that drip bytes on every channel are closed, and a fifth "
          "gets a channel",
          "[asio][memobus]") {
    host::memobus_server_options o;
    o.max_channels = 4;
    o.idle_timeout = 500ms;
    o.request_timeout = 200ms;
    running_server s(o);
    std::array<std::uint8_t, mb::max_message> command{};
    const auto n = mb::encode_command(make(mb::sfc::read_holding_registers_ext, 0, 4), 0, command);
    REQUIRE(n);

    // Each drips a well-formed command, a byte every 100 ms: 2.2 s for its 22 bytes.
    std::vector<std::unique_ptr<tcp_master>> drippers;
    for (int i = 0; i < 4; ++i) drippers.push_back(std::make_unique<tcp_master>(s.server.port()));
    std::atomic<int> closed{0};
    std::vector<std::thread> threads;
    const time_point deadline = host::steady_now() + 3s;
    for (auto& d : drippers)
        threads.emplace_back([&, m = d.get()] {
            if (m->drip_until_closed({command.data(), *n}, 100ms, deadline)) ++closed;
        });
    for (auto& t : threads) t.join();
    CHECK(closed == 4);
    CHECK(s.server.stats().request_timeouts == 4);
    CHECK(s.server.stats().idle_closed == 0);

    tcp_master fifth(s.server.port());
    CHECK(fifth.transact(make(mb::sfc::read_holding_registers_ext, 0, 4)));
    CHECK(s.server.stats().refused == 0);
}

// Bytes that form no message are dropped by the decoder, and timed as a request all the same.
TEST_CASE("memobus server: closes a master that sends only bytes forming no message",
          "[asio][memobus]") {
    host::memobus_server_options o;
    o.idle_timeout = 60s;
    o.request_timeout = 200ms;
    running_server s(o);
    tcp_master garbage(s.server.port());
    const std::array<std::uint8_t, 4> noise{0xA5, 0x5A, 0xC3, 0x3C};
    CHECK(garbage.drip_until_closed(noise, 50ms, host::steady_now() + 3s));
    CHECK(s.server.stats().request_timeouts == 1);
    CHECK(s.server.channel_stats(0).malformed >= 1);
}

TEST_CASE("memobus server: each channel has its own offsets and write range", "[asio][memobus]") {
    host::memobus_server_options o;
    mb::channel_config first;
    first.mw_offset = 1000;
    first.write_low = 1000;
    first.write_high = 1099;
    o.channels = {first};
    o.channel.write_high = 999;
    running_server s(o);
    tcp_master a(s.server.port()); // channel 0
    REQUIRE(a.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    tcp_master b(s.server.port()); // channel 1: the default
    const std::array<std::uint16_t, 1> v{0x1234};
    auto w = make(mb::sfc::write_holding_registers_ext, 5, 1);
    w.words = v;
    REQUIRE(a.transact(w));
    REQUIRE(b.transact(w));
    w.address = 1005;
    const auto refused = b.transact(w);
    REQUIRE_FALSE(refused);
    CHECK(refused.error() == ferrule::error(mb::device_errc::count_error));
    // a's MW00005 is MW01005; b's is MW00005
    auto r = a.transact(make(mb::sfc::read_holding_registers_ext, 5, 1));
    REQUIRE(r);
    CHECK(mb::word_at(r->function, r->raw, 0) == 0x1234);
    r = b.transact(make(mb::sfc::read_holding_registers_ext, 1005, 1));
    REQUIRE(r);
    CHECK(mb::word_at(r->function, r->raw, 0) == 0x1234);
    CHECK(s.server.channel_stats(1).count_errors == 1);
}

TEST_CASE("memobus server: UDP peers, each its own channel, within max_channels",
          "[asio][memobus]") {
    host::memobus_server_options o;
    o.max_channels = 2;
    running_server s(o);
    udp_master a(s.server.udp_port(), "127.0.0.1");
    udp_master b(s.server.udp_port(), "127.0.0.2");
    std::atomic<int> ok{0};
    const auto run = [&](udp_master& m, std::uint16_t base) {
        std::array<std::uint16_t, 16> values{};
        for (int round = 0; round < 50; ++round) {
            for (std::uint16_t k = 0; k < values.size(); ++k)
                values[k] = static_cast<std::uint16_t>(base ^ round << 4 ^ k);
            auto w = make(mb::sfc::write_holding_registers_ext, base, 16);
            w.words = values;
            if (!m.transact(w)) return;
            const auto r = m.transact(make(mb::sfc::read_holding_registers_ext, base, 16));
            if (!r) return;
            for (std::uint16_t k = 0; k < values.size(); ++k)
                if (mb::word_at(r->function, r->raw, k) != values[k]) return;
        }
        ++ok;
    };
    std::thread ta([&] { run(a, 100); });
    std::thread tb([&] { run(b, 200); });
    ta.join();
    tb.join();
    CHECK(ok == 2);
    CHECK(s.server.stats().udp_peers == 2);
    CHECK(s.server.channel_stats(0).requests == 100);
    CHECK(s.server.channel_stats(1).requests == 100);

    // A third peer finds no free channel: its datagrams are dropped.
    udp_master c(s.server.udp_port(), "127.0.0.3");
    CHECK(c.transact(make(mb::sfc::read_holding_registers_ext, 0, 1), 200ms).error() ==
          ferrule::error(errc::timeout));
    CHECK(s.server.stats().udp_refused == 1);
    CHECK(a.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
}

TEST_CASE("memobus server: a UDP peer silent for idle_timeout gives its channel to a new one",
          "[asio][memobus]") {
    host::memobus_server_options o;
    o.max_channels = 1;
    o.idle_timeout = 100ms;
    running_server s(o);
    udp_master a(s.server.udp_port(), "127.0.0.1");
    udp_master b(s.server.udp_port(), "127.0.0.2");
    REQUIRE(a.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    CHECK(b.transact(make(mb::sfc::read_holding_registers_ext, 0, 1), 50ms).error() ==
          ferrule::error(errc::timeout));
    std::this_thread::sleep_for(100ms);
    ++b.serial; // the dropped request's
    CHECK(b.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    CHECK(s.server.stats().udp_refused == 1);
    CHECK(s.server.channel_stats(0).opened == 2);
}

TEST_CASE("memobus server: a UDP peer silent for idle_timeout gives its channel to a TCP master",
          "[asio][memobus]") {
    host::memobus_server_options o;
    o.max_channels = 1;
    o.idle_timeout = 100ms;
    running_server s(o);
    udp_master a(s.server.udp_port());
    REQUIRE(a.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    std::this_thread::sleep_for(150ms);
    tcp_master t(s.server.port());
    CHECK(t.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    CHECK(s.server.stats().accepted == 1);
    CHECK(s.server.stats().refused == 0);
}

TEST_CASE("memobus server: datagrams that are no command take no UDP channel", "[asio][memobus]") {
    host::memobus_server_options o;
    o.max_channels = 4;
    running_server s(o);
    // One byte each, from four ports on four addresses: as many as there are channels. (On
    // loopback a datagram is in the server's socket when send_to returns, so the server reads
    // them before the master's command below.)
    const std::array<const char*, 4> from{"127.0.0.2", "127.0.0.3", "127.0.0.4", "127.0.0.5"};
    const std::array<std::uint8_t, 4> bytes{0x11, 0x19, 0x00, 0xFF};
    asio::io_context ctx;
    for (std::size_t i = 0; i < from.size(); ++i) {
        asio::ip::udp::socket junk(ctx, {asio::ip::make_address(from[i]), 0});
        junk.send_to(asio::buffer(&bytes[i], 1),
                     {asio::ip::make_address("127.0.0.1"), s.server.udp_port()});
    }
    udp_master m(s.server.udp_port());
    CHECK(m.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    CHECK(s.server.stats().udp_ignored == 4);
    CHECK(s.server.stats().udp_peers == 1);
    CHECK(s.server.stats().udp_refused == 0);
    CHECK(s.server.open_channels() == 1);
}

TEST_CASE("memobus server: a UDP master that runs again from new ports keeps one channel",
          "[asio][memobus]") {
    host::memobus_server_options o;
    o.max_channels = 4;
    running_server s(o);
    // Six runs of a master one after the other, each from its own ephemeral port, as six runs
    // of `ferrule memobus read --udp`. (Each socket stays open so that no two share a port.)
    std::vector<std::unique_ptr<udp_master>> runs;
    for (int i = 0; i < 6; ++i) {
        INFO("run " << i + 1);
        runs.push_back(std::make_unique<udp_master>(s.server.udp_port()));
        CHECK(runs.back()->transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    }
    CHECK(s.server.stats().udp_peers == 1);
    CHECK(s.server.stats().udp_moved == 5);
    CHECK(s.server.stats().udp_refused == 0);
    CHECK(s.server.open_channels() == 1);
    CHECK(s.server.channel_stats(0).opened == 1);
    CHECK(s.server.channel_stats(0).requests == 6);
    // The first port, back again, is answered too: two programs on one host share a channel.
    CHECK(runs.front()->transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    CHECK(s.server.stats().udp_moved == 6);
    // A TCP master finds a free channel.
    tcp_master t(s.server.port());
    CHECK(t.transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    CHECK(s.server.stats().accepted == 1);
    CHECK(s.server.stats().refused == 0);
}

TEST_CASE("memobus server: a new UDP master with every channel in use is refused, counted and "
          "reported",
          "[asio][memobus]") {
    std::mutex lock;
    std::condition_variable reported;
    std::vector<asio::ip::udp::endpoint> refused;
    host::memobus_server_options o;
    o.max_channels = 4;
    o.on_udp_refused = [&](const asio::ip::udp::endpoint& from) {
        const std::lock_guard<std::mutex> hold(lock);
        refused.push_back(from);
        reported.notify_all();
    };
    running_server s(o);
    const std::array<const char*, 4> from{"127.0.0.2", "127.0.0.3", "127.0.0.4", "127.0.0.5"};
    std::vector<std::unique_ptr<udp_master>> live;
    for (const char* address : from) {
        live.push_back(std::make_unique<udp_master>(s.server.udp_port(), address));
        REQUIRE(live.back()->transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    }

    udp_master fifth(s.server.udp_port(), "127.0.0.1");
    REQUIRE_FALSE(fifth.send(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    {
        std::unique_lock<std::mutex> hold(lock);
        REQUIRE(reported.wait_for(hold, 2s, [&] { return !refused.empty(); }));
        CHECK(refused.size() == 1);
        CHECK(refused.front() == fifth.socket.local_endpoint());
    }
    CHECK(s.server.stats().udp_refused == 1);
    CHECK(s.server.stats().udp_peers == 4);
    CHECK(s.server.open_channels() == 4);

    // Garbage from a sixth address while all are in use is ignored, not refused; the live
    // masters go on (the server reads the garbage before their commands, see above).
    asio::io_context ctx;
    asio::ip::udp::socket junk(ctx, {asio::ip::make_address("127.0.0.6"), 0});
    const std::array<std::uint8_t, 1> garbage{0x11};
    junk.send_to(asio::buffer(garbage), {asio::ip::make_address("127.0.0.1"), s.server.udp_port()});
    for (auto& m : live) CHECK(m->transact(make(mb::sfc::read_holding_registers_ext, 0, 1)));
    CHECK(s.server.stats().udp_ignored == 1);
    CHECK(s.server.stats().udp_refused == 1);
    const std::lock_guard<std::mutex> hold(lock);
    CHECK(refused.size() == 1);
}
