// The loopback TCP load generator the server benchmarks share (bench/modbus_tcp.cpp,
// bench/memobus_tcp.cpp): one thread with epoll over non-blocking connections, each with one
// request outstanding, lighter than the servers it drives so that it is not the limit.
//
// A Client has fd(), send_request() (false when the socket refused it), on_readable(result)
// (true when the whole response is in or the connection failed; it records the latency) and
// ok().
#pragma once

#include <benchmark/benchmark.h>

#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <pthread.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

namespace ferrule::bench {

using clock_type = std::chrono::steady_clock;

struct load_result {
    std::vector<std::uint32_t> latency_ns;
    std::size_t errors = 0;
};

// A non-blocking TCP connection to 127.0.0.1:port with TCP_NODELAY; -1 when refused.
inline int connect_loopback(std::uint16_t port) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
        close(fd);
        return -1;
    }
    const int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
    return fd;
}

// Runs the pool until `end` or `max_requests` responses.
template <class Client>
void run_load(std::vector<std::unique_ptr<Client>>& pool, clock_type::time_point end,
              std::size_t max_requests, load_result& out) {
    const int ep = epoll_create1(0);
    std::size_t active = 0;
    for (auto& c : pool) {
        epoll_event ev{};
        ev.events = EPOLLIN;
        ev.data.ptr = c.get();
        epoll_ctl(ep, EPOLL_CTL_ADD, c->fd(), &ev);
        if (c->send_request())
            ++active;
        else
            ++out.errors;
    }
    std::array<epoll_event, 128> events{};
    while (active > 0) {
        const int n = epoll_wait(ep, events.data(), static_cast<int>(events.size()), 1000);
        if (n <= 0) {
            ++out.errors; // a response did not come within a second
            break;
        }
        const bool more = clock_type::now() < end && out.latency_ns.size() < max_requests;
        for (int i = 0; i < n; ++i) {
            auto* c = static_cast<Client*>(events[static_cast<std::size_t>(i)].data.ptr);
            if (!c->on_readable(out)) continue;
            const bool failed = !c->ok() || (more && !c->send_request());
            if (failed) ++out.errors;
            if (failed || !more) {
                epoll_ctl(ep, EPOLL_CTL_DEL, c->fd(), nullptr);
                --active;
            }
        }
    }
    close(ep);
}

// A server thread's CPU time.
inline double thread_cpu_seconds(std::thread& t) {
    clockid_t id{};
    pthread_getcpuclockid(t.native_handle(), &id);
    timespec ts{};
    clock_gettime(id, &ts);
    return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) / 1e9;
}

inline double percentile(std::vector<std::uint32_t>& v, double p) {
    if (v.empty()) return 0;
    const auto k = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k] / 1000.0;
}

// requests, req_per_s, server_cpu_us_per_req, p50_us, p99_us, max_us.
inline void report(benchmark::State& state, load_result& r, double seconds, double server_cpu) {
    if (r.errors > 0) state.SkipWithError("a request failed or returned wrong values");
    const auto requests = static_cast<double>(r.latency_ns.size());
    state.counters["requests"] = requests;
    state.counters["req_per_s"] = requests / seconds;
    state.counters["server_cpu_us_per_req"] = requests > 0 ? server_cpu / requests * 1e6 : 0.0;
    state.counters["p50_us"] = percentile(r.latency_ns, 0.50);
    state.counters["p99_us"] = percentile(r.latency_ns, 0.99);
    state.counters["max_us"] =
        r.latency_ns.empty() ? 0.0
                             : *std::max_element(r.latency_ns.begin(), r.latency_ns.end()) / 1000.0;
}

} // namespace ferrule::bench
