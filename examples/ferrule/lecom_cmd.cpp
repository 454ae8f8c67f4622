// `ferrule lecom …`: Lenze drives over LECOM-A/B (read, write, poll a live table).
#include <unistd.h>

#include <chrono>
#include <map>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "ferrule/host/serve.hpp"
#include "ferrule/lecom/access.hpp"
#include "ferrule/lecom/error.hpp"
#include "ferrule/lecom/poller.hpp"
#include "lecom_text.hpp"

namespace ferrule::cli {
namespace {

namespace lc = ferrule::lecom;
using namespace std::chrono_literals;

struct lecom_options {
    common_options common;
    std::string profile = std::string(lc::lenze_4900.name);
    bool extended = false;
    std::vector<std::string> codes;
    std::string code; // write's one code
    std::string value;
    std::vector<unsigned> drives;
    unsigned interval_ms = 0;
    unsigned cycles = 0;
    unsigned refresh_ms = 500;
    unsigned gap_ms = 0;
    std::vector<lc::code_address> parsed; // from `codes`
};

bool is_device_error(std::error_code ec) {
    return ec.category() == lc::device_category();
}

lc::master_config master_config(const lecom_options& o, const serial_format& f) {
    lc::master_config c;
    c.format = f;
    if (o.common.timeout_ms) c.response_timeout = std::chrono::milliseconds(*o.common.timeout_ms);
    if (o.common.retries) c.retries = *o.common.retries;
    c.turnaround = std::chrono::milliseconds(o.gap_ms);
    return c;
}

struct context {
    const lecom_options& o;
    lc::master master;
    std::vector<lc::code_address> codes;
    std::unique_ptr<port_session> port;

