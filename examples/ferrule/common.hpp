// What every `ferrule` subcommand shares: the common options, opening the port, tracing,
// printing results as text or JSON, and exit codes.
#pragma once

#include <CLI/CLI.hpp>
#include <asio/io_context.hpp>
#include <asio/serial_port.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "../common/hex.hpp"
#include "ferrule/asio/serial_port.hpp"
#include "ferrule/asio/serial_stream.hpp"
#include "ferrule/core/serial_format.hpp"

namespace ferrule::cli {

// Exit codes (docs/cli.md).
enum exit_code : int {
    exit_ok = 0,
    exit_device_error = 1, // the device answered with an error
    exit_usage = 2,
    exit_transport = 3, // timeout, no port, I/O error
};

struct common_options {
    std::string port = "/dev/ttyUSB0";
    std::optional<std::uint32_t> baud;
    std::optional<std::string> format;
    unsigned address = 0;
    std::optional<unsigned> timeout_ms;
    std::optional<unsigned> retries;
    bool trace = false;
    bool json = false;
    bool dry_run = false;
    bool rs485 = false;
};

// Adds the common options to a protocol's subcommand. `default_address` is the protocol's;
// `address_names` the option's names in its terms (Modbus: the unit).
void add_common_options(CLI::App& app, common_options& o, unsigned default_address,
                        const std::string& address_names = "--address,-a");

// The serial format from --format / --baud over the protocol's manual default.
result<serial_format> resolve_format(const common_options& o, serial_format manual_default);

using tools::hex;
using tools::parse_hex;

// The --trace printer: each chunk with its time since `t0`, direction and hex, on stderr.
host::tap_handler trace_tap(time_point t0);

// One open port with its blocking stream; prints --trace lines on stderr.
class port_session {
public:
    // Opens the port; on failure prints why and returns nullptr.
    static std::unique_ptr<port_session> open(const common_options& o, const serial_format& f);
    host::serial_stream& stream() noexcept { return stream_; }

private:
    port_session() : port_(ctx_), stream_(ctx_, port_) {}
    ::asio::io_context ctx_;
    ::asio::serial_port port_;
    host::serial_stream stream_;
    time_point opened_{};
};

// What every protocol subcommand does around its work: the serial format from the options over
// the manual's default, the port unless --dry-run, then fn(context). Context is the
// protocol's: built from (options, format), with a `port` member. Returns the exit status.
template <class Context, class Options>
int run_on_port(const Options& o, const serial_format& manual_default, int (*fn)(Context&)) {
    const auto f = resolve_format(o.common, manual_default);
    if (!f) {
        fmt::print(stderr, "ferrule: --format/--baud: {}\n", f.error().message());
        return exit_usage;
    }
    Context c(o, *f);
    if (!o.common.dry_run) {
        c.port = port_session::open(o.common, *f);
        if (!c.port) return exit_transport;
    }
    return fn(c);
}

// Prints one result: as a JSON object (--json) or as the text line given.
void emit(const common_options& o, const nlohmann::json& j, const std::string& text);

// Reports a failed operation and returns its exit code: 1 if the device said so, else 3.
int report_error(const common_options& o, const std::string& what, std::error_code ec,
                 bool device_error);

} // namespace ferrule::cli
