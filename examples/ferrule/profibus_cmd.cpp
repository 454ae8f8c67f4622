// `ferrule profibus …`: a class-1 DP master (DP-V0) for one slave on a serial port: diag,
// set-prm, cfg, get-cfg, exchange, clear (protocols/modbus_profibus.md §B).
//
// Set_Prm and Chk_Cfg are answered with a short acknowledgement whatever the slave thinks of
// them (§B.5); its verdict is in the diagnosis. So set-prm and cfg read Slave_Diag after the
// request and report Prm_Fault or Cfg_Fault as the slave's answer.
#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/error.hpp"
#include "ferrule/profibus/master.hpp"
#include "ferrule/profibus/services.hpp"
#include "profibus_text.hpp"

namespace ferrule::cli {
namespace {

namespace pb = ferrule::profibus;
using namespace ferrule::cli::profibus_text;

struct profibus_options {
    common_options common;
    unsigned master_address = 2;
    std::optional<unsigned> ident;
    std::optional<unsigned> watchdog_ms;
    bool lock = true; // Lock_Req; --no-lock sends Set_Prm without it
    std::string user_prm;
    std::string cfg;
    std::string out;
    unsigned count = 1;
    unsigned interval_ms = 100;
    bool no_init = false;
};

pb::master_config master_config(const profibus_options& o, const serial_format& f) {
    pb::master_config c;
    c.format = f;
    c.address = static_cast<std::uint8_t>(o.master_address);
    if (o.common.timeout_ms) c.slot_time = std::chrono::milliseconds(*o.common.timeout_ms);
    if (o.common.retries) c.retries = *o.common.retries;
    return c;
}

struct context {
    const profibus_options& o;
    pb::master master;
    std::unique_ptr<port_session> port;
    serial_format format;

