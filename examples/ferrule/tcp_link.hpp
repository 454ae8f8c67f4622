// A TCP connection for the CLI (Modbus TCP, Extended MEMOBUS): resolve, bind a local port if
// asked, connect with a timeout, a blocking stream.
#pragma once

#include <CLI/CLI.hpp>
#include <asio/io_context.hpp>
#include <asio/ip/tcp.hpp>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "ferrule/host/serial_stream.hpp"

namespace ferrule::cli {

// "host" or "host:port": the name and the port, `default_port` when none is given. A port
// that is not a number 1-65535 is a usage error: CLI::ValidationError, thrown before
// anything is resolved or connected (exit code 2 from the command's callback).
std::pair<std::string, std::string> split_host_port(const std::string& host_port,
                                                    const std::string& default_port);

// The same check of the port while the command line is parsed, so that --dry-run, which
// connects nowhere, refuses a bad port too. Give it to CLI::Option::check().
CLI::Validator host_port_check();

struct tcp_peer {
    std::string default_port = "502";          // Modbus TCP's registered port (TCP §4.1)
    std::string server = "Modbus TCP server";  // for "no … listens on port N"
    std::optional<std::uint16_t> local_port{}; // bind before connecting
};

class tcp_link {
public:
    // "host" or "host:port"; on failure prints why (refused, unknown host, no answer within
    // `connect_timeout`) and returns nullptr. A port that is not 1-65535: as split_host_port().
    static std::unique_ptr<tcp_link> open(const std::string& host_port,
                                          std::chrono::milliseconds connect_timeout, bool trace,
                                          const tcp_peer& peer = {});
    host::tcp_stream& stream() noexcept { return stream_; }

private:
    tcp_link() : socket_(ctx_), stream_(ctx_, socket_) {}
    ::asio::io_context ctx_;
    ::asio::ip::tcp::socket socket_;
    host::tcp_stream stream_;
};

} // namespace ferrule::cli
