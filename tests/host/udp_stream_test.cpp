// udp_stream on loopback: the Extended MEMOBUS master reads and writes through it against a
// tiny in-test UDP responder (one datagram, one message: protocols/memobus.md §6), a
// datagram longer than a read comes in pieces but never merged with the next, silence is a
// timeout, and nobody listening is an error.
#include <catch2/catch.hpp>

#include <asio/io_context.hpp>
#include <asio/ip/udp.hpp>

#include <poll.h>

#include <array>
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "ferrule/host/udp_stream.hpp"
#include "ferrule/memobus/access.hpp"
#include "ferrule/memobus/message.hpp"

namespace {

using namespace ferrule;
using namespace std::chrono_literals;
namespace mo = ferrule::memobus;

// Answers each Extended MEMOBUS command datagram: MW n reads as 1000 + n, writes are
// acknowledged, a datagram that is no command is sent back as it came. It serves until
// stopped.
struct responder {
    asio::io_context ctx;
    asio::ip::udp::socket socket{ctx, {asio::ip::make_address("127.0.0.1"), 0}};
    std::atomic<bool> stop{false};
    std::atomic<int> served{0};
    std::thread thread;

    responder() {
        thread = std::thread([this] { serve(); });
    }
    ~responder() {
        stop = true;
        thread.join();
    }
    std::uint16_t port() const { return socket.local_endpoint().port(); }

    void serve() {
        std::array<std::uint8_t, mo::max_message + 16> in{};
        std::array<std::uint8_t, mo::max_message> out{};
        while (!stop) {
            ::pollfd p{socket.native_handle(), POLLIN, 0};
            if (::poll(&p, 1, 10) <= 0) continue;
            asio::ip::udp::endpoint from;
            std::error_code ec;
            const std::size_t n = socket.receive_from(asio::buffer(in), from, 0, ec);
            if (ec) continue;
            const std::span<const std::uint8_t> datagram(in.data(), n);
            const auto h = mo::parse_message(datagram);
            const auto req = h ? mo::parse_request(datagram.subspan(mo::header_size))
                               : result<mo::request>(errc::malformed);
            if (!req) {
                socket.send_to(asio::buffer(datagram.data(), datagram.size()), from, 0, ec);
                continue;
            }
            std::array<std::uint16_t, mo::max_read_registers_ext> words{};
            for (std::size_t i = 0; i < req->count; ++i)
                words[i] = static_cast<std::uint16_t>(1000 + req->address + i);
            mo::response rsp;
            rsp.words = std::span<const std::uint16_t>(words).first(req->count);
            const auto len = mo::encode_response(*h, *req, rsp, out);
            if (!len) continue;
            ++served; // before the answer: the client counts on it once answered
            socket.send_to(asio::buffer(out.data(), *len), from, 0, ec);
        }
    }
};

struct udp_client {
    asio::io_context ctx;
    asio::ip::udp::socket socket{ctx};
    host::udp_stream line{ctx, socket};

    explicit udp_client(std::uint16_t port) {
        socket.open(asio::ip::udp::v4());
        socket.connect({asio::ip::make_address("127.0.0.1"), port});
    }
};

} // namespace

TEST_CASE("udp_stream carries the memobus master's datagrams", "[asio][memobus][udp]") {
    responder r;
    udp_client c(r.port());
    mo::master_config cfg;
    cfg.response_timeout = 2s;
    mo::master m(cfg);
    // 2044 words: a 4102-byte datagram, read 64 bytes at a time by ferrule::run()
    std::vector<std::uint16_t> words(mo::max_read_registers_ext);
    REQUIRE_FALSE(mo::read_words(c.line, m, mo::mw(100), words));
    CHECK(words.front() == 1100);
    CHECK(words.back() == 1100 + 2043);
    const std::array<std::uint16_t, 2> values{1, 2};
    REQUIRE_FALSE(mo::write_words(c.line, m, mo::mw(7), values));
    REQUIRE_FALSE(mo::loopback(c.line, m));
    CHECK(r.served == 3);
    CHECK(m.serial() == 2);
    CHECK(m.stats().succeeded == 3);
}

TEST_CASE("udp_stream keeps datagrams apart", "[asio][udp]") {
    responder r;
    udp_client c(r.port());
    std::vector<std::uint8_t> tracked;
    c.line.set_tap([&](host::direction d, std::span<const std::uint8_t> b, time_point) {
        if (d == host::direction::rx) tracked.insert(tracked.end(), b.begin(), b.end());
    });
    // Two datagrams that are no commands come back as they are.
    const std::vector<std::uint8_t> first(10, 0xAA);
    const std::vector<std::uint8_t> second(3, 0xBB);
    REQUIRE_FALSE(c.line.write(first).ec);
    REQUIRE_FALSE(c.line.write(second).ec);
    std::array<std::uint8_t, 4> buf{};
    std::vector<std::size_t> sizes;
    std::vector<std::uint8_t> got;
    while (got.size() < 13) {
        const auto res = c.line.read_some(buf, c.line.now() + 2s);
        REQUIRE_FALSE(res.ec);
        sizes.push_back(res.bytes);
        got.insert(got.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(res.bytes));
    }
    CHECK(sizes == std::vector<std::size_t>{4, 4, 2, 3}); // 10 in pieces, then 3
    CHECK(got.front() == 0xAA);
    CHECK(got.back() == 0xBB);
    CHECK(tracked == got);

    // Nothing more: a timeout at the deadline.
    const auto t0 = c.line.now();
    const auto res = c.line.read_some(buf, t0 + 30ms);
    CHECK(res.bytes == 0);
    CHECK(res.ec == errc::timeout);
    CHECK(c.line.now() - t0 >= 30ms);

    // discard_input drops what has come and not been read.
    REQUIRE_FALSE(c.line.write(first).ec);
    ::pollfd p{c.socket.native_handle(), POLLIN, 0};
    REQUIRE(::poll(&p, 1, 2000) == 1); // the echo has arrived
    c.line.discard_input();
    CHECK(c.line.read_some(buf, c.line.now() + 20ms).ec == errc::timeout);
}

TEST_CASE("udp_stream: a port nobody listens on is an error", "[asio][udp]") {
    std::uint16_t port = 0;
    {
        asio::io_context ctx;
        asio::ip::udp::socket probe{ctx, {asio::ip::make_address("127.0.0.1"), 0}};
        port = probe.local_endpoint().port();
    }
    udp_client c(port);
    mo::master_config cfg;
    cfg.response_timeout = 1s;
    mo::master m(cfg);
    std::array<std::uint16_t, 1> one{};
    const auto ec = mo::read_words(c.line, m, mo::mw(0), one);
    CHECK(ec);
    CHECK(ec != errc::timeout); // ICMP port unreachable: connection refused
    CHECK(m.stats().failed == 1);
}
