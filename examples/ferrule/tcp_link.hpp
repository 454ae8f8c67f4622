// A Modbus TCP connection for the CLI: resolve, connect with a timeout, a blocking stream.
#pragma once

#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "ferrule/asio/serial_stream.hpp"

namespace ferrule::cli {

class tcp_link {
public:
    // "host" or "host:port" (port 502 when none is given); on failure prints why (refused,
    // unknown host, no answer within `connect_timeout`) and returns nullptr.
    static std::unique_ptr<tcp_link> open(const std::string& host_port,
                                          std::chrono::milliseconds connect_timeout, bool trace);
    host::tcp_stream& stream() noexcept { return stream_; }

private:
    tcp_link() : socket_(ctx_), stream_(ctx_, socket_) {}
    ::asio::io_context ctx_;
    ::asio::ip::tcp::socket socket_;
    host::tcp_stream stream_;
};

} // namespace ferrule::cli
