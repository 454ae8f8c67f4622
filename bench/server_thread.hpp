// A ferrule TCP server (modbus_tcp_server, memobus_server) on its own io_context thread,
// for the server benchmarks (bench/modbus_tcp.cpp, bench/memobus_tcp.cpp): it serves `Data`
// (a model or a register image), which `fill` sets up before the server listens on a free
// loopback port.
#pragma once

#include <asio/io_context.hpp>
#include <asio/ip/address.hpp>
#include <asio/post.hpp>

#include <cstdint>
#include <thread>

#include "tcp_load.hpp"

namespace ferrule::bench {

template <class Server, class Data>
class server_thread {
public:
    template <class Options, class Fill>
    server_thread(const Options& options, Fill fill)
        : server_(ctx_.get_executor(), data_, options) {
        fill(data_);
        server_.listen({::asio::ip::make_address("127.0.0.1"), 0});
        thread_ = std::thread([this] { ctx_.run(); });
    }
    ~server_thread() {
        ::asio::post(ctx_, [this] { server_.close(); });
        ctx_.stop();
        thread_.join();
    }
    server_thread(const server_thread&) = delete;
    server_thread& operator=(const server_thread&) = delete;

    std::uint16_t port() const { return server_.port(); }
    double cpu_seconds() { return thread_cpu_seconds(thread_); }

private:
    ::asio::io_context ctx_;
    Data data_;
    Server server_;
    std::thread thread_;
};

} // namespace ferrule::bench
