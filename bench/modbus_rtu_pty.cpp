// Modbus RTU over a pseudo-terminal pair made by socat, against one libmodbus RTU server
// (a child process of the benchmark, 19200 8N1 as tests/peers/libmodbus_peer.c): each
// transaction reads 10 holding registers (FC 3) of unit 1 and checks the values.
//
//   bare        a bare write() of the 8-byte request, poll() + read() until the 25-byte
//               response is in: what any client must at least do (the floor)
//   libmodbus   modbus_read_registers() of a libmodbus RTU client (it keeps no gap)
//   ferrule     modbus::read_holding_registers() over host::serial_stream on an
//               asio::serial_port, inter_frame_gap = 0 (the option for virtual links),
//               input flushed before each request (discard_stale_input, the default:
//               one tcflush() per transaction)
//   ferrule_noflush  the same with discard_stale_input = false: the system calls of the
//               bare loop and of libmodbus, which flush nothing either
//
// side_by_side runs the three in turns on one pty pair and server, so they share whatever
// else the machine does. Counters per client: transactions per second of wall time and CPU
// time per transaction (getrusage RUSAGE_SELF, user + system; the server and socat are other
// processes). only_<client> runs one client alone, for counting its system calls with
// `strace -c` (docs/PERFORMANCE.md).
#include <benchmark/benchmark.h>

#include <fcntl.h>
#include <modbus.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <asio/io_context.hpp>
#include <asio/serial_port.hpp>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <thread>

#include "ferrule/host/serial_stream.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/client.hpp"

extern char** environ;

namespace {

namespace mb = ferrule::modbus;
constexpr int registers = 10;

double cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
           static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

bool values_ok(const std::uint16_t* regs) {
    for (int i = 0; i < registers; ++i)
        if (regs[i] != 0x1000 + i) return false;
    return true;
}

// socat's pty pair and a libmodbus RTU server on one end, for the lifetime of the object.
class rig {
public:
    rig() {
        char dir_template[] = "/tmp/ferrule-bench-XXXXXX";
        dir_ = mkdtemp(dir_template);
        client_path_ = dir_ + "/client";
        server_path_ = dir_ + "/server";
        const std::string a = "pty,raw,echo=0,link=" + client_path_;
        const std::string b = "pty,raw,echo=0,link=" + server_path_;
        char* argv[] = {const_cast<char*>("socat"), const_cast<char*>(a.c_str()),
                        const_cast<char*>(b.c_str()), nullptr};
        if (posix_spawnp(&socat_, "socat", nullptr, nullptr, argv, environ) != 0) return;
        struct stat st {};
        for (int i = 0; i < 500 && (stat(client_path_.c_str(), &st) != 0 ||
                                    stat(server_path_.c_str(), &st) != 0);
             ++i)
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        server_ = fork();
        if (server_ == 0) serve(server_path_.c_str());
        // Give the server time to open its end and set the line up.
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    ~rig() {
        if (server_ > 0) {
            kill(server_, SIGTERM);
            waitpid(server_, nullptr, 0);
        }
        if (socat_ > 0) {
            kill(socat_, SIGTERM);
            waitpid(socat_, nullptr, 0);
        }
        rmdir(dir_.c_str());
    }
    rig(const rig&) = delete;
    rig& operator=(const rig&) = delete;

    bool ok() const { return socat_ > 0 && server_ > 0; }
    const std::string& client_path() const { return client_path_; }

private:
    [[noreturn]] static void serve(const char* path) {
        modbus_t* ctx = modbus_new_rtu(path, 19200, 'N', 8, 1);
        if (!ctx || modbus_set_slave(ctx, 1) != 0 || modbus_connect(ctx) != 0) _exit(1);
        modbus_mapping_t* m = modbus_mapping_new(0, 0, 100, 0);
        for (int i = 0; i < 100; ++i) m->tab_registers[i] = static_cast<std::uint16_t>(0x1000 + i);
        std::array<std::uint8_t, MODBUS_RTU_MAX_ADU_LENGTH> req{};
        for (;;) {
            const int n = modbus_receive(ctx, req.data());
            if (n > 0) modbus_reply(ctx, req.data(), n, m);
        }
    }

    std::string dir_, client_path_, server_path_;
    pid_t socat_ = -1;
    pid_t server_ = -1;
};

class bare_client {
public:
    explicit bare_client(const std::string& path) : fd_(open(path.c_str(), O_RDWR | O_NOCTTY)) {}
    ~bare_client() {
        if (fd_ >= 0) close(fd_);
    }
    bare_client(const bare_client&) = delete;
    bare_client& operator=(const bare_client&) = delete;
    bool ok() const { return fd_ >= 0; }

