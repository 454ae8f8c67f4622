// Modbus TCP servers on loopback under the same load: ferrule's host::modbus_tcp_server
// (one io_context thread, a memory_model) against a libmodbus server written the usual way
// for many clients (one thread, a select() loop over the listening socket and the clients,
// modbus_receive() + modbus_reply() for the socket that is readable).
//
// Load: one thread with epoll over `clients` non-blocking connections, each with one request
// outstanding at a time: read 10 holding registers (FC 3) of unit 1, the values are checked.
// A run lasts one second of wall time or 400 000 requests, whichever ends first. Counters:
// requests per second, the server thread's CPU time per request, and the latency of each
// request (send of the request to the whole response read) as median, 99th percentile and
// maximum, in microseconds.
//
// stalled/<server>: 8 clients as above plus one that sends the first 6 bytes of a 12-byte
// request when the run begins and then nothing until it ends.
#include <benchmark/benchmark.h>

#include <modbus.h>
#include <netinet/in.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>

#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>
#include <asio/write.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

#include "ferrule/host/modbus_tcp_server.hpp"
#include "ferrule/modbus/memory_model.hpp"
#include "server_thread.hpp"
#include "tcp_load.hpp"

namespace {

namespace mb = ferrule::modbus;
using ferrule::bench::clock_type;
using ferrule::bench::load_result;
using ferrule::bench::thread_cpu_seconds;
constexpr int registers = 10;
constexpr std::size_t max_requests = 400'000;
constexpr auto run_time = std::chrono::seconds(1);

// --- servers --------------------------------------------------------------------------------

using model = mb::memory_model<0, 0, 100, 0>;

struct ferrule_server
    : ferrule::bench::server_thread<ferrule::host::modbus_tcp_server<model>, model> {
    ferrule_server()
        : server_thread(options(), [](model& m) {
              for (std::size_t i = 0; i < 100; ++i)
                  m.holding_registers()[i] = static_cast<std::uint16_t>(0x1000 + i);
          }) {}
    static ferrule::host::modbus_tcp_server_options options() {
        ferrule::host::modbus_tcp_server_options o;
        o.max_connections = 128;
        return o;
    }
};

class libmodbus_server {
public:
    libmodbus_server() : ctx_(modbus_new_tcp("127.0.0.1", 0)) {
        map_ = modbus_mapping_new(0, 0, 100, 0);
        for (int i = 0; i < 100; ++i)
            map_->tab_registers[i] = static_cast<std::uint16_t>(0x1000 + i);
        listener_ = modbus_tcp_listen(ctx_, 128);
        sockaddr_storage a{};
        socklen_t n = sizeof a;
        getsockname(listener_, reinterpret_cast<sockaddr*>(&a), &n);
        port_ = ntohs(reinterpret_cast<sockaddr_in*>(&a)->sin_port);
        thread_ = std::thread([this] { serve(); });
    }
    ~libmodbus_server() {
        stop_ = true;
        thread_.join();
        close(listener_);
        modbus_mapping_free(map_);
        modbus_free(ctx_);
    }
    libmodbus_server(const libmodbus_server&) = delete;
    libmodbus_server& operator=(const libmodbus_server&) = delete;
    std::uint16_t port() const { return port_; }
    double cpu_seconds() { return thread_cpu_seconds(thread_); }

private:
    // libmodbus's many-clients example: select() over the listener and every client; a
    // readable client socket gets modbus_receive() + modbus_reply(); -1 closes it. (The
    // 100 ms select() timeout only lets the destructor stop the loop.)
    void serve() {
        fd_set all;
        FD_ZERO(&all);
        FD_SET(listener_, &all);
        int max_fd = listener_;
        std::array<std::uint8_t, MODBUS_TCP_MAX_ADU_LENGTH> query{};
        while (!stop_) {
            fd_set ready = all;
            timeval tv{0, 100'000};
            if (select(max_fd + 1, &ready, nullptr, nullptr, &tv) <= 0) continue;
            for (int fd = 0; fd <= max_fd; ++fd) {
                if (!FD_ISSET(fd, &ready)) continue;
                if (fd == listener_) {
                    const int c = accept(listener_, nullptr, nullptr);
                    if (c < 0) continue;
                    FD_SET(c, &all);
                    max_fd = std::max(max_fd, c);
                    continue;
                }
                modbus_set_socket(ctx_, fd);
                const int rc = modbus_receive(ctx_, query.data());
                if (rc > 0) {
                    modbus_reply(ctx_, query.data(), rc, map_);
                } else if (rc == -1) {
                    close(fd);
                    FD_CLR(fd, &all);
                }
            }
        }
        for (int fd = 0; fd <= max_fd; ++fd)
            if (fd != listener_ && FD_ISSET(fd, &all)) close(fd);
    }

    modbus_t* ctx_;
    modbus_mapping_t* map_ = nullptr;
    int listener_ = -1;
    std::uint16_t port_ = 0;
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

// --- load -----------------------------------------------------------------------------------

// One client connection: a request written, its response read, the next request. The
// socket is non-blocking; the pool's epoll loop tells it when the response is readable.
class load_client {
public:
    explicit load_client(std::uint16_t port) : fd_(ferrule::bench::connect_loopback(port)) {
        if (fd_ < 0) ok_ = false;
    }
    ~load_client() {
        if (fd_ >= 0) close(fd_);
    }
    load_client(const load_client&) = delete;
    load_client& operator=(const load_client&) = delete;
    int fd() const { return fd_; }

    // Sends the next request; false when the socket refused it.
    bool send_request() {
        ++transaction_;
        // MBAP: transaction, protocol 0, length 6, unit 1; PDU: FC 3, address 0, 10 registers
        request_ = {static_cast<std::uint8_t>(transaction_ >> 8),
                    static_cast<std::uint8_t>(transaction_),
                    0,
                    0,
                    0,
                    6,
                    1,
                    3,
                    0,
                    0,
                    0,
                    registers};
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
    bool valid() const {
        if (response_[0] != request_[0] || response_[1] != request_[1] || response_[7] != 3 ||
            response_[8] != 2 * registers)
            return false;
        for (int i = 0; i < registers; ++i)
            if ((response_[9 + 2 * i] << 8 | response_[10 + 2 * i]) != 0x1000 + i) return false;
        return true;
    }

    int fd_;
    bool ok_ = true;
    clock_type::time_point sent_{};
    std::array<std::uint8_t, 12> request_{};
    std::array<std::uint8_t, 9 + 2 * registers> response_{};
    std::size_t received_ = 0;
    std::uint16_t transaction_ = 0;
};

template <class Server>
void load(benchmark::State& state, bool stalled) {
    const int clients = static_cast<int>(state.range(0));
    load_result result;
    double seconds = 0;
    double server_cpu = 0;
    for (auto _ : state) {
        Server server;
        ::asio::io_context ctx;
        ::asio::ip::tcp::socket staller(ctx);
        if (stalled) {
            staller.connect({::asio::ip::make_address("127.0.0.1"), server.port()});
            const std::array<std::uint8_t, 6> half{0, 1, 0, 0, 0, 6};
            ::asio::write(staller, ::asio::buffer(half));
        }
        result.latency_ns.reserve(max_requests);
        const double cpu_before = server.cpu_seconds();
        const auto start = clock_type::now();
        std::vector<std::unique_ptr<load_client>> pool;
        for (int i = 0; i < clients; ++i)
            pool.push_back(std::make_unique<load_client>(server.port()));
        ferrule::bench::run_load(pool, start + run_time, max_requests, result);
        seconds = std::chrono::duration<double>(clock_type::now() - start).count();
        server_cpu = server.cpu_seconds() - cpu_before;
    }
    ferrule::bench::report(state, result, seconds, server_cpu);
}

void ferrule_server_load(benchmark::State& state) {
    load<ferrule_server>(state, false);
}
void libmodbus_server_load(benchmark::State& state) {
    load<libmodbus_server>(state, false);
}
void stalled_ferrule(benchmark::State& state) {
    load<ferrule_server>(state, true);
}
void stalled_libmodbus(benchmark::State& state) {
    load<libmodbus_server>(state, true);
}

} // namespace

BENCHMARK(ferrule_server_load)
    ->Arg(1)
    ->Arg(8)
    ->Arg(64)
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(libmodbus_server_load)
    ->Arg(1)
    ->Arg(8)
    ->Arg(64)
    ->Iterations(1)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(stalled_ferrule)->Arg(8)->Iterations(1)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(stalled_libmodbus)->Arg(8)->Iterations(1)->UseRealTime()->Unit(benchmark::kMillisecond);
