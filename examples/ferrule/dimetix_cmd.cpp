// `ferrule dimetix …`: a Dimetix D-Series laser distance sensor on a serial port.
#include <array>
#include <chrono>
#include <limits>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "ferrule/dimetix/access.hpp"

namespace ferrule::cli {
namespace {

namespace dx = ferrule::dimetix;
using namespace std::chrono_literals;

struct dimetix_options {
    common_options common;
    unsigned count = 1;
    unsigned interval_ms = 100;
    bool repetitive = false;
    std::string mnemonic;
    std::vector<std::int32_t> values;
    bool force = false;
};

bool is_device_error(std::error_code ec) {
    return ec.category() == dx::device_category();
}

struct context {
    const dimetix_options& o;
    dx::sensor sensor;
    std::unique_ptr<port_session> port;

    context(const dimetix_options& opts, const serial_format& f)
        : o(opts), sensor(config(opts, f)) {}

    static dx::sensor_config config(const dimetix_options& o, const serial_format& f) {
        dx::sensor_config c;
        c.format = f;
        if (o.common.timeout_ms)
            c.command_timeout = c.measurement_timeout =
                std::chrono::milliseconds(*o.common.timeout_ms);
        if (o.common.retries) c.retries = *o.common.retries;
        c.fault_threshold = 0; // a command-line call reports each failure itself
        c.force_continuous = o.force;
        return c;
    }
    std::uint8_t id() const noexcept { return static_cast<std::uint8_t>(o.common.address); }
};

// For --dry-run: the request line as hex and as text.
int print_request(const dx::command& c) {
    std::array<std::uint8_t, dx::max_request_length> buf{};
    const auto n = dx::encode(c, buf);
    if (!n) {
        fmt::print(stderr, "ferrule: cannot encode the command: {}\n",
                   std::error_code(n.error()).message());
        return exit_usage;
    }
    const std::span<const std::uint8_t> bytes(buf.data(), *n);
    fmt::print("{}   {}\\r\\n\n", hex(bytes),
               std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size() - 2));
    return exit_ok;
}

std::string values_text(const dx::reply& r) {
    std::string s;
    for (auto v : r.value_span()) s += fmt::format("{}{}", s.empty() ? "" : " ", v);
    return s;
}

nlohmann::json reply_json(const dx::reply& r) {
    return {{"ok", true},
            {"id", r.id},
            {"mnemonic", std::string(r.mnemonic.view())},
            {"values", std::vector<std::int32_t>(r.value_span().begin(), r.value_span().end())}};
}

int fail(const context& c, const std::string& what, std::error_code ec) {
    return report_error(c.o.common, what, ec, is_device_error(ec));
}

// One command, its answer printed as it came.
int simple(context& c, const dx::command& cmd, const std::string& what) {
    if (c.o.common.dry_run) return print_request(cmd);
    const auto r = dx::transact(c.port->stream(), c.sensor, cmd);
    if (!r) return fail(c, what, r.error());
    auto j = reply_json(*r);
    j["operation"] = what;
    emit(c.o.common, j,
         r->count ? fmt::format("sensor {} {}: {}", r->id, what, values_text(*r))
                  : fmt::format("sensor {} {}: ok", r->id, what));
    return exit_ok;
}

int cmd_measure(context& c) {
    if (c.o.common.dry_run) return print_request(dx::distance(c.id()));
    for (unsigned i = 0; i < c.o.count; ++i) {
        if (i) std::this_thread::sleep_for(std::chrono::milliseconds(c.o.interval_ms));
        const auto m = dx::measure(c.port->stream(), c.sensor, c.id());
        if (!m) return fail(c, "measure", m.error());
        nlohmann::json j{
            {"ok", true}, {"id", c.id()}, {"sample", i + 1}, {"distance_mm", m->distance / 10.0}};
        std::string text =
            fmt::format("sensor {} distance {:10.1f} mm", c.id(), m->distance / 10.0);
        if (m->fields >= 3) {
            j["signal"] = m->signal;
            j["temperature_celsius"] = m->temperature / 10.0;
            text += fmt::format("  signal {}  temperature {:.1f} degC", m->signal,
                                m->temperature / 10.0);
        }
        if (m->fields >= 4 && m->speed != dx::measurement::invalid_speed) {
            j["speed_mm_s"] = m->speed;
            text += fmt::format("  speed {} mm/s", m->speed);
        }
        emit(c.o.common, j, text);
    }
    return exit_ok;
}

// Tracking with buffering (sNf + sNq): the safe way to poll on RS-485 (S1 §5.8).
int cmd_track(context& c) {
    const auto start_cmd =
        dx::tracking_buffered(c.id(), static_cast<std::int32_t>(c.o.interval_ms));
    if (c.o.common.dry_run) {
        print_request(start_cmd);
        print_request(dx::read_buffer(c.id()));
        return print_request(dx::stop_clear(c.id()));
    }
    auto& line = c.port->stream();
    if (auto ec = dx::start_buffered_tracking(line, c.sensor, c.id(),
                                              static_cast<std::int32_t>(c.o.interval_ms)))
        return fail(c, "start tracking (sNf)", ec);
    const auto t0 = std::chrono::steady_clock::now();
    unsigned got = 0;
    int rc = exit_ok;
    while (got < c.o.count) {
        std::this_thread::sleep_for(std::chrono::milliseconds(c.o.interval_ms));
        const auto b = dx::read_buffer(line, c.sensor, c.id());
        if (!b) {
            rc = fail(c, "read buffer (sNq)", b.error());
            break;
        }
        if (b->status == dx::buffer_status::no_new_value) continue;
        ++got;
        const double t =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        const bool overwritten = b->status == dx::buffer_status::overwritten;
        emit(c.o.common,
             {{"ok", true},
              {"id", c.id()},
              {"sample", got},
              {"t_s", t},
              {"distance_mm", b->distance / 10.0},
              {"overwritten", overwritten}},
             fmt::format("[{}/{}] t={:6.2f} s  distance {:10.1f} mm{}", got, c.o.count, t,
                         b->distance / 10.0, overwritten ? "  (values were overwritten)" : ""));
    }
    if (auto ec = dx::stop(line, c.sensor, c.id()); ec && rc == exit_ok)
        rc = fail(c, "stop (sNc)", ec);
    return rc;
}

int cmd_temperature(context& c) {
    if (c.o.common.dry_run) return print_request(dx::temperature(c.id()));
    const auto t = dx::temperature(c.port->stream(), c.sensor, c.id());
    if (!t) return fail(c, "temperature", t.error());
    emit(c.o.common, {{"ok", true}, {"id", c.id()}, {"temperature_celsius", *t / 10.0}},
         fmt::format("sensor {} temperature {:.1f} degC", c.id(), *t / 10.0));
    return exit_ok;
}

int cmd_signal(context& c) {
    if (c.o.common.dry_run) return print_request(dx::signal(c.id(), false));
    const auto s = dx::signal_strength(c.port->stream(), c.sensor, c.id());
    if (!s) return fail(c, "signal", s.error());
    emit(c.o.common, {{"ok", true}, {"id", c.id()}, {"signal", *s}},
         fmt::format("sensor {} signal strength {}", c.id(), *s));
    return exit_ok;
}

int cmd_laser_on(context& c) {
    return simple(c, dx::laser_on(c.id()), "laser on");
}
int cmd_stop(context& c) {
    return simple(c, dx::stop_clear(c.id()), "stop/clear");
}

int cmd_info(context& c) {
    const std::array<std::pair<dx::command, const char*>, 3> items{
        {{dx::software_version(c.id()), "software_version"},
         {dx::serial_number(c.id()), "serial_number"},
         {dx::device_type(c.id()), "device_type"}}};
    if (c.o.common.dry_run) {
        for (const auto& [cmd, name] : items) print_request(cmd);
        return exit_ok;
    }
    nlohmann::json j{{"ok", true}, {"id", c.id()}};
    std::string text = fmt::format("sensor {}:", c.id());
    for (const auto& [cmd, name] : items) {
        const auto r = dx::transact(c.port->stream(), c.sensor, cmd);
        if (!r) return fail(c, name, r.error());
        j[name] = r->count ? r->values[0] : 0;
        text += fmt::format(" {} {:0{}}", name, r->count ? r->values[0] : 0,
                            std::string_view(name) == "device_type" ? 4 : 1);
    }
    emit(c.o.common, j, text);
    return exit_ok;
}

int cmd_errors_read(context& c) {
    if (c.o.common.dry_run) return print_request(dx::read_error_stack(c.id()));
    const auto r = dx::read_error_stack(c.port->stream(), c.sensor, c.id());
    if (!r) return fail(c, "read error stack", r.error());
    nlohmann::json list = nlohmann::json::array();
    std::string text = fmt::format("sensor {} error stack (newest first):", c.id());
    for (auto code : r->value_span()) {
        const std::string meaning =
            code == 0 ? "no error" : std::error_code(dx::make_device_error(code)).message();
        list.push_back({{"code", code}, {"meaning", meaning}});
        text += fmt::format("\n  {:03}  {}", code, meaning);
    }
    emit(c.o.common, {{"ok", true}, {"id", c.id()}, {"errors", list}}, text);
    return exit_ok;
}

int cmd_errors_clear(context& c) {
    return simple(c, dx::clear_error_stack(c.id()), "clear error stack");
}

// sNbr takes the communication settings 1, 2, 6, 7, 10, 11, not all of 1-11 (S1 §8.3.1).
bool is_comm(const dx::command_spec& s) {
    return s.name == dx::mnemonic("br");
}

// The range of a configuration command's first parameter (S1 §8.3-8.4), for a refusal.
std::string first_value_range(const dx::command_spec& s) {
    if (is_comm(s)) return "1, 2, 6, 7, 10, 11";
    return range_text(std::array<interval, 1>{{{s.lo, s.hi}}});
}

bool first_value_fits(const dx::command_spec& s, std::int32_t v) {
    if (is_comm(s)) return dx::is_comm_setting(v);
    return v >= s.lo && v <= s.hi;
}

// Refuses a first value (the selector of afi / ado, the value of a set) outside the range the
// manual gives the command; exit_ok when it is in it or the form has no such parameter.
int check_first_value(const std::string& option, const std::string& m,
                      std::span<const std::int32_t> values, std::size_t params) {
    const dx::command_spec* s = dx::find_spec(dx::mnemonic(m), true);
    if (!s || values.empty() || values.size() != params || first_value_fits(*s, values[0]))
        return exit_ok;
    return refuse(option, std::to_string(values[0]), first_value_range(*s),
                  fmt::format("{}, S1 §8.3-8.4", m));
}

// Values go on the wire as signed 32-bit numbers (S1 §8.1.3).
CLI::Validator int32_check() {
    return integer_in(std::numeric_limits<std::int32_t>::min(),
                      std::numeric_limits<std::int32_t>::max(), "32-bit signed");
}

int cmd_config_get(context& c) {
    if (const auto* s = dx::find_spec(dx::mnemonic(c.o.mnemonic), true))
        if (const int rc = check_first_value("selector", c.o.mnemonic, c.o.values, s->params_a))
            return rc;
    const auto cmd = dx::get(c.id(), c.o.mnemonic, c.o.values);
    if (!cmd) {
        fmt::print(stderr, "ferrule: '{}' is no configuration value to read (S1 §8.3-8.4)\n",
                   c.o.mnemonic);
        return exit_usage;
    }
    return simple(c, *cmd, "config " + c.o.mnemonic);
}

int cmd_config_set(context& c) {
    if (const auto* s = dx::find_spec(dx::mnemonic(c.o.mnemonic), true))
        if (const int rc = check_first_value("values", c.o.mnemonic, c.o.values, s->params_b))
            return rc;
    const auto cmd = dx::set(c.id(), c.o.mnemonic, c.o.values);
    if (!cmd) {
        fmt::print(stderr,
                   "ferrule: '{}' with {} value(s) is no configuration command (S1 §8.3-8.4)\n",
                   c.o.mnemonic, c.o.values.size());
        return exit_usage;
    }
    return simple(c, *cmd, "config " + c.o.mnemonic);
}

int cmd_config_save(context& c) {
    return simple(c, dx::save_configuration(c.id()), "save configuration");
}

} // namespace

