#include "tcp_link.hpp"

#include <asio/connect.hpp>
#include <asio/steady_timer.hpp>
#include <fmt/core.h>

#include <cstdio>

#include "common.hpp"

namespace ferrule::cli {

std::unique_ptr<tcp_link> tcp_link::open(const std::string& host_port,
                                         std::chrono::milliseconds connect_timeout, bool trace) {
    std::string name = host_port;
    std::string port = "502"; // Modbus TCP's registered port (TCP §4.1)
    if (const auto colon = host_port.rfind(':'); colon != std::string::npos) {
        name = host_port.substr(0, colon);
        port = host_port.substr(colon + 1);
    }
    std::unique_ptr<tcp_link> l(new tcp_link());
    std::error_code ec;
    ::asio::ip::tcp::resolver resolver(l->ctx_);
    const auto endpoints = resolver.resolve(name, port, ec);
    if (ec) {
        fmt::print(stderr, "ferrule: cannot resolve {}: {}\n", host_port, ec.message());
        return nullptr;
    }
    bool done = false;
    ::asio::steady_timer timer(l->ctx_);
    timer.expires_after(connect_timeout);
    ::asio::async_connect(l->socket_, endpoints,
                          [&](std::error_code e, const ::asio::ip::tcp::endpoint&) {
                              done = true;
                              ec = e;
                              timer.cancel();
                          });
    timer.async_wait([&](std::error_code e) {
        if (!e && !done) l->socket_.close();
    });
    l->ctx_.run();
    if (!done || ec == ::asio::error::operation_aborted) {
        fmt::print(stderr, "ferrule: cannot connect to {}: no answer within {} ms\n", host_port,
                   connect_timeout.count());
        return nullptr;
    }
    if (ec == ::asio::error::connection_refused) {
        fmt::print(stderr,
                   "ferrule: cannot connect to {}: connection refused (no Modbus TCP server "
                   "listens on port {})\n",
                   host_port, port);
        return nullptr;
    }
    if (ec) {
        fmt::print(stderr, "ferrule: cannot connect to {}: {}\n", host_port, ec.message());
        return nullptr;
    }
    l->socket_.set_option(::asio::ip::tcp::no_delay(true), ec);
    if (trace) l->stream_.set_tap(trace_tap(host::steady_now()));
    return l;
}

} // namespace ferrule::cli
