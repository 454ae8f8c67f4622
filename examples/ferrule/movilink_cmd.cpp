// `ferrule movilink …`: a MOVILINK master on a serial port.
#include <array>
#include <chrono>
#include <limits>
#include <thread>

#include "commands.hpp"
#include "common.hpp"
#include "ferrule/movilink/access.hpp"
#include "ferrule/movilink/parameters.hpp"
#include "ferrule/movilink/process_data.hpp"

namespace ferrule::cli {
namespace {

namespace ml = ferrule::movilink;
using namespace std::chrono_literals;

using namespace ml::parameter_index;

struct movilink_options {
    common_options common;
    unsigned index = 0;
    unsigned subindex = 0;
    std::int64_t value = 0;
    bool eeprom = false;
    double rpm = 0;
    unsigned ramp_ms = 1000;
    double seconds = 10;
    bool rapid = false;
    unsigned count = 10;
    unsigned interval_ms = 200;
};

bool is_device_error(std::error_code ec) {
    return ec.category() == ml::device_category();
}

// Everything a command needs: the master, and the port unless --dry-run.
struct context {
    const movilink_options& o;
    ml::master master;
    std::unique_ptr<port_session> port;

    explicit context(const movilink_options& opts, const serial_format& f)
        : o(opts), master(config(opts, f)) {}