void add_dimetix(CLI::App& app, int& exit_status) {
    auto* dx_app =
        app.add_subcommand("dimetix", "Dimetix D-Series laser distance sensor (ASCII protocol)");
    dx_app->require_subcommand(1);
    auto o = std::make_shared<dimetix_options>();

    const auto add = [o, &exit_status](CLI::App& parent, const char* name, const char* help,
                                       int (*fn)(context&)) {
        auto* sub = parent.add_subcommand(name, help);
        // IDs 0-99 on RS-422/485 (S1 §4.1); the rates of the sNbr settings (S1 §8.3.1).
        add_common_options(*sub, o->common,
                           {0, integer_in(0, dx::max_id, "sensor ID, S1 §4.1"),
                            integer_in({{9600, 9600}, {19200, 19200}, {115200, 115200}},
                                       "the sNbr settings, S1 §8.3.1")});
        sub->get_option("--address")->description("sensor ID (0-99)");
        sub->add_flag("--force-continuous", o->force,
                      "allow continuous output although several sensors may share the line");
        sub->callback(
            [o, fn, &exit_status] { exit_status = run_on_port(*o, dx::default_format, fn); });
        return sub;
    };

    auto* measure =
        add(*dx_app, "measure", "single distance measurement (sNg), --count times", cmd_measure);
    measure->add_option("--count,-n", o->count, "measurements")
        ->transform(integer_in(1, max_count))
        ->capture_default_str();
    measure->add_option("--interval", o->interval_ms, "ms between measurements")
        ->transform(integer_in(0, max_ms))
        ->capture_default_str();
    auto* track = add(*dx_app, "track",
                      "N samples with tracking and buffering (sNf + sNq), then sNc", cmd_track);
    track->add_option("count", o->count, "samples")
        ->transform(integer_in(1, max_count))
        ->required();
    track->add_option("--interval", o->interval_ms, "sampling time in ms")
        ->transform(integer_in(0, max_ms, "sNf sampling time, S1 §8.2.5"))
        ->capture_default_str();
    add(*dx_app, "temperature", "sensor temperature (sNt)", cmd_temperature);
    add(*dx_app, "signal", "signal strength, single (sNm+0)", cmd_signal);
    add(*dx_app, "laser-on", "laser on as a pointing aid until stop (sNo)", cmd_laser_on);
    add(*dx_app, "stop", "stop / clear: ends tracking, laser off (sNc)", cmd_stop);
    add(*dx_app, "info", "software version, serial number, device type (sNsv, sNsn, sNdt)",
        cmd_info);
    auto* errors = dx_app->add_subcommand("errors", "the sensor's error stack");
    errors->require_subcommand(1);
    add(*errors, "read", "read the error stack (sNre), newest first", cmd_errors_read);
    add(*errors, "clear", "clear the error stack (sNce)", cmd_errors_clear);
    auto* config = dx_app->add_subcommand("config", "configuration values (S1 §8.3-8.4)");
    config->require_subcommand(1);
    auto* get =
        add(*config, "get", "read a configuration value, e.g. mc, uo, fi, v", cmd_config_get);
    get->add_option("mnemonic", o->mnemonic, "command mnemonic")->required();
    get->add_option("selector", o->values, "selector where the command has one (afi, ado)")
        ->transform(int32_check());
    auto* set = add(*config, "set", "set a configuration value (volatile until 'config save')",
                    cmd_config_set);
    set->add_option("mnemonic", o->mnemonic, "command mnemonic")->required();
    set->add_option("values", o->values, "values; the first in the command's range (S1 §8.3-8.4)")
        ->transform(int32_check())
        ->required();
    add(*config, "save", "write the configuration to flash (sNs)", cmd_config_save);
}

} // namespace ferrule::cli
