// ferrule's Extended MEMOBUS controller side, host::memobus_server (one io_context thread,
// one register_image, a channel per master), on loopback under load.
//
// Load: one thread with epoll over `masters` non-blocking connections (max_channels is 128,
// so every one gets a channel), each with one request outstanding at a time: master i reads
// its own block of 10 hold registers, MW(10 i)…MW(10 i + 9), with SFC 09; the serial
// (0…255, wrapping), the response's shape and the values are checked. A run lasts one second
// of wall time or 400 000 requests, whichever ends first. Counters: requests per second, the
// server thread's CPU time per request, and the latency of each request (send of the
// request to the whole response read) as median, 99th percentile and maximum, in
// microseconds.
#include <benchmark/benchmark.h>

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>

#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/post.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

#include "ferrule/host/memobus_server.hpp"
#include "ferrule/core/bytes.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/register_image.hpp"
#include "server_thread.hpp"
#include "tcp_load.hpp"

namespace {

namespace mem = ferrule::memobus;
using ferrule::bench::clock_type;
using ferrule::bench::load_result;
constexpr int registers = 10;
constexpr int most_masters = 64;
constexpr std::size_t max_requests = 400'000;
constexpr auto run_time = std::chrono::seconds(1);

// The value of MW n in the image.
constexpr std::uint16_t value_of(std::size_t n) {
    return static_cast<std::uint16_t>(0x5A00 ^ (n * 7));
}

using image = mem::register_image<registers * most_masters, 16>;

struct server : ferrule::bench::server_thread<ferrule::host::memobus_server<image>, image> {
    server()
        : server_thread(options(), [](image& im) {
              for (std::size_t i = 0; i < image::mw_size; ++i) im.set_mw(i, value_of(i));
          }) {}
    static ferrule::host::memobus_server_options options() {
        ferrule::host::memobus_server_options o;
        o.max_channels = 128;
        return o;
    }
};

// One master connection: a request written, its response read, the next request. The
// socket is non-blocking; the pool's epoll loop tells it when the response is readable.
class load_master {
public:
    load_master(std::uint16_t port, int index)
        : fd_(ferrule::bench::connect_loopback(port)),
          first_(static_cast<std::uint16_t>(registers * index)) {
        if (fd_ < 0) ok_ = false;
        mem::request r;
        r.function = mem::sfc::read_holding_registers_ext;
        r.address = first_;
        r.count = registers;
        if (mem::encode_command(r, 0, request_).value_or(0) != request_.size()) ok_ = false;
    }
    ~load_master() {
        if (fd_ >= 0) close(fd_);
    }
    load_master(const load_master&) = delete;
    load_master& operator=(const load_master&) = delete;
    int fd() const { return fd_; }

    // Sends the next request (the next serial); false when the socket refused it.
    bool send_request() {
        request_[1] = ++serial_;
        received_ = 0;
        sent_ = clock_type::now();
        return ok_ && ::send(fd_, request_.data(), request_.size(), MSG_NOSIGNAL) ==
                          static_cast<ssize_t>(request_.size());
    }

    // Reads what has come; true when the whole response is in (recorded in `out`).
    bool on_readable(load_result& out) {
        const ssize_t n = recv(fd_, response_.data() + received_, response_.size() - received_, 0);
        if (n <= 0) {
            if (n == 0 || errno != EAGAIN) ok_ = false;
            return !ok_;
        }
        received_ += static_cast<std::size_t>(n);
        if (received_ < response_.size()) return false;
        if (!valid()) ++out.errors;
        out.latency_ns.push_back(static_cast<std::uint32_t>(
            std::chrono::duration_cast<std::chrono::nanoseconds>(clock_type::now() - sent_)
                .count()));
        return true;
    }
    bool ok() const { return ok_; }

private:
    // 218 header (type 0x19, the serial, total 40), length 26, MFC 20, SFC 09, CPU 01,
    // spare, count 10, the registers little-endian.
    bool valid() const {
        const auto& r = response_;
        if (r[0] != 0x19 || r[1] != serial_ || ferrule::load_le16(&r[6]) != r.size() ||
            ferrule::load_le16(&r[12]) != r.size() - 14 || r[14] != mem::mfc_extended ||
            r[15] != 0x09 || r[16] != mem::swap_nibbles(mem::default_cpu) ||
            ferrule::load_le16(&r[18]) != registers)
            return false;
        for (int i = 0; i < registers; ++i)
            if (ferrule::load_le16(&r[20 + 2 * i]) != value_of(first_ + std::size_t(i)))
                return false;
        return true;
    }

    int fd_;
    bool ok_ = true;
    std::uint16_t first_;
    std::uint8_t serial_ = 0xFF; // the first request has serial 0
    clock_type::time_point sent_{};
    std::array<std::uint8_t, 22> request_{};
    std::array<std::uint8_t, 20 + 2 * registers> response_{};
    std::size_t received_ = 0;
};

void memobus_server_load(benchmark::State& state) {
    const int masters = static_cast<int>(state.range(0));
    load_result result;
    double seconds = 0;
    double server_cpu = 0;
    for (auto _ : state) {
        server s;
        result.latency_ns.reserve(max_requests);
        const double cpu_before = s.cpu_seconds();
        const auto start = clock_type::now();
        std::vector<std::unique_ptr<load_master>> pool;
        for (int i = 0; i < masters; ++i)
            pool.push_back(std::make_unique<load_master>(s.port(), i));
        ferrule::bench::run_load(pool, start + run_time, max_requests, result);
        seconds = std::chrono::duration<double>(clock_type::now() - start).count();
        server_cpu = s.cpu_seconds() - cpu_before;
    }
    ferrule::bench::report(state, result, seconds, server_cpu);
}

} // namespace

BENCHMARK(memobus_server_load)
    ->Arg(1)
    ->Arg(16)
    ->Arg(64)
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
