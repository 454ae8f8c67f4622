#include "common.hpp"

#include <cctype>
#include <cstdio>
#include <set>

namespace ferrule::cli {

void add_common_options(CLI::App& app, common_options& o, unsigned default_address,
                        const std::string& address_names) {
    o.address = default_address;
    app.add_option("--port,-p", o.port, "serial port")->capture_default_str();
    app.add_option("--baud,-b", o.baud, "baud rate (default: the manual's)");
    app.add_option("--format,-f", o.format,
                   "character format: 8E1, 7E1, 8N1, ... (default: the manual's)");
    app.add_option(address_names, o.address, "device address")->capture_default_str();
    app.add_option("--timeout", o.timeout_ms, "response timeout in ms (default: the manual's)");
    app.add_option("--retries", o.retries, "resends after a failed attempt");
    app.add_flag("--trace", o.trace, "print every frame as hex with direction and time (stderr)");
    app.add_flag("--json", o.json, "one JSON object per result");
    app.add_flag("--dry-run", o.dry_run, "print the request bytes as hex; open nothing");
    app.add_flag("--rs485", o.rs485, "let the port's driver switch the RS-485 transceiver");
}

result<serial_format> resolve_format(const common_options& o, serial_format manual_default) {
    serial_format f = manual_default;
    if (o.format) {
        const auto parsed = serial_format::parse(*o.format, f.baud);
        if (!parsed) return parsed.error();
        f = *parsed;
    }
    if (o.baud) f.baud = *o.baud;
    if (f.baud == 0) return errc::invalid_argument;
    return f;
}

// For text protocols (Dimetix): the bytes as text too, with CR and LF escaped.
std::string ascii_suffix(std::span<const std::uint8_t> bytes) {
    std::string text;
    for (auto b : bytes) {
        if (b == '\r')
            text += "\\r";
        else if (b == '\n')
            text += "\\n";
        else if (b >= 0x20 && b < 0x7F)
            text += static_cast<char>(b);
        else
            return {};
    }
    return "   \"" + text + "\"";
}

std::unique_ptr<port_session> port_session::open(const common_options& o, const serial_format& f) {
    std::unique_ptr<port_session> p(new port_session());
    host::serial_options options;
    options.format = f;
    options.rs485 = o.rs485;
    // A port opened again (the demo does) has nothing new to say: each warning once.
    const auto warn = [](std::string_view text) {
        static std::set<std::string, std::less<>> said;
        if (said.emplace(text).second) fmt::print(stderr, "warning: {}\n", text);
    };
    if (auto ec = host::open_serial(p->port_, o.port, options, warn)) {
        fmt::print(stderr, "ferrule: {}\n", host::open_error_message(o.port, ec));
        return nullptr;
    }
    p->opened_ = host::steady_now();
    if (o.trace) p->stream_.set_tap(trace_tap(p->opened_));
    return p;
}

host::tap_handler trace_tap(time_point t0) {
    return [t0](host::direction d, std::span<const std::uint8_t> b, time_point t) {
        fmt::print(stderr, "{:10.3f} ms {} {}{}\n",
                   std::chrono::duration<double, std::milli>(t - t0).count(),
                   d == host::direction::tx ? "->" : "<-", hex(b), ascii_suffix(b));
    };
}

void emit(const common_options& o, const nlohmann::json& j, const std::string& text) {
    if (o.json)
        fmt::print("{}\n", j.dump());
    else
        fmt::print("{}\n", text);
    std::fflush(stdout);
}

int report_error(const common_options& o, const std::string& what, std::error_code ec,
                 bool device_error) {
    if (o.json) {
        nlohmann::json j{{"ok", false},
                         {"operation", what},
                         {"error", ec.message()},
                         {"category", ec.category().name()},
                         {"code", ec.value()}};
        fmt::print("{}\n", j.dump());
    } else {
        fmt::print(stderr, "ferrule: {}: {}\n", what, ec.message());
    }
    return device_error ? exit_device_error : exit_transport;
}

} // namespace ferrule::cli