    bool transact() {
        // unit 1, FC 3, address 0, 10 registers, CRC
        static constexpr std::array<std::uint8_t, 8> request{0x01, 0x03, 0x00, 0x00,
                                                             0x00, 0x0A, 0xC5, 0xCD};
        if (write(fd_, request.data(), request.size()) != static_cast<ssize_t>(request.size()))
            return false;
        std::array<std::uint8_t, 5 + 2 * registers> response{};
        std::size_t got = 0;
        while (got < response.size()) {
            pollfd p{fd_, POLLIN, 0};
            if (poll(&p, 1, 1000) != 1) return false;
            const ssize_t n = read(fd_, response.data() + got, response.size() - got);
            if (n <= 0) return false;
            got += static_cast<std::size_t>(n);
        }
        std::array<std::uint16_t, registers> regs{};
        for (int i = 0; i < registers; ++i)
            regs[i] = static_cast<std::uint16_t>(response[3 + 2 * i] << 8 | response[4 + 2 * i]);
        return values_ok(regs.data());
    }

private:
    int fd_;
};

class libmodbus_client {
public:
    explicit libmodbus_client(const std::string& path)
        : ctx_(modbus_new_rtu(path.c_str(), 19200, 'N', 8, 1)) {
        if (ctx_ && modbus_connect(ctx_) != 0) {
            modbus_free(ctx_);
            ctx_ = nullptr;
        }
        if (!ctx_) return;
        modbus_set_slave(ctx_, 1);
        modbus_set_response_timeout(ctx_, 1, 0);
    }
    ~libmodbus_client() {
        if (!ctx_) return;
        modbus_close(ctx_);
        modbus_free(ctx_);
    }
    libmodbus_client(const libmodbus_client&) = delete;
    libmodbus_client& operator=(const libmodbus_client&) = delete;
    bool ok() const { return ctx_ != nullptr; }

    bool transact() {
        std::array<std::uint16_t, registers> regs{};
        return modbus_read_registers(ctx_, 0, registers, regs.data()) == registers &&
               values_ok(regs.data());
    }

private:
    modbus_t* ctx_;
};

// `baud` is client_config::format's: the session times the request's bytes with it and sends
// the next request no earlier than the computed end of the last one, whatever the gap.
class ferrule_client {
public:
    ferrule_client(const std::string& path, std::uint32_t baud, bool flush = true)
        : port_(ctx_, path), stream_(ctx_, port_), session_(config(baud, flush)) {
        port_.set_option(::asio::serial_port::baud_rate(19200));
        port_.set_option(::asio::serial_port::character_size(8));
        port_.set_option(::asio::serial_port::parity(::asio::serial_port::parity::none));
        port_.set_option(::asio::serial_port::stop_bits(::asio::serial_port::stop_bits::one));
    }
    bool ok() const { return port_.is_open(); }

    bool transact() {
        std::array<std::uint16_t, registers> regs{};
        return !mb::read_holding_registers(stream_, session_, 1, 0, regs) && values_ok(regs.data());
    }

private:
    static mb::client_config config(std::uint32_t baud, bool flush) {
        mb::client_config c;
        c.format = {baud, 8, ferrule::parity::none, 1};
        c.inter_frame_gap = ferrule::duration::zero();
        c.discard_stale_input = flush;
        return c;
    }

