#include "tcp_link.hpp"

#include <asio/connect.hpp>
#include <asio/steady_timer.hpp>
#include <fmt/core.h>

#include <charconv>
#include <cstdio>
#include <system_error>

#include "common.hpp"

namespace ferrule::cli {

namespace {

// A port is a decimal number 1-65535: the resolver would take a service name, and wrap a
// larger number into that range (99999 to 34463). Empty when it is one, else why not.
std::string port_problem(const std::string& port) {
    unsigned value = 0;
    const char* last = port.data() + port.size();
    const auto [end, ec] = std::from_chars(port.data(), last, value);
    if (port.empty() || ec != std::errc{} || end != last || value < 1 || value > 65535)
        return fmt::format("port '{}' is not a number 1-65535", port);
    return {};
}

const std::string& checked_port(const std::string& host_port, const std::string& port) {
    if (auto why = port_problem(port); !why.empty())
        throw CLI::ValidationError("--host " + host_port, why);
    return port;
}

} // namespace

std::pair<std::string, std::string> split_host_port(const std::string& host_port,
                                                    const std::string& default_port) {
    if (const auto colon = host_port.rfind(':'); colon != std::string::npos)
        return {host_port.substr(0, colon), checked_port(host_port, host_port.substr(colon + 1))};
    return {host_port, default_port};
}

CLI::Validator host_port_check() {
    return CLI::Validator(
        [](std::string& host_port) {
            const auto colon = host_port.rfind(':');
            return colon == std::string::npos ? std::string()
                                              : port_problem(host_port.substr(colon + 1));
        },
        "HOST[:PORT]");
}

std::unique_ptr<tcp_link> tcp_link::open(const std::string& host_port,
                                         std::chrono::milliseconds connect_timeout, bool trace,
                                         const tcp_peer& peer) {
    const auto [name, port] = split_host_port(host_port, peer.default_port);
    std::unique_ptr<tcp_link> l(new tcp_link());
    std::error_code ec;
    ::asio::ip::tcp::resolver resolver(l->ctx_);
    const auto endpoints = resolver.resolve(name, port, ec);
    if (ec) {
        fmt::print(stderr, "ferrule: cannot resolve {}: {}\n", host_port, ec.message());
        return nullptr;
    }
    if (peer.local_port) {
        const auto protocol = endpoints.begin()->endpoint().protocol();
        l->socket_.open(protocol, ec);
        if (!ec) l->socket_.set_option(::asio::socket_base::reuse_address(true), ec);
        if (!ec) l->socket_.bind({protocol, *peer.local_port}, ec);
        if (ec) {
            fmt::print(stderr, "ferrule: cannot bind local port {}: {}\n", *peer.local_port,
                       ec.message());
            return nullptr;
        }
    }
    bool done = false;
    ::asio::steady_timer timer(l->ctx_);
    timer.expires_after(connect_timeout);
    // A bound socket keeps its local port: connect it to the first address as it is.
    const auto connected = [&](std::error_code e) {
        done = true;
        ec = e;
        timer.cancel();
    };
    if (peer.local_port)
        l->socket_.async_connect(endpoints.begin()->endpoint(), connected);
    else
        ::asio::async_connect(
            l->socket_, endpoints,
            [&](std::error_code e, const ::asio::ip::tcp::endpoint&) { connected(e); });
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
                   "ferrule: cannot connect to {}: connection refused (no {} listens on port {})\n",
                   host_port, peer.server, port);
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