    context(const lecom_options& opts, const serial_format& f)
        : o(opts), master(master_config(opts, f)), codes(opts.parsed) {}
    std::uint8_t address() const { return static_cast<std::uint8_t>(o.common.address); }
};

int fail(const context& c, const std::string& what, std::error_code ec) {
    return report_error(c.o.common, what, ec, is_device_error(ec));
}

int print_request(const lc::frame& f) {
    std::array<std::uint8_t, lc::max_frame_length> buf{};
    const auto n = lc::encode(f, buf);
    if (!n) {
        fmt::print(stderr, "ferrule: cannot encode the request: {}\n",
                   std::error_code(n.error()).message());
        return exit_usage;
    }
    fmt::print("{}\n", hex({buf.data(), *n}));
    return exit_ok;
}

nlohmann::json value_json(const lc::value& v) {
    nlohmann::json j{{"value", value_text(v)}, {"format", format_name(v.format)}};
    if (v.format == lc::value_format::decimal) j["number"] = v.fixed / 10000.0;
    if (v.format == lc::value_format::hex) j["number"] = v.hex;
    if (v.format == lc::value_format::string) j["text"] = std::string(v.text());
    return j;
}

int cmd_read(context& c) {
    int rc = exit_ok;
    for (const auto& code : c.codes) {
        if (c.o.common.dry_run) {
            if (const int r = print_request(lc::read_request(c.address(), code))) return r;
            continue;
        }
        const auto v = lc::read(c.port->stream(), c.master, c.address(), code);
        const std::string what = fmt::format("read {} from drive {}", code_text(code), c.address());
        if (!v) {
            rc = fail(c, what, v.error());
            continue;
        }
        auto j = value_json(*v);
        j["ok"] = true;
        j["address"] = c.address();
        j["code"] = code.code;
        j["subcode"] = code.subcode;
        emit(c.o.common, j,
             fmt::format("drive {} {} = {}", c.address(), code_text(code), value_text(*v)));
    }
    return rc;
}

int cmd_write(context& c) {
    const auto v = lc::parse_value(c.o.value);
    if (!v) {
        fmt::print(stderr,
                   "ferrule: value: '{}' is no LECOM value: give a decimal -214748.3648 to "
                   "214748.3647 with up to 4 places (FIX32), H + 2/4/8 hex digits, S text or "
                   "O hex octets\n",
                   c.o.value);
        return exit_usage;
    }
    const auto& code = c.codes.front();
    if (c.o.common.dry_run) return print_request(lc::write_request(c.address(), code, *v));
    const std::string what =
        fmt::format("write {} = {} to drive {}", code_text(code), value_text(*v), c.address());
    if (auto ec = lc::write(c.port->stream(), c.master, c.address(), code, *v))
        return fail(c, what, ec);
    const bool group = lc::is_group_address(c.address());
    auto j = value_json(*v);
    j["ok"] = true;
    j["address"] = c.address();
    j["code"] = code.code;
    j["subcode"] = code.subcode;
    j["acknowledged"] = !group;
    const std::string target = !group ? fmt::format("drive {}", c.address())
                               : c.address() == lc::broadcast_address
                                   ? std::string("address 00 (all drives)")
                                   : fmt::format("address {:02} (drives {}1-{}9)", c.address(),
                                                 c.address() / 10, c.address() / 10);
    emit(c.o.common, j,
         fmt::format("{} {} = {}: {}", target, code_text(code), value_text(*v),
                     group ? "sent, no reply by design" : "ACK"));
    return exit_ok;
}

// --- poll ----------------------------------------------------------------------------------
using poller_t = lc::poller<64, 8, lc::max_drives_with_repeaters>;

std::string table(const poller_t& p, const std::vector<unsigned>& drives,
                  const std::vector<lc::code_address>& codes) {
    std::string s = fmt::format("{:<7}{:<9}", "drive", "state");
    for (const auto& code : codes) s += fmt::format("{:>14}", code_text(code));
    s += fmt::format("{:>8}{:>8}\n", "fails", "t/o");
    for (std::size_t d = 0; d < drives.size(); ++d) {
        const auto* ds = p.drive(static_cast<std::uint8_t>(drives[d]));
        s += fmt::format("{:<7}{:<9}", drives[d],
                         ds && ds->online                        ? "online"
                         : !ds || (!ds->seen && ds->misses == 0) ? "waiting"
                                                                 : "OFFLINE");
        for (std::size_t k = 0; k < codes.size(); ++k) {
            const auto& st = p.state(d * codes.size() + k);
            std::string cell = st.valid ? value_text(st.last) : "-";
            if (st.error && is_device_error(st.error)) cell = "(no such code)";
            s += fmt::format("{:>14}", cell);
        }
        s += fmt::format("{:>8}{:>8}\n", ds ? ds->failures : 0, ds ? ds->timeouts : 0);
    }
    const auto ms = std::chrono::duration<double, std::milli>(p.last_cycle_time()).count();
    s += fmt::format("cycle {}  last cycle {:.1f} ms  transactions {}\n", p.cycles(), ms,
                     p.completed());
    return s;
}

nlohmann::json table_json(const poller_t& p, const std::vector<unsigned>& drives,
                          const std::vector<lc::code_address>& codes) {
    nlohmann::json list = nlohmann::json::array();
    for (std::size_t d = 0; d < drives.size(); ++d) {
        const auto* ds = p.drive(static_cast<std::uint8_t>(drives[d]));
        nlohmann::json values = nlohmann::json::object();
        for (std::size_t k = 0; k < codes.size(); ++k) {
            const auto& st = p.state(d * codes.size() + k);
            if (st.valid)
                values[code_text(codes[k])] = value_json(st.last);
            else if (st.error)
                values[code_text(codes[k])] = {{"error", st.error.message()}};
        }
        list.push_back({{"address", drives[d]},
                        {"online", ds && ds->online},
                        {"failures", ds ? ds->failures : 0},
                        {"timeouts", ds ? ds->timeouts : 0},
                        {"values", values}});
    }
    return {
        {"ok", true},
        {"cycles", p.cycles()},
        {"last_cycle_ms", std::chrono::duration<double, std::milli>(p.last_cycle_time()).count()},
        {"drives", list}};
}

int cmd_poll(context& c) {
    std::vector<unsigned> drives = c.o.drives;
    if (drives.empty()) drives.push_back(c.o.common.address);
    if (c.o.common.dry_run) {
        for (unsigned d : drives)
            for (const auto& code : c.codes)
                print_request(lc::read_request(static_cast<std::uint8_t>(d), code));
        return exit_ok;
    }
    lc::poller_config pc;
    pc.master = c.master.config();
    poller_t p(pc);
    for (unsigned d : drives)
        for (const auto& code : c.codes)
            if (!p.add({static_cast<std::uint8_t>(d), code,
                        std::chrono::milliseconds(c.o.interval_ms)})) {
                fmt::print(stderr, "ferrule: too many drives x codes to poll\n");
                return exit_usage;
            }
    const bool live = !c.o.common.json && isatty(STDOUT_FILENO);
    bool printed = false;
    const auto show = [&] {
        if (c.o.common.json) {
            emit(c.o.common, table_json(p, drives, c.codes), "");
            return;
        }
        // On a terminal the table is redrawn in place; piped, each refresh is appended.
        if (live && printed) fmt::print("\x1b[{}A", drives.size() + 2);
        fmt::print("{}", table(p, drives, c.codes));
        std::fflush(stdout);
        printed = true;
    };
    const auto ec =
        host::serve_while(c.port->stream(), p, std::chrono::milliseconds(c.o.refresh_ms), [&] {
            if (c.o.cycles != 0 && p.cycles() >= c.o.cycles) return false;
            if (p.completed() > 0) show();
            return true;
        });
    if (ec) return fail(c, "poll", ec);
    show();
    for (unsigned d : drives)
        if (const auto* ds = p.drive(static_cast<std::uint8_t>(d)); !ds || !ds->online)
            return exit_transport;
    return exit_ok;
}

// 00 reaches all drives, x0 the group x1-x9; neither is answered (S1 p.8-24).
CLI::Validator any_address() {
    return integer_in(0, lc::max_address, "00 all drives, x0 a group, else one drive; S1 p.8-24");
}

// A drive's own address (C0009): 01-99 except x0.
CLI::Validator drive_address() {
    std::vector<interval> units;
    for (std::int64_t tens = 0; tens <= 90; tens += 10) units.push_back({tens + 1, tens + 9});
    return integer_in(std::move(units),
                      "a drive's own address; 00 and x0 are group addresses: a RECEIVE to them "
                      "gets no reply, S1 p.8-24");
}

// The callback's refusal of a code argument.
void refuse_code(const std::string& argument, const std::string& text, bool extended) {
    fmt::print(stderr,
               "ferrule: {}: '{}' is no code: give {}, C0039/3 with a subcode 0-255 (extended "
               "addressing), or the wire form !CCCCSS\n",
               argument, text,
               extended ? std::string("C0-C65535")
                        : fmt::format("C0-C{} (standard addressing; up to C65535 with --extended)",
                                      lc::max_standard_code));
}

} // namespace

void add_lecom(CLI::App& app, int& exit_status) {
    auto* lc_app = app.add_subcommand("lecom", "Lenze drives over LECOM-A/B (4900, 8200, 9300)");
    lc_app->require_subcommand(1);
    auto o = std::make_shared<lecom_options>();

    const auto add = [lc_app, o, &exit_status](const char* name, const char* help,
                                               int (*fn)(context&), CLI::Validator address,
                                               const char* address_help) {
        auto* sub = lc_app->add_subcommand(name, help);
        // "Baud rate 1200 … 57600" (S3, lecom.md §2).
        add_common_options(*sub, o->common,
                           {1, std::move(address), host_baud_in(1200, 57600, "S3: 1200-57600")});
        sub->get_option("--address")->description(address_help);
        sub->add_option("--profile", o->profile,
                        "serial format profile: lenze-4900 (9600 8E1, the LECOM paper's drives) "
                        "or lenze-8200 (9600 7E1, Lenze's 8200 / 2102 manuals)")
            ->check(
                CLI::IsMember({std::string(lc::lenze_4900.name), std::string(lc::lenze_8200.name)}))
            ->capture_default_str();
        sub->add_flag("--extended", o->extended,
                      "extended code addressing (!CCCCSS) even for codes up to 6229");
        sub->callback([o, fn, &exit_status] {
            const bool one = !o->code.empty();
            if (one) o->codes = {o->code};
            o->parsed.clear();
            for (const auto& text : o->codes) {
                const auto code = parse_code_arg(text, o->extended);
                if (!code) {
                    refuse_code(one ? "code" : "codes", text, o->extended);
                    exit_status = exit_usage;
                    return;
                }
                o->parsed.push_back(*code);
            }
            exit_status = run_on_port(*o, lc::find_profile(o->profile)->format, fn);
        });
        return sub;
    };
    const auto ms = [](CLI::App* sub, const char* name, unsigned& target, const char* help,
                       std::int64_t lo) {
        sub->add_option(name, target, help)
            ->transform(integer_in(lo, max_ms))
            ->capture_default_str();
    };

    const char* one_drive = "drive address (C0009): 01-99 without x0";
    auto* read =
        add("read", "read codes from one drive (RECEIVE)", cmd_read, drive_address(), one_drive);
    read->add_option("codes", o->codes, "codes, e.g. C0050 C0068 C0039/3")->required();
    auto* write = add("write", "write a code on one drive, or on a group / all (SEND)", cmd_write,
                      any_address(), "drive address; 00 all drives, x0 the group x1-x9");
    write->add_option("code", o->code, "code, e.g. C0046")->required();
    write->add_option("value", o->value, "value: 1500, -12.5, H0900, Stext, O0A1B")->required();
    auto* poll = add("poll", "poll codes of several drives; a live table with online state",
                     cmd_poll, drive_address(), one_drive);
    poll->add_option("codes", o->codes, "codes to poll on every drive")->required();
    poll->add_option("--drives,-d", o->drives, "drive addresses (default: --address)")
        ->delimiter(',')
        ->transform(drive_address());
    ms(poll, "--interval", o->interval_ms,
       "ms between polls of one item (0: as fast as the line allows)", 0);
    poll->add_option("--cycles,-n", o->cycles, "stop after this many poll cycles (0: never)")
        ->transform(integer_in(0, max_count))
        ->capture_default_str();
    ms(poll, "--refresh", o->refresh_ms, "ms between table updates", 1);
    ms(poll, "--gap", o->gap_ms, "ms of silence between transactions", 0);
}

} // namespace ferrule::cli