    context(const profibus_options& opts, const serial_format& f)
        : o(opts), master(master_config(opts, f)), format(f) {}
    std::uint8_t slave() const { return static_cast<std::uint8_t>(o.common.address); }
    host::serial_stream& line() { return port->stream(); }
};

int usage(const std::string& why) {
    fmt::print(stderr, "ferrule: {}\n", why);
    return exit_usage;
}

// What went wrong, in the slave's words when it answered: "slave 8: SAP not activated (RS)";
// for the line, with the number of requests sent.
std::string error_text(const context& c, std::error_code ec) {
    if (ec.category() == pb::device_category()) {
        std::string m = ec.message();
        if (m.starts_with("slave: ")) m = m.substr(7);
        return fmt::format("slave {}: {}", c.slave(), m);
    }
    const unsigned n = c.master.attempts();
    return fmt::format("slave {}: {}{}", c.slave(), ec.message(),
                       n > 1 ? fmt::format(" after {} requests", n) : std::string());
}

int fail(const context& c, const std::string& what, std::error_code ec) {
    const bool device = ec.category() == pb::device_category();
    if (c.o.common.json) {
        nlohmann::json j{{"ok", false},
                         {"operation", what},
                         {"slave", c.slave()},
                         {"error", error_text(c, ec)},
                         {"category", ec.category().name()},
                         {"code", ec.value()}};
        fmt::print("{}\n", j.dump());
    } else {
        fmt::print(stderr, "ferrule: {}: {}\n", what, error_text(c, ec));
    }
    return device ? exit_device_error : exit_transport;
}

// --dry-run: the request the master would send first, as hex.
int print_request(const context& c, std::error_code started) {
    if (started) return usage(fmt::format("cannot encode the request: {}", started.message()));
    fmt::print("{}\n", hex(c.master.request_bytes()));
    return exit_ok;
}

bool open_port(context& c) {
    c.port = port_session::open(c.o.common, c.format);
    return c.port != nullptr;
}

nlohmann::json diag_json(const pb::slave_diag& d) {
    return {{"station_status_1", bit_names(d.status1, station_status_1)},
            {"station_status_2", bit_names(d.status2, station_status_2)},
            {"station_status_3", bit_names(d.status3, station_status_3)},
            {"master_address", d.master},
            {"ident_number", d.ident},
            {"extended", hex(d.ext)},
            {"ready", d.ready()}};
}

std::string diag_text(const pb::slave_diag& d) {
    return fmt::format("Station_Status_1  0x{:02X}  {}\n"
                       "Station_Status_2  0x{:02X}  {}\n"
                       "Station_Status_3  0x{:02X}  {}\n"
                       "Diag.Master_Add   {}{}\n"
                       "Ident_Number      0x{:04X}\n"
                       "extended          {}\n"
                       "ready             {}",
                       d.status1, join(bit_names(d.status1, station_status_1)), d.status2,
                       join(bit_names(d.status2, station_status_2)), d.status3,
                       join(bit_names(d.status3, station_status_3)), d.master,
                       d.master == pb::diag::no_master ? " (none)" : "", d.ident,
                       d.ext.empty() ? "-" : hex(d.ext), d.ready() ? "yes" : "no");
}

int cmd_diag(context& c) {
    if (c.o.common.dry_run) return print_request(c, c.master.start_slave_diag(c.slave()));
    if (!open_port(c)) return exit_transport;
    pb::slave_diag d;
    if (auto ec = pb::read_slave_diag(c.line(), c.master, c.slave(), d))
        return fail(c, "Slave_Diag", ec);
    // Master_Lock is this master's conclusion from Master_Add, never the slave's (§B.5).
    if (pb::locked_to_other(d, c.master.config().address)) d.status1 |= pb::diag::master_lock;
    nlohmann::json j = diag_json(d);
    j["ok"] = true;
    j["slave"] = c.slave();
    emit(c.o.common, j, diag_text(d));
    return exit_ok;
}

// Set_Prm's data from the options; the ident is given by the caller.
pb::prm_data prm_from_options(const profibus_options& o, std::uint16_t ident,
                              std::span<const std::uint8_t> user) {
    pb::prm_data p;
    p.ident = ident;
    p.min_tsdr = static_cast<std::uint8_t>(pb::min_tsdr_bits);
    p.user = user;
    p.station_status = o.lock ? pb::prm::lock_req : std::uint8_t{0};
    if (o.watchdog_ms) {
        p.station_status |= pb::prm::wd_on;
        p.set_watchdog_ms(*o.watchdog_ms);
    }
    return p;
}

std::string prm_text(const pb::prm_data& p) {
    return fmt::format(
        "ident 0x{:04X}, watchdog {}, {}, min_TSDR {} tbit{}", p.ident,
        p.watchdog_on()
            ? fmt::format(
                  "{} ms ({} x {} x 10 ms)",
                  std::chrono::duration_cast<std::chrono::milliseconds>(p.watchdog()).count(),
                  p.wd_fact1, p.wd_fact2)
            : std::string("off"),
        (p.station_status & pb::prm::lock_req)
            ? "locked"
            : "not locked (no Lock_Req: the slave takes only min_TSDR and User_Prm_Data)",
        p.min_tsdr, p.user.empty() ? std::string() : ", User_Prm_Data " + hex(p.user));
}

// After Set_Prm or Chk_Cfg: the slave's verdict, from its diagnosis. A slave locked to
// another master acknowledges both and takes neither.
std::error_code verdict(context& c, std::uint8_t fault, pb::device_errc error) {
    pb::slave_diag d;
    if (auto ec = pb::read_slave_diag(c.line(), c.master, c.slave(), d)) return ec;
    if (pb::locked_to_other(d, c.master.config().address)) return pb::device_errc::master_lock;
    if (d.status1 & fault) return error;
    return {};
}

int cmd_set_prm(context& c) {
    std::vector<std::uint8_t> user;
    if (!parse_hex(c.o.user_prm, user)) return usage("--user-prm: hex bytes, e.g. 00 0A");
    const pb::prm_data p = prm_from_options(c.o, static_cast<std::uint16_t>(*c.o.ident), user);
    if (c.o.common.dry_run) return print_request(c, c.master.start_set_prm(c.slave(), p));
    if (!open_port(c)) return exit_transport;
    if (auto ec = pb::set_prm(c.line(), c.master, c.slave(), p)) return fail(c, "Set_Prm", ec);
    if (auto ec = verdict(c, pb::diag::prm_fault, pb::device_errc::prm_fault))
        return fail(c, "Set_Prm", ec);
    nlohmann::json j{
        {"ok", true},
        {"slave", c.slave()},
        {"ident_number", p.ident},
        {"watchdog_ms",
         p.watchdog_on()
             ? std::chrono::duration_cast<std::chrono::milliseconds>(p.watchdog()).count()
             : 0},
        {"lock", c.o.lock},
        {"user_prm_data", hex(p.user)}};
    emit(c.o.common, j, fmt::format("Set_Prm to slave {}: {}: accepted", c.slave(), prm_text(p)));
    return exit_ok;
}

std::string cfg_text(std::span<const std::uint8_t> cfg) {
    const auto s = pb::cfg_io_sizes(cfg);
    if (!s) return fmt::format("{} (not a valid configuration)", hex(cfg));
    return fmt::format("{}: {} bytes out, {} in", cfg.empty() ? "-" : hex(cfg), s->outputs,
                       s->inputs);
}

nlohmann::json cfg_json(std::span<const std::uint8_t> cfg) {
    nlohmann::json j{{"cfg", hex(cfg)}};
    if (const auto s = pb::cfg_io_sizes(cfg)) {
        j["outputs"] = s->outputs;
        j["inputs"] = s->inputs;
    }
    return j;
}

int cmd_chk_cfg(context& c) {
    std::vector<std::uint8_t> cfg;
    if (!parse_hex(c.o.cfg, cfg) || cfg.empty() || !pb::cfg_io_sizes(cfg))
        return usage("cfg: configuration identifier bytes in hex, e.g. 24 14");
    if (c.o.common.dry_run) return print_request(c, c.master.start_chk_cfg(c.slave(), cfg));
    if (!open_port(c)) return exit_transport;
    if (auto ec = pb::chk_cfg(c.line(), c.master, c.slave(), cfg)) return fail(c, "Chk_Cfg", ec);
    if (auto ec = verdict(c, pb::diag::cfg_fault, pb::device_errc::cfg_fault))
        return fail(c, "Chk_Cfg", ec);
    nlohmann::json j = cfg_json(cfg);
    j["ok"] = true;
    j["slave"] = c.slave();
    emit(c.o.common, j, fmt::format("Chk_Cfg to slave {}: {}: accepted", c.slave(), cfg_text(cfg)));
    return exit_ok;
}

int cmd_get_cfg(context& c) {
    if (c.o.common.dry_run) return print_request(c, c.master.start_get_cfg(c.slave()));
    if (!open_port(c)) return exit_transport;
    if (auto ec = pb::get_cfg(c.line(), c.master, c.slave())) return fail(c, "Get_Cfg", ec);
    const auto cfg = c.master.reply();
    nlohmann::json j = cfg_json(cfg);
    j["ok"] = true;
    j["slave"] = c.slave();
    emit(c.o.common, j, fmt::format("slave {} configuration {}", c.slave(), cfg_text(cfg)));
    return exit_ok;
}

// The start-up of §B.6 with the given ident and configuration, or those the slave reports
// (Slave_Diag, Get_Cfg) where none are given. The configuration ends up in `cfg`.
int bring_up(context& c, std::vector<std::uint8_t>& cfg) {
    std::uint16_t ident = 0;
    if (c.o.ident) {
        ident = static_cast<std::uint16_t>(*c.o.ident);
    } else {
        pb::slave_diag d;
        if (auto ec = pb::read_slave_diag(c.line(), c.master, c.slave(), d))
            return fail(c, "Slave_Diag", ec);
        ident = d.ident;
    }
    if (cfg.empty()) {
        if (auto ec = pb::get_cfg(c.line(), c.master, c.slave())) return fail(c, "Get_Cfg", ec);
        const auto r = c.master.reply();
        cfg.assign(r.begin(), r.end());
    }
    std::vector<std::uint8_t> user;
    if (!parse_hex(c.o.user_prm, user)) return usage("--user-prm: hex bytes, e.g. 00 0A");
    const pb::prm_data p = prm_from_options(c.o, ident, user);
    if (auto ec = pb::bring_up(c.line(), c.master, c.slave(), p, cfg))
        return fail(c, "start-up (FDL_Status, Slave_Diag, Set_Prm, Chk_Cfg)", ec);
    nlohmann::json j = cfg_json(cfg);
    j["ok"] = true;
    j["slave"] = c.slave();
    j["ident_number"] = ident;
    j["ready"] = true;
    emit(c.o.common, j,
         fmt::format("slave {} ready for Data_Exchange: {}; cfg {}", c.slave(), prm_text(p),
                     cfg_text(cfg)));
    return exit_ok;
}

int cmd_exchange(context& c) {
    std::vector<std::uint8_t> out;
    std::vector<std::uint8_t> cfg;
    if (!parse_hex(c.o.out, out))
        return usage("--out: the output bytes in hex, e.g. 06 C8 00 00 25");
    if (!c.o.cfg.empty() && (!parse_hex(c.o.cfg, cfg) || !pb::cfg_io_sizes(cfg)))
        return usage("--cfg: configuration identifier bytes in hex, e.g. 24 14");
    if (c.o.common.dry_run) return print_request(c, c.master.start_data_exchange(c.slave(), out));
    if (!open_port(c)) return exit_transport;
    if (!c.o.no_init) {
        if (const int rc = bring_up(c, cfg); rc != exit_ok) return rc;
        if (const auto s = pb::cfg_io_sizes(cfg); s && s->outputs != out.size())
            return usage(fmt::format("--out has {} bytes; the configuration {} has {} outputs",
                                     out.size(), hex(cfg), s->outputs));
    }
    for (unsigned i = 0; i < c.o.count; ++i) {
        if (i) std::this_thread::sleep_for(std::chrono::milliseconds(c.o.interval_ms));
        auto ec = c.master.start_data_exchange(c.slave(), out);
        if (!ec) ec = run(c.line(), c.master);
        if (ec) return fail(c, "Data_Exchange", ec);
        const auto in = c.master.reply();
        const bool dh = c.master.data_high();
        nlohmann::json j{{"ok", true},          {"slave", c.slave()}, {"cycle", i + 1},
                         {"outputs", hex(out)}, {"inputs", hex(in)},  {"data_high", dh}};
        std::string text = fmt::format("{:>3}: outputs {} -> inputs {} ({})", i + 1, hex(out),
                                       in.empty() ? "-" : hex(in), dh ? "DH: new diagnosis" : "DL");
        if (dh) {
            // The master fetches the new diagnosis (§B.3).
            pb::slave_diag d;
            if (auto dec = pb::read_slave_diag(c.line(), c.master, c.slave(), d))
                return fail(c, "Slave_Diag", dec);
            j["diagnosis"] = diag_json(d);
            text += fmt::format("\n     Slave_Diag: {}; {}; extended {}",
                                join(bit_names(d.status1, station_status_1)),
                                join(bit_names(d.status2, station_status_2)),
                                d.ext.empty() ? "-" : hex(d.ext));
        }
        emit(c.o.common, j, text);
    }
    return exit_ok;
}

int cmd_clear(context& c) {
    const pb::global_control gc{pb::control::clear_data, 0};
    if (c.o.common.dry_run) return print_request(c, c.master.start_global_control(gc));
    if (!open_port(c)) return exit_transport;
    if (auto ec = pb::send_global_control(c.line(), c.master, gc))
        return fail(c, "Global_Control", ec);
    emit(c.o.common, {{"ok", true}, {"command", "Clear_Data"}, {"group", 0}, {"da", 127}},
         "Global_Control Clear_Data to every slave (DA 127, group 0): sent, no reply by design");
    return exit_ok;
}

int run_profibus(const profibus_options& o, int (*fn)(context&)) {
    const auto f = resolve_format(o.common, pb::format(19'200));
    if (!f) return usage(fmt::format("--format/--baud: {}", std::error_code(f.error()).message()));
    if (o.master_address == o.common.address)
        return usage(fmt::format("--master-address and --address: {} for both; the master and "
                                 "its slave need two of the station addresses 0-126",
                                 o.master_address));
    context c(o, *f);
    return fn(c);
}

// Ident_Numbers are 0x0001-0xFFFE, assigned by PI (§B.8).
CLI::Validator ident_check() {
    return integer_in(0x0001, 0xFFFE, "Ident_Number, §B.8");
}

} // namespace

void add_profibus(CLI::App& app, int& exit_status) {
    auto* pb_app = app.add_subcommand(
        "profibus",
        "PROFIBUS-DP master (DP-V0) for one slave: diag, set-prm, cfg, get-cfg, exchange, clear");
    pb_app->require_subcommand(1);
    auto o = std::make_shared<profibus_options>();

    const auto add = [pb_app, o, &exit_status](const char* name, const char* help,
                                               int (*fn)(context&)) {
        auto* sub = pb_app->add_subcommand(name, help);
        // Station addresses 0-126, 127 is the broadcast (§B.3); of the DP rates (9.6 kbit/s to
        // 12 Mbit/s, §B.1) a serial port sets 9600 and 19200.
        add_common_options(
            *sub, o->common,
            {8, integer_in(0, pb::max_station_address, "DP station addresses"),
             integer_in({{9600, 9600}, {19200, 19200}}, "the DP rates a serial port sets")});
        sub->get_option("--address")->description("the slave's station address (0-126)");
        sub->get_option("--timeout")
            ->description("slot time in ms: the wait for a reply's first byte (default: 100 tbit "
                          "up to 187.5 kbit/s)");
        sub->add_option("--master-address", o->master_address,
                        "this master's station address (0-126)")
            ->transform(integer_in(0, pb::max_station_address, "DP station addresses"))
            ->capture_default_str();
        sub->callback([o, fn, &exit_status] { exit_status = run_profibus(*o, fn); });
        return sub;
    };
    const auto prm = [o](CLI::App* sub) {
        sub->add_option("--watchdog-ms", o->watchdog_ms,
                        "switch the slave's watchdog on with this time (WD_Fact_1 x WD_Fact_2 x "
                        "10 ms)")
            ->transform(integer_in(10, 255 * 255 * 10, "WD_Fact_1 x WD_Fact_2 x 10 ms"));
        sub->add_flag("--lock,!--no-lock", o->lock,
                      "Lock_Req (the default): bind the slave to this master and have it take all "
                      "parameters; --no-lock: only min_TSDR and User_Prm_Data");
        sub->add_option("--user-prm", o->user_prm, "User_Prm_Data in hex");
    };

    add("diag", "read Slave_Diag: station status, master address, ident, extended diagnosis",
        cmd_diag);
    auto* set_prm = add("set-prm", "Set_Prm, then Slave_Diag for the slave's verdict", cmd_set_prm);
    set_prm->add_option("--ident", o->ident, "Ident_Number the slave must have (0x0001-0xFFFE)")
        ->transform(ident_check())
        ->required();
    prm(set_prm);
    auto* cfg = add("cfg", "Chk_Cfg with these identifier bytes, then Slave_Diag for the verdict",
                    cmd_chk_cfg);
    cfg->add_option("identifiers", o->cfg, "identifier bytes in hex, e.g. \"24 14\"")->required();
    add("get-cfg", "Get_Cfg: the slave's configuration identifiers", cmd_get_cfg);
    auto* ex = add("exchange",
                   "start the slave up (unless --no-init), then Data_Exchange: outputs out, "
                   "inputs and DL/DH back",
                   cmd_exchange);
    ex->add_option("--out", o->out, "the output bytes in hex, e.g. \"06 C8 00 00 25\"")->required();
    ex->add_option("--count,-c", o->count,
                   "Data_Exchange cycles (a gateway's reply comes with a later one)")
        ->transform(integer_in(1, max_count))
        ->capture_default_str();
    ex->add_option("--interval-ms", o->interval_ms, "pause between cycles")
        ->transform(integer_in(0, max_ms))
        ->capture_default_str();
    ex->add_flag("--no-init", o->no_init, "no start-up: the slave is in Data_Exchange already");
    ex->add_option("--ident", o->ident,
                   "start-up: Ident_Number for Set_Prm (default: the one the slave reports)")
        ->transform(ident_check());
    ex->add_option("--cfg", o->cfg,
                   "start-up: identifier bytes for Chk_Cfg (default: the slave's, from Get_Cfg)");
    prm(ex);
    add("clear", "Global_Control Clear_Data to every slave: outputs to their safe state",
        cmd_clear);
}

} // namespace ferrule::cli
