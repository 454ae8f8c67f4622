#include "common.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

namespace ferrule::cli {

std::optional<std::int64_t> parse_integer(std::string_view text) {
    const bool negative = text.starts_with('-');
    if (negative) text.remove_prefix(1);
    int base = 10;
    if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
        text.remove_prefix(2);
        base = 16;
    }
    // from_chars into an unsigned type takes digits only: no sign, blank or second prefix.
    std::uint64_t magnitude = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), magnitude, base);
    if (text.empty() || end != text.data() + text.size()) return std::nullopt;
    constexpr auto max = std::numeric_limits<std::int64_t>::max();
    constexpr auto min = std::numeric_limits<std::int64_t>::min();
    if (ec == std::errc::result_out_of_range) return negative ? min : max;
    if (ec != std::errc{}) return std::nullopt;
    if (negative)
        return magnitude > std::uint64_t{max} ? min : -static_cast<std::int64_t>(magnitude);
    return magnitude > std::uint64_t{max} ? max : static_cast<std::int64_t>(magnitude);
}

namespace {

std::string bounds_text(const std::string& lo, const std::string& hi, bool negative) {
    return negative ? lo + " to " + hi : lo + "-" + hi;
}

// "<value> is outside <range> (<note>)": the one form of every refusal.
std::string outside(std::string_view value, std::string_view range, std::string_view note) {
    std::string m = fmt::format("{} is outside {}", value, range);
    if (!note.empty()) m += fmt::format(" ({})", note);
    return m;
}

std::string no_number(std::string_view value, std::string_view kind, std::string_view range,
                      std::string_view note) {
    std::string m = fmt::format("'{}' is no {}: give {}", value, kind, range);
    if (!note.empty()) m += fmt::format(" ({})", note);
    return m;
}

} // namespace

std::string range_text(std::span<const interval> allowed) {
    std::string s;
    for (const auto& i : allowed) {
        if (!s.empty()) s += ", ";
        s += i.lo == i.hi ? std::to_string(i.lo)
                          : bounds_text(std::to_string(i.lo), std::to_string(i.hi), i.lo < 0);
    }
    return s;
}

std::string range_text(double lo, double hi) {
    return bounds_text(fmt::format("{}", lo), fmt::format("{}", hi), lo < 0);
}

CLI::Validator integer_in(std::vector<interval> allowed, std::string note) {
    const std::string range = range_text(allowed);
    return CLI::Validator(
        [allowed = std::move(allowed), range, note = std::move(note)](std::string& text) {
            const auto v = parse_integer(text);
            if (!v) return no_number(text, "integer (decimal or 0x hex)", range, note);
            if (std::none_of(allowed.begin(), allowed.end(),
                             [&](const interval& i) { return *v >= i.lo && *v <= i.hi; }))
                return outside(text, range, note);
            text = std::to_string(*v);
            return std::string();
        },
        range);
}

CLI::Validator integer_in(std::int64_t lo, std::int64_t hi, std::string note) {
    return integer_in(std::vector<interval>{{lo, hi}}, std::move(note));
}

CLI::Validator number_in(double lo, double hi, std::string note) {
    const std::string range = range_text(lo, hi);
    return CLI::Validator(
        [lo, hi, range, note = std::move(note)](std::string& text) {
            double v = 0;
            const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
            const bool whole = end == text.data() + text.size();
            if (text.empty() || !whole || std::isnan(v) ||
                (ec != std::errc{} && ec != std::errc::result_out_of_range))
                return no_number(text, "number", range, note);
            if (ec == std::errc::result_out_of_range || !(v >= lo && v <= hi))
                return outside(text, range, note);
            return std::string();
        },
        range);
}

CLI::Validator host_baud_in(std::int64_t lo, std::int64_t hi, std::string note) {
    std::vector<interval> rates;
    for (auto b : host_baud_rates)
        if (b >= lo && b <= hi) rates.push_back({b, b});
    return integer_in(std::move(rates), std::move(note));
}

int refuse(std::string_view option, std::string_view value, std::string_view range,
           std::string_view note) {
    fmt::print(stderr, "ferrule: {}: {}\n", option, outside(value, range, note));
    return exit_usage;
}

void add_common_options(CLI::App& app, common_options& o, const protocol_ranges& ranges,
                        const std::string& address_names) {
    o.address = ranges.default_address;
    app.add_option("--port,-p", o.port, "serial port")->capture_default_str();
    app.add_option("--baud,-b", o.baud, "baud rate (default: the manual's)")
        ->transform(ranges.baud);
    app.add_option("--format,-f", o.format,
                   "character format: 8E1, 7E1, 8N1, ... (default: the manual's)");
    app.add_option(address_names, o.address, "device address")
        ->transform(ranges.address)
        ->capture_default_str();
    app.add_option("--timeout", o.timeout_ms, "response timeout in ms (default: the manual's)")
        ->transform(integer_in(1, max_ms));
    app.add_option("--retries", o.retries, "resends after a failed attempt")
        ->transform(integer_in(0, max_retries));
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