    static ml::master_config config(const movilink_options& o, const serial_format& f) {
        ml::master_config c;
        c.format = f;
        if (o.common.timeout_ms)
            c.response_timeout = std::chrono::milliseconds(*o.common.timeout_ms);
        if (o.common.retries) c.retries = *o.common.retries;
        c.fault_threshold = 0; // a command-line call reports each failure itself
        return c;
    }
};

// The request a parameter service would send, for --dry-run.
void print_param_request(std::uint8_t address, ml::service svc, std::uint16_t index,
                         std::uint32_t value, std::uint8_t subindex) {
    const ml::telegram t{ml::direction::request,
                         address,
                         ml::pdu_type::param_acyclic,
                         ml::param_channel::make(svc, index, value, subindex),
                         {}};
    std::array<std::uint8_t, ml::max_telegram_size> buf{};
    fmt::print("{}\n", hex(std::span(buf.data(), *ml::encode(t, buf))));
}

void print_pd_request(std::uint8_t address, std::span<const std::uint16_t> po) {
    ml::telegram t{ml::direction::request, address, ml::pd_type(po.size(), false, false), {}, {}};
    for (std::size_t i = 0; i < po.size(); ++i) t.pd[i] = po[i];
    std::array<std::uint8_t, ml::max_telegram_size> buf{};
    fmt::print("{}\n", hex(std::span(buf.data(), *ml::encode(t, buf))));
}

result<std::uint32_t> read_param(context& c, std::uint16_t index, std::uint8_t subindex = 0) {
    return ml::read_parameter(c.port->stream(), c.master,
                              static_cast<std::uint8_t>(c.o.common.address), index, subindex);
}

// Bit 5 with "ready" is a warning, without it a fault (movilink.md §3.3); the high byte
// is then that warning's or fault's number, else the unit status.
std::string status_text(ml::status_word sw) {
    const char* high = sw.fault()     ? "fault number"
                       : sw.warning() ? "warning number"
                                      : "unit status";
    const unsigned number = sw.fault()     ? sw.fault_number()
                            : sw.warning() ? sw.warning_number()
                                           : sw.unit_status();
    return fmt::format("0x{:04X} (ready {}, output stage {}, fault {}, warning {}, {} {})",
                       sw.value, sw.ready() ? 1 : 0, sw.output_stage_enabled() ? 1 : 0,
                       sw.fault() ? 1 : 0, sw.warning() ? 1 : 0, high, number);
}

int cmd_status(context& c) {
    const auto adr = static_cast<std::uint8_t>(c.o.common.address);
    const std::array<std::uint16_t, 4> indices{p010_inverter_status, p000_speed,
                                               p004_output_current, p014_heat_sink_temperature};
    if (c.o.common.dry_run) {
        for (auto ix : indices) print_param_request(adr, ml::service::read, ix, 0, 0);
        return exit_ok;
    }
    std::array<std::uint32_t, 4> v{};
    for (std::size_t i = 0; i < indices.size(); ++i) {
        const auto r = read_param(c, indices[i]);
        if (!r)
            return report_error(c.o.common, fmt::format("read index {}", indices[i]), r.error(),
                                is_device_error(r.error()));
        v[i] = *r;
    }
    const ml::status_word sw{static_cast<std::uint16_t>(v[0])};
    const double speed = static_cast<std::int32_t>(v[1]) / 1000.0;   // P000: rpm, conversion -3
    const double current = static_cast<std::int32_t>(v[2]) / 1000.0; // P004: % I_N, conversion -3
    const auto temperature = static_cast<std::int32_t>(v[3]);
    emit(c.o.common,
         {{"ok", true},
          {"address", adr},
          {"status_word", sw.value},
          {"ready", sw.ready()},
          {"output_stage_enabled", sw.output_stage_enabled()},
          {"state", ml::name(sw.state())},
          {"fault", sw.fault()},
          {"fault_number", sw.fault_number()},
          {"warning", sw.warning()},
          {"warning_number", sw.warning_number()},
          {"unit_status", sw.unit_status()},
          {"speed_rpm", speed},
          {"current_percent", current},
          {"heat_sink_celsius", temperature}},
         fmt::format(
             "drive {}: status {}\n  speed {:.1f} rpm, output current {:.1f} % I_N, heat sink "
             "{} degC",
             adr, status_text(sw), speed, current, temperature));
    return exit_ok;
}

int cmd_read(context& c) {
    const auto adr = static_cast<std::uint8_t>(c.o.common.address);
    const auto index = static_cast<std::uint16_t>(c.o.index);
    const auto sub = static_cast<std::uint8_t>(c.o.subindex);
    if (c.o.common.dry_run) {
        print_param_request(adr, ml::service::read, index, 0, sub);
        return exit_ok;
    }
    const auto r = read_param(c, index, sub);
    if (!r)
        return report_error(c.o.common, fmt::format("read index {}", index), r.error(),
                            is_device_error(r.error()));
    emit(c.o.common,
         {{"ok", true},
          {"address", adr},
          {"index", index},
          {"subindex", sub},
          {"value", static_cast<std::int32_t>(*r)},
          {"raw", *r}},
         fmt::format("index {} (0x{:04X}) subindex {} = {} (0x{:08X})", index, index, sub,
                     static_cast<std::int32_t>(*r), *r));
    return exit_ok;
}

int cmd_write(context& c) {
    const auto adr = static_cast<std::uint8_t>(c.o.common.address);
    const auto index = static_cast<std::uint16_t>(c.o.index);
    const auto sub = static_cast<std::uint8_t>(c.o.subindex);
    const auto value = static_cast<std::uint32_t>(c.o.value);
    const auto svc = c.o.eeprom ? ml::service::write : ml::service::write_volatile;
    if (c.o.common.dry_run) {
        print_param_request(adr, svc, index, value, sub);
        return exit_ok;
    }
    if (auto ec =
            ml::write_parameter(c.port->stream(), c.master, adr, index, value, c.o.eeprom, sub))
        return report_error(c.o.common, fmt::format("write index {}", index), ec,
                            is_device_error(ec));
    emit(c.o.common,
         {{"ok", true},
          {"address", adr},
          {"index", index},
          {"subindex", sub},
          {"value", static_cast<std::int32_t>(value)},
          {"service", ml::name(svc)}},
         fmt::format("index {} (0x{:04X}) subindex {} := {} ({})", index, index, sub,
                     static_cast<std::int32_t>(value), ml::name(svc)));
    return exit_ok;
}

// Cyclic 3PD with `po` until `done(pi)` or the time is up; one progress line per interval.
int cycle(context& c, std::array<std::uint16_t, 3> po, const char* what,
          const std::function<bool(const ml::process_input&)>& done,
          std::chrono::duration<double> limit, unsigned max_lines = 0) {
    const auto adr = static_cast<std::uint8_t>(c.o.common.address);
    const auto start = std::chrono::steady_clock::now();
    auto last_line = start - 1h;
    unsigned lines = 0;
    for (;;) {
        const auto pi = ml::exchange(c.port->stream(), c.master, adr, po);
        if (!pi) return report_error(c.o.common, what, pi.error(), is_device_error(pi.error()));
        const auto now = std::chrono::steady_clock::now();
        const bool finished = done(*pi) || now - start >= limit;
        if (finished || now - last_line >= std::chrono::milliseconds(c.o.interval_ms)) {
            const ml::status_word sw{pi->words[0]};
            const double t = std::chrono::duration<double>(now - start).count();
            emit(c.o.common,
                 {{"ok", true},
                  {"t_s", t},
                  {"address", adr},
                  {"status_word", sw.value},
                  {"ready", sw.ready()},
                  {"fault", sw.fault()},
                  {"warning", sw.warning()},
                  {"speed_rpm", ml::digits_to_rpm(pi->words[1])},
                  {"current_percent", ml::digits_to_current(pi->words[2])}},
                 fmt::format("t={:6.2f} s  status {}  speed {:7.1f} rpm  current {:5.1f} % I_N", t,
                             status_text(sw), ml::digits_to_rpm(pi->words[1]),
                             ml::digits_to_current(pi->words[2])));
            last_line = now;
            if (max_lines && ++lines >= max_lines) return exit_ok;
        }
        if (finished) return exit_ok;
    }
}

int cmd_run(context& c) {
    const std::array<std::uint16_t, 3> po{
        ml::control_word::enable().value, ml::rpm_to_digits(c.o.rpm),
        ml::ramp_to_digits(std::chrono::milliseconds(c.o.ramp_ms))};
    if (c.o.common.dry_run) {
        print_pd_request(static_cast<std::uint8_t>(c.o.common.address), po);
        return exit_ok;
    }
    const std::uint16_t target = po[1];
    return cycle(
        c, po, "run", [target](const ml::process_input& pi) { return pi.words[1] == target; },
        std::chrono::duration<double>(c.o.seconds));
}

int cmd_stop(context& c) {
    const auto cw = c.o.rapid ? ml::control_word::rapid_stop() : ml::control_word::stop();
    const std::array<std::uint16_t, 3> po{
        cw.value, 0, ml::ramp_to_digits(std::chrono::milliseconds(c.o.ramp_ms))};
    if (c.o.common.dry_run) {
        print_pd_request(static_cast<std::uint8_t>(c.o.common.address), po);
        return exit_ok;
    }
    return cycle(
        c, po, "stop", [](const ml::process_input& pi) { return pi.words[1] == 0; },
        std::chrono::duration<double>(c.o.seconds));
}

// Watches PI while sending the PO words the drive already has (P094-P096), so the drive
// keeps doing what it does.
int cmd_watch(context& c) {
    const auto adr = static_cast<std::uint8_t>(c.o.common.address);
    if (c.o.common.dry_run) {
        for (unsigned i = 0; i < 3; ++i)
            print_param_request(adr, ml::service::read,
                                static_cast<std::uint16_t>(p094_po1_setpoint + i), 0, 0);
        return exit_ok;
    }
    std::array<std::uint16_t, 3> po{};
    for (unsigned i = 0; i < 3; ++i) {
        const auto r = read_param(c, static_cast<std::uint16_t>(p094_po1_setpoint + i));
        if (!r)
            return report_error(c.o.common, "read PO setpoints (P094-P096)", r.error(),
                                is_device_error(r.error()));
        po[i] = static_cast<std::uint16_t>(*r);
    }
    return cycle(
        c, po, "watch", [](const ml::process_input&) { return false; }, std::chrono::hours(24),
        c.o.count);
}

// Addresses (SC01 p.20-22): 0-99 single, 100-199 group, 254 point-to-point, 255 broadcast;
// 200-253 are none on RS-485. Group and broadcast requests get no reply, so only a write may
// use them: every other command waits for the drive's answer.
CLI::Validator address_check(bool needs_reply) {
    if (needs_reply)
        return integer_in({{0, 99}, {ml::address_point_to_point, ml::address_point_to_point}},
                          "0-99 single, 254 point-to-point; group and broadcast addresses "
                          "get no reply, SC01 p.21");
    return integer_in({{0, 199}, {ml::address_point_to_point, ml::address_broadcast}},
                      "0-99 single, 100-199 group, 254 point-to-point, 255 broadcast, SC01 p.20");
}

} // namespace

void add_movilink(CLI::App& app, int& exit_status) {
    auto* ml_app =
        app.add_subcommand("movilink", "SEW MOVILINK master (MOVITRAC B, MOVIDRIVE, MOVIMOT)");
    ml_app->require_subcommand(1);
    auto o = std::make_shared<movilink_options>();

    const auto add = [&](const char* name, const char* help, int (*fn)(context&),
                         bool needs_reply = true) {
        auto* sub = ml_app->add_subcommand(name, help);
        // 9600 Bd; MOVIDRIVE B (via XT) and the WAGO gateway also 57600 (SC01 p.27, MDXB p.18).
        add_common_options(*sub, o->common,
                           {1, address_check(needs_reply),
                            integer_in({{9600, 9600}, {57600, 57600}}, "SC01 p.27, MDXB p.18")});
        sub->get_option("--address")
            ->description(needs_reply ? "drive address: 0-99, 254 point-to-point"
                                      : "drive address: 0-99, 100-199 group, 254 "
                                        "point-to-point, 255 broadcast (no reply)");
        sub->callback(
            [o, fn, &exit_status] { exit_status = run_on_port(*o, ml::default_format, fn); });
        return sub;
    };
    const auto interval = [&](CLI::App* sub, const char* help) {
        sub->add_option("--interval", o->interval_ms, help)
            ->transform(integer_in(0, max_ms))
            ->capture_default_str();
    };
    // PO3: 1 digit = 1 ms, an unsigned word (MTB scaling examples).
    const auto ramp = [&](CLI::App* sub) {
        sub->add_option("--ramp", o->ramp_ms, "ramp in ms")
            ->transform(integer_in(0, 0xFFFF, "PO3 ramp: 16 bits of 1 ms"))
            ->capture_default_str();
    };
    const auto seconds = [&](CLI::App* sub, const char* help) {
        sub->add_option("--seconds", o->seconds, help)
            ->transform(number_in(0, 86'400))
            ->capture_default_str();
    };
    const auto subindex = [&](CLI::App* sub) {
        sub->add_option("--subindex", o->subindex, "subindex (byte 1 of the parameter channel)")
            ->transform(integer_in(0, 0xFF));
    };
    const auto index = [&](CLI::App* sub, const char* help) {
        sub->add_option("index", o->index, help)
            ->transform(integer_in(0, 0xFFFF, "16 bits"))
            ->required();
    };

    add("status", "status word, speed, current and heat sink temperature (parameter reads)",
        cmd_status);
    auto* read = add("read", "read a parameter by index", cmd_read);
    index(read, "parameter index, e.g. 8318 or 0x207E (P000)");
    subindex(read);
    auto* write =
        add("write", "write a parameter by index (volatile unless --eeprom)", cmd_write, false);
    index(write, "parameter index");
    write->add_option("value", o->value, "32-bit value in the parameter's unit, signed or unsigned")
        ->transform(integer_in(std::numeric_limits<std::int32_t>::min(),
                               std::numeric_limits<std::uint32_t>::max(),
                               "32 bits, signed or unsigned"))
        ->required();
    subindex(write);
    write->add_flag("--eeprom", o->eeprom,
                    "non-volatile write (wears the EEPROM: not for cyclic use)");
    auto* run = add("run", "enable and run at a speed with cyclic 3PD; shows the ramp", cmd_run);
    // PO2 speed: a signed word of 0.2 rpm per digit, -32768 to 32767 digits (MTB scaling
    // examples).
    run->add_option("rpm", o->rpm, "speed setpoint in rpm (negative: the other direction)")
        ->transform(number_in(-6553.6, 6553.4, "PO2 speed: a signed 16-bit word of 0.2 rpm"))
        ->required();
    ramp(run);
    seconds(run, "stop watching after this long");
    interval(run, "ms between progress lines");
    auto* stop = add("stop", "stop with the ramp (or --rapid) and wait for standstill", cmd_stop);
    stop->add_flag("--rapid", o->rapid, "rapid stop (control word 0x0000)");
    ramp(stop);
    seconds(stop, "give up waiting after this long");
    interval(stop, "ms between progress lines");
    auto* watch =
        add("watch", "watch process input words without changing the drive's outputs", cmd_watch);
    watch->add_option("--count", o->count, "lines to print")
        ->transform(integer_in(1, max_count))
        ->capture_default_str();
    interval(watch, "ms between lines");
}

} // namespace ferrule::cli
