// A master keeps talking to a controller across the controller's restart:
// reconnecting_tcp_stream opens the connection again on the first request after it was lost.
#include <catch2/catch.hpp>

#include <asio/io_context.hpp>
#include <asio/post.hpp>

#include <array>
#include <memory>
#include <thread>

#include "ferrule/host/memobus_server.hpp"
#include "ferrule/host/reconnecting_tcp_stream.hpp"
#include "ferrule/memobus/access.hpp"
#include "ferrule/memobus/register_image.hpp"

namespace {

using namespace ferrule;
using namespace std::chrono_literals;
namespace mo = ferrule::memobus;
using image_type = mo::register_image<1024, 16>;

struct controller {
    asio::io_context ctx;
    image_type image;
    host::memobus_server<image_type> server{ctx.get_executor(), image};
    std::thread thread;

    explicit controller(std::uint16_t port) {
        REQUIRE_FALSE(server.listen({asio::ip::make_address("127.0.0.1"), port}));
        thread = std::thread([this] { ctx.run(); });
    }
    ~controller() {
        asio::post(ctx, [this] { server.close(); });
        ctx.stop();
        thread.join();
    }
};

} // namespace

TEST_CASE("memobus master reconnects to a controller that restarted", "[asio][memobus]") {
    auto mp = std::make_unique<controller>(0);
    const std::uint16_t port = mp->server.port();
    asio::io_context ctx;
    host::reconnecting_tcp_stream line(ctx, {asio::ip::make_address("127.0.0.1"), port});
    mo::master m({.response_timeout = 500ms});
    const std::array<std::uint16_t, 2> out{0x1234, 0xABCD};
    REQUIRE_FALSE(mo::write(line, m, "MW00100", out));
    CHECK(line.stats().connects == 1);

    mp.reset(); // the controller goes away
    std::array<std::uint16_t, 2> in{};
    CHECK(mo::read(line, m, "MW00100", in)); // this transaction fails
    CHECK_FALSE(line.connected());

    mp = std::make_unique<controller>(port); // and comes back, its image empty
    REQUIRE_FALSE(mo::write(line, m, "MW00100", out));
    REQUIRE_FALSE(mo::read(line, m, "MW00100", in));
    CHECK(in == out);
    CHECK(line.stats().connects == 2);
    CHECK(line.stats().losses >= 1);
}
