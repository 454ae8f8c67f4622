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
#include <string_view>
#include <system_error>
#include <vector>

#include "../common/hex.hpp"
#include "ferrule/core/serial_format.hpp"
#include "ferrule/host/serial_port.hpp"
#include "ferrule/host/serial_stream.hpp"

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

// Numbers on the command line (docs/cli.md, "Numbers and ranges"). An integer is decimal or
// 0x hex, '-' before a negative one; a leading 0 is still decimal (CLI11 alone reads 010 as
// octal 8). Every numeric option and argument is checked against its range while the command
// line is parsed, or by refuse() where the range depends on other options: a refusal names
// the option, the value and the range, and exits 2.

// An integer from a command line; a number beyond 64 bits saturates to the nearest 64-bit
// bound, which every range refuses. nullopt when `text` is no number.
std::optional<std::int64_t> parse_integer(std::string_view text);

// Inclusive bounds of allowed values.
struct interval {
    std::int64_t lo;
    std::int64_t hi;
};

// "0-255", "-32768 to 65535", "9600, 57600", "0-99, 254".
std::string range_text(std::span<const interval> allowed);
std::string range_text(double lo, double hi);

// The check of an integer option or argument: only values in `allowed`. `note` (what the
// values mean, the manual's section) follows the range in a refusal. It leaves the number in
// decimal for CLI11 to convert. Give it to CLI::Option::transform().
CLI::Validator integer_in(std::vector<interval> allowed, std::string note = {});
CLI::Validator integer_in(std::int64_t lo, std::int64_t hi, std::string note = {});
// The check of a decimal number (rpm, s, ms): finite and in [lo, hi].
CLI::Validator number_in(double lo, double hi, std::string note = {});

// Every duration in ms, interval, response timeout or pause, is at most a day (also the
// longest sampling time of a D-Series sensor, S1 §8.2.5).
inline constexpr std::int64_t max_ms = 86'400'000;
// A count of repetitions (measurements, cycles, lines).
inline constexpr std::int64_t max_count = 1'000'000;
// Resends after a failed attempt: more only hide a broken line.
inline constexpr std::int64_t max_retries = 100;

// The refusal of a value whose range depends on other options, found after parsing. Prints
// "ferrule: <option>: <value> is outside <range> (<note>)" and returns exit_usage.
int refuse(std::string_view option, std::string_view value, std::string_view range,
           std::string_view note = {});

// The baud rates host::open_serial() can set (ferrule/host/serial_port.hpp).
inline constexpr std::int64_t host_baud_rates[] = {1200,  2400,   4800,   9600,   19200, 38400,
                                                   57600, 115200, 230400, 460800, 921600};

// The check of --baud: the rates host::open_serial() can set within [lo, hi].
CLI::Validator host_baud_in(std::int64_t lo, std::int64_t hi, std::string note);

// What the common options of a protocol accept: its addresses and baud rates.
struct protocol_ranges {
    unsigned default_address;
    CLI::Validator address;
    CLI::Validator baud;
};

// Adds the common options to a protocol's subcommand. `address_names` are the address
// option's names in the protocol's terms (Modbus: the unit).
void add_common_options(CLI::App& app, common_options& o, const protocol_ranges& ranges,
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
        fmt::print(stderr, "ferrule: --format/--baud: {}\n", std::error_code(f.error()).message());
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