    ::asio::io_context ctx_;
    ::asio::serial_port port_;
    ferrule::host::serial_stream stream_;
    mb::client session_;
};

struct tally {
    double wall = 0;
    double cpu = 0;
    int good = 0;
    int done = 0;
};

template <class Client>
void burst(Client& c, int n, tally& t) {
    const auto w0 = std::chrono::steady_clock::now();
    const double c0 = cpu_seconds();
    for (int i = 0; i < n; ++i)
        if (c.transact()) ++t.good;
    t.cpu += cpu_seconds() - c0;
    t.wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
    t.done += n;
}

void put(benchmark::State& state, const char* name, const tally& t) {
    state.counters[std::string(name) + "_tx_per_s"] = t.done / t.wall;
    state.counters[std::string(name) + "_cpu_us_per_tx"] = t.cpu / t.done * 1e6;
}

// 50 rounds of 100 transactions of each client in turn (5000 each), with format 4 Mbaud for
// ferrule; and 100 transactions of ferrule with format 19200 at the end.
void side_by_side(benchmark::State& state) {
    constexpr int rounds = 50, burst_size = 100;
    tally bare, lib, ours, noflush, ours19200;
    for (auto _ : state) {
        rig r;
        if (!r.ok()) return state.SkipWithError("no pty pair / server");
        bare_client b(r.client_path());
        libmodbus_client l(r.client_path());
        ferrule_client f(r.client_path(), 4'000'000);
        ferrule_client fn(r.client_path(), 4'000'000, false);
        ferrule_client f19200(r.client_path(), 19200);
        if (!b.ok() || !l.ok() || !f.ok() || !fn.ok())
            return state.SkipWithError("cannot open the pty");
        for (int i = 0; i < rounds; ++i) {
            burst(b, burst_size, bare);
            burst(l, burst_size, lib);
            burst(f, burst_size, ours);
            burst(fn, burst_size, noflush);
        }
        burst(f19200, burst_size, ours19200);
    }
    if (bare.good != bare.done || lib.good != lib.done || ours.good != ours.done ||
        noflush.good != noflush.done || ours19200.good != ours19200.done)
        state.SkipWithError("a transaction failed or returned wrong values");
    put(state, "bare", bare);
    put(state, "libmodbus", lib);
    put(state, "ferrule", ours);
    put(state, "ferrule_noflush", noflush);
    put(state, "ferrule_19200", ours19200);
    state.counters["ferrule_vs_bare"] = bare.wall / ours.wall;
    state.counters["ferrule_vs_libmodbus"] = lib.wall / ours.wall;
    state.counters["noflush_vs_bare"] = bare.wall / noflush.wall;
    state.counters["noflush_vs_libmodbus"] = lib.wall / noflush.wall;
}

// One client alone, 2000 transactions.
template <class Client, class... Args>
void only(benchmark::State& state, Args... args) {
    tally t;
    for (auto _ : state) {
        rig r;
        Client c(r.client_path(), args...);
        if (!r.ok() || !c.ok()) return state.SkipWithError("no pty pair / server");
        burst(c, 2000, t);
    }
    if (t.good != t.done) state.SkipWithError("a transaction failed or returned wrong values");
    put(state, "client", t);
}

void only_bare(benchmark::State& state) {
    only<bare_client>(state);
}
void only_libmodbus(benchmark::State& state) {
    only<libmodbus_client>(state);
}
void only_ferrule(benchmark::State& state) {
    only<ferrule_client>(state, std::uint32_t{4'000'000}, true);
}
void only_ferrule_noflush(benchmark::State& state) {
    only<ferrule_client>(state, std::uint32_t{4'000'000}, false);
}

} // namespace

BENCHMARK(side_by_side)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(only_bare)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(only_libmodbus)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(only_ferrule)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(only_ferrule_noflush)->Iterations(1)->Unit(benchmark::kMillisecond);
