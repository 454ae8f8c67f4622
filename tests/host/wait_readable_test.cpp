// wait_readable(), the ppoll() wait of serial_stream, tcp_stream and udp_stream, on a pipe:
// the deadline, a byte already there, the other end closed.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <system_error>

#include "ferrule/host/serial_stream.hpp"

using namespace std::chrono_literals;
using ferrule::errc;
using ferrule::host::steady_now;
using ferrule::host::wait_readable;

namespace {
struct pipe_fds {
    std::array<int, 2> fd{-1, -1};
    pipe_fds() { REQUIRE(::pipe(fd.data()) == 0); }
    ~pipe_fds() {
        for (const int f : fd)
            if (f >= 0) ::close(f);
    }
    int reader() const { return fd[0]; }
    void write_byte() const {
        const std::uint8_t b = 0x42;
        REQUIRE(::write(fd[1], &b, 1) == 1);
    }
};
} // namespace

TEST_CASE("wait_readable ends in errc::timeout at the deadline, not before", "[asio][wait]") {
    pipe_fds p;
    const auto deadline = steady_now() + 30ms;
    CHECK(wait_readable(p.reader(), deadline) == errc::timeout);
    CHECK(steady_now() >= deadline);
    // A deadline already passed asks once and does not wait.
    CHECK(wait_readable(p.reader(), steady_now() - 1s) == errc::timeout);
}

TEST_CASE("wait_readable returns at once when a byte is there", "[asio][wait]") {
    pipe_fds p;
    p.write_byte();
    // A deadline far away: only the byte ends the wait.
    CHECK_FALSE(wait_readable(p.reader(), steady_now() + 1h));
    // Even when the deadline has passed, what is there is readable.
    CHECK_FALSE(wait_readable(p.reader(), steady_now() - 1s));
}

TEST_CASE("wait_readable reports a descriptor closed at its other end as readable",
          "[asio][wait]") {
    pipe_fds p;
    ::close(p.fd[1]);
    p.fd[1] = -1;
    // End of file is for the read to report: the wait ends.
    CHECK_FALSE(wait_readable(p.reader(), steady_now() + 1h));
}
