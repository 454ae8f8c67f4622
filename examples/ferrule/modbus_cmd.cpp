// `ferrule modbus …`: Modbus RTU on a serial port or Modbus TCP (read, write, diag, id).
#include <algorithm>
#include <array>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/modbus/client.hpp"
#include "ferrule/modbus/error.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/tcp.hpp"
#include "modbus_text.hpp"
#include "tcp_link.hpp"

namespace ferrule::cli {
namespace {

namespace mb = ferrule::modbus;

struct modbus_options {
    common_options common;
    std::string host;
    std::string type = "holding";
    unsigned start = 0;
    unsigned count = 1;
    std::string as = "u16";
    std::string word_order = "abcd";
    std::vector<std::string> values;
    std::optional<double> gap_ms;
    std::string diag = "echo";
    unsigned echo_data = 0x1234;
    std::string id_code = "basic";
};

mb::client_config client_config(const modbus_options& o, const serial_format& f) {
    mb::client_config c;
    c.format = f;
    c.rtu = o.host.empty();
    c.inter_frame_gap = mb::t35(f);
    if (o.gap_ms)
        c.inter_frame_gap = std::chrono::duration_cast<duration>(
            std::chrono::duration<double, std::milli>(*o.gap_ms));
    if (o.common.timeout_ms) c.response_timeout = std::chrono::milliseconds(*o.common.timeout_ms);
    if (o.common.retries) c.retries = *o.common.retries;
    return c;
}

struct context {
    const modbus_options& o;
    mb::client client;
    value_type type = value_type::u16;
    mb::word_order order = mb::word_order::abcd;
    serial_format format;
    std::unique_ptr<port_session> port;
    std::unique_ptr<tcp_link> tcp;

    context(const modbus_options& opts, const serial_format& f)
        : o(opts), client(client_config(opts, f)), format(f) {}
    bool rtu() const { return o.host.empty(); }
    std::uint8_t unit() const { return static_cast<std::uint8_t>(o.common.address); }
    bool broadcast() const { return rtu() && unit() == mb::broadcast_address; }
};

// --dry-run: the request ADU (TCP: transaction id 1) as hex.
int print_request(const context& c, const mb::request& r) {
    std::array<std::uint8_t, mb::max_pdu> pdu{};
    std::array<std::uint8_t, mb::max_tcp_adu> adu{};
    const auto n = mb::encode_request(r, pdu);
    if (!n) {
        fmt::print(stderr, "ferrule: cannot encode the request: {}\n",
                   std::error_code(n.error()).message());
        return exit_usage;
    }
    const std::span<const std::uint8_t> p(pdu.data(), *n);
    const auto size =
        c.rtu() ? mb::encode_rtu(c.unit(), p, adu) : mb::encode_tcp(1, c.unit(), p, adu);
    fmt::print("{}\n", hex({adu.data(), *size}));
    return exit_ok;
}

// Opens the serial port or connects to the TCP server, once the request is known to be
// right; false (and why printed) when that fails.
bool open_link(context& c) {
    if (c.rtu())
        c.port = port_session::open(c.o.common, c.format);
    else
        c.tcp = tcp_link::open(c.o.host,
                               std::chrono::milliseconds(c.o.common.timeout_ms.value_or(3000)),
                               c.o.common.trace);
    return c.port || c.tcp;
}

std::error_code transact(context& c, const mb::request& r) {
    if (auto ec = c.client.start(c.unit(), r)) return ec;
    return c.tcp ? run(c.tcp->stream(), c.client) : run(c.port->stream(), c.client);
}

int fail(const context& c, const std::string& what, std::error_code ec) {
    const bool exception = ec.category() == mb::device_category();
    if (c.o.common.json) {
        nlohmann::json j{{"ok", false},
                         {"operation", what},
                         {"error", error_text(ec)},
                         {"category", ec.category().name()},
                         {"code", ec.value()}};
        if (exception) j["exception"] = ec.value();
        fmt::print("{}\n", j.dump());
    } else {
        fmt::print(stderr, "ferrule: {}: {}\n", what, error_text(ec));
    }
    return exception ? exit_device_error : exit_transport;
}

int usage(const std::string& why) {
    fmt::print(stderr, "ferrule: {}\n", why);
    return exit_usage;
}

mb::function read_function(const std::string& type) {
    if (type == "coil") return mb::function::read_coils;
    if (type == "discrete") return mb::function::read_discrete_inputs;
    if (type == "input") return mb::function::read_input_registers;
    return mb::function::read_holding_registers;
}

std::string unit_text(const context& c) {
    return c.broadcast() ? std::string("unit 0 (broadcast)") : fmt::format("unit {}", c.unit());
}

// RTU unit 0 is the broadcast: every server executes a write and none answers (Serial Line
// V1.02 §2.2), so nothing else can be broadcast.
int refuse_broadcast(const char* what) {
    return refuse("--unit", "0", "1-247",
                  fmt::format("0 is the RTU broadcast address, and {} cannot be broadcast", what));
}

// The most values one read of `per` registers (or bits) each can take from `start` (AP §6.1-6.4:
// 2000 bits, 125 registers); 0 when not even one fits below 65536.
unsigned max_read_count(unsigned start, bool bits, unsigned per) {
    const unsigned limit = bits ? mb::max_read_bits : mb::max_read_registers;
    return std::min(limit, 0x10000 - start) / per;
}

int cmd_read(context& c) {
    if (c.broadcast()) return refuse_broadcast("a read");
    const mb::function fc = read_function(c.o.type);
    const bool bits = fc == mb::function::read_coils || fc == mb::function::read_discrete_inputs;
    const unsigned per = bits ? 1 : registers_per_value(c.type);
    const unsigned most = max_read_count(c.o.start, bits, per);
    if (most == 0)
        return refuse("--start", std::to_string(c.o.start), "0-65534",
                      fmt::format("a {} value takes 2 registers", c.o.as));
    if (c.o.count > most) {
        const bool by_address =
            0x10000 - c.o.start < (bits ? mb::max_read_bits : mb::max_read_registers);
        return refuse("--count", std::to_string(c.o.count), fmt::format("1-{}", most),
                      by_address
                          ? fmt::format("from --start {} the addresses end at 65535", c.o.start)
                      : bits ? std::string("one request reads 2000 bits, AP §6.1-6.2")
                             : fmt::format("one request reads 125 registers, {} per {} "
                                           "value, AP §6.3-6.4",
                                           per, c.o.as));
    }
    const unsigned quantity = c.o.count * per;
    mb::request r;
    r.function = fc;
    r.address = static_cast<std::uint16_t>(c.o.start);
    r.quantity = static_cast<std::uint16_t>(quantity);
    if (c.o.common.dry_run) return print_request(c, r);
    if (!open_link(c)) return exit_transport;
    const std::string what = fmt::format("{} {} (0x{:04X}), quantity {}, of {}",
                                         function_name(static_cast<std::uint8_t>(fc)), c.o.start,
                                         c.o.start, quantity, unit_text(c));
    if (auto ec = transact(c, r)) return fail(c, what, ec);
    const auto data = c.client.reply().data;
    std::string text;
    nlohmann::json values = nlohmann::json::array();
    nlohmann::json registers = nlohmann::json::array();
    for (unsigned i = 0; i < c.o.count; ++i) {
        const unsigned address = c.o.start + i * per;
        if (!text.empty()) text += '\n';
        if (bits) {
            const int bit = (data[i / 8] >> (i % 8)) & 1;
            values.push_back(bit);
            text += fmt::format("[{}]: {}", address, bit);
            continue;
        }
        std::array<std::uint16_t, 2> regs{};
        for (unsigned k = 0; k < per; ++k) {
            regs[k] = mb::register_at(data, i * per + k);
            registers.push_back(regs[k]);
        }
        const double v = value_number(c.type, regs, c.order);
        if (c.type == value_type::f32)
            values.push_back(v);
        else
            values.push_back(static_cast<std::int64_t>(v));
        text += fmt::format("[{}]: {}", address, value_text(c.type, regs, c.order));
    }
    nlohmann::json j{{"ok", true},       {"unit", c.unit()},   {"function", static_cast<int>(fc)},
                     {"type", c.o.type}, {"start", c.o.start}, {"count", c.o.count},
                     {"values", values}};
    if (!bits) {
        j["as"] = c.o.as;
        j["registers"] = registers;
    }
    emit(c.o.common, j, text);
    return exit_ok;
}

int cmd_write(context& c) {
    if (c.o.type != "coil" && c.o.type != "holding")
        return usage("--type: only coils and holding registers can be written");
    mb::request r;
    r.address = static_cast<std::uint16_t>(c.o.start);
    std::vector<std::uint16_t> regs;
    std::array<std::uint8_t, mb::packed_size(mb::max_write_bits)> packed{};
    std::array<std::uint8_t, 2 * mb::max_write_registers> bytes{};
    if (c.o.type == "coil") {
        for (std::size_t i = 0; i < c.o.values.size(); ++i) {
            const auto& v = c.o.values[i];
            if (v != "0" && v != "1")
                return usage(fmt::format("values: '{}' is no coil value: give 0 or 1", v));
            if (v == "1") packed[i / 8] = static_cast<std::uint8_t>(packed[i / 8] | 1u << (i % 8));
            regs.push_back(v == "1");
        }
        if (regs.size() > mb::max_write_bits) return usage("one request writes 1-1968 coils");
        if (regs.size() == 1) {
            r.function = mb::function::write_single_coil;
            r.value = regs[0] ? mb::coil_on : mb::coil_off;
        } else {
            r.function = mb::function::write_multiple_coils;
            r.quantity = static_cast<std::uint16_t>(regs.size());
            r.data = std::span<const std::uint8_t>(packed).first(mb::packed_size(regs.size()));
        }
    } else {
        for (const auto& v : c.o.values) {
            const auto words = parse_value(c.type, v, c.order);
            if (!words)
                return usage(fmt::format("values: '{}' is no {} value: give {}", v, c.o.as,
                                         value_range(c.type)));
            regs.insert(regs.end(), words->begin(), words->end());
        }
        if (regs.size() > mb::max_write_registers)
            return usage("one request writes 1-123 registers");
        if (regs.size() == 1) {
            r.function = mb::function::write_single_register;
            r.value = regs[0];
        } else {
            r.function = mb::function::write_multiple_registers;
            r.quantity = static_cast<std::uint16_t>(regs.size());
            for (std::size_t i = 0; i < regs.size(); ++i) mb::put_register(bytes, i, regs[i]);
            r.data = std::span<const std::uint8_t>(bytes).first(2 * regs.size());
        }
    }
    if (c.o.start + regs.size() > 0x10000)
        return refuse("--start", std::to_string(c.o.start),
                      fmt::format("0-{}", 0x10000 - regs.size()),
                      fmt::format("{} {} from it end beyond 65535", regs.size(),
                                  c.o.type == "coil" ? "coils" : "registers"));
    if (c.o.common.dry_run) return print_request(c, r);
    if (!open_link(c)) return exit_transport;
    std::string values;
    for (const auto& v : c.o.values) values += (values.empty() ? "" : " ") + v;
    const auto fc = static_cast<std::uint8_t>(r.function);
    const std::string what = fmt::format("{} {} (0x{:04X}) = {} on {}", function_name(fc),
                                         c.o.start, c.o.start, values, unit_text(c));
    const auto ec = transact(c, r);
    const bool no_reply = ec == errc::no_response_expected;
    if (ec && !no_reply) return fail(c, what, ec);
    nlohmann::json j{{"ok", true},        {"unit", c.unit()},         {"function", fc},
                     {"type", c.o.type},  {"start", c.o.start},       {"values", c.o.values},
                     {"registers", regs}, {"acknowledged", !no_reply}};
    emit(c.o.common, j, fmt::format("{}: {}", what, no_reply ? "sent, no reply by design" : "ok"));
    return exit_ok;
}

struct named_counter {
    const char* name;
    mb::diag_sub sub;
};
constexpr std::array<named_counter, 8> counters{{
    {"bus message count", mb::diag_sub::bus_message_count},
    {"bus communication error count", mb::diag_sub::bus_comm_error_count},
    {"bus exception error count", mb::diag_sub::bus_exception_count},
    {"server message count", mb::diag_sub::server_message_count},
    {"server no response count", mb::diag_sub::server_no_response_count},
    {"server NAK count", mb::diag_sub::server_nak_count},
    {"server busy count", mb::diag_sub::server_busy_count},
    {"bus character overrun count", mb::diag_sub::bus_char_overrun_count},
}};

mb::request diag_request(mb::diag_sub sub, std::array<std::uint8_t, 2>& data, std::uint16_t value) {
    store_be16(data.data(), value);
    mb::request r;
    r.function = mb::function::diagnostics;
    r.value = static_cast<std::uint16_t>(sub);
    r.data = data;
    return r;
}

int cmd_diag(context& c) {
    if (c.broadcast()) return refuse_broadcast("diagnostics");
    std::array<std::uint8_t, 2> data{};
    if (c.o.diag == "echo" || c.o.diag == "clear") {
        const bool echo = c.o.diag == "echo";
        const auto r =
            diag_request(echo ? mb::diag_sub::return_query_data : mb::diag_sub::clear_counters,
                         data, echo ? static_cast<std::uint16_t>(c.o.echo_data) : std::uint16_t{0});
        if (c.o.common.dry_run) return print_request(c, r);
        if (!open_link(c)) return exit_transport;
        const std::string what = fmt::format(
            "diagnostics {} on {}", echo ? "return query data" : "clear counters", unit_text(c));
        if (auto ec = transact(c, r)) return fail(c, what, ec);
        const std::uint16_t back = load_be16(c.client.reply().data.data());
        nlohmann::json j{
            {"ok", true}, {"unit", c.unit()}, {"sub_function", r.value}, {"data", back}};
        emit(c.o.common, j,
             echo ? fmt::format("{}: echoed 0x{:04X}", what, back) : fmt::format("{}: ok", what));
        return exit_ok;
    }
    if (!c.o.common.dry_run && !open_link(c)) return exit_transport;
    nlohmann::json values = nlohmann::json::object();
    std::string text;
    for (const auto& k : counters) {
        const auto r = diag_request(k.sub, data, 0);
        if (c.o.common.dry_run) {
            print_request(c, r);
            continue;
        }
        if (auto ec = transact(c, r)) return fail(c, fmt::format("diagnostics {}", k.name), ec);
        const std::uint16_t n = load_be16(c.client.reply().data.data());
        values[k.name] = n;
        text += fmt::format("{}{:<30} {}", text.empty() ? "" : "\n", k.name, n);
    }
    if (!c.o.common.dry_run)
        emit(c.o.common, {{"ok", true}, {"unit", c.unit()}, {"counters", values}}, text);
    return exit_ok;
}

int cmd_id(context& c) {
    if (c.broadcast()) return refuse_broadcast("device identification");
    mb::request r;
    r.function = mb::function::encapsulated_interface;
    r.read_device_id_code =
        static_cast<std::uint8_t>(c.o.id_code == "regular"    ? mb::device_id_code::regular
                                  : c.o.id_code == "extended" ? mb::device_id_code::extended
                                                              : mb::device_id_code::basic);
    if (c.o.common.dry_run) return print_request(c, r);
    if (!open_link(c)) return exit_transport;
    nlohmann::json objects = nlohmann::json::object();
    std::string text;
    std::uint8_t conformity = 0;
    // A server that has more than fits in one response says where to go on (AP §6.21).
    for (unsigned part = 0; part < 256; ++part) {
        if (auto ec = transact(c, r))
            return fail(c, fmt::format("read device identification of {}", unit_text(c)), ec);
        const auto& resp = c.client.reply();
        conformity = resp.conformity;
        auto rest = resp.data;
        mb::device_id_object obj;
        while (mb::next_device_id_object(rest, obj)) {
            const std::string value(reinterpret_cast<const char*>(obj.value.data()),
                                    obj.value.size());
            objects[object_name(obj.id)] = value;
            text += fmt::format("{:<20} {}\n", object_name(obj.id) + ":", value);
        }
        if (!resp.more_follows) break;
        r.object_id = resp.next_object_id;
    }
    text += fmt::format("{:<20} 0x{:02X}", "conformity level:", conformity);
    emit(c.o.common,
         {{"ok", true}, {"unit", c.unit()}, {"conformity", conformity}, {"objects", objects}},
         text);
    return exit_ok;
}

int run_modbus(const modbus_options& o, int (*fn)(context&)) {
    const auto f = resolve_format(o.common, mb::default_format);
    if (!f) return usage(fmt::format("--format/--baud: {}", std::error_code(f.error()).message()));
    if (o.host.empty() && o.common.address > mb::max_unit_address)
        return refuse("--unit", std::to_string(o.common.address), "0-247",
                      "RTU units are 1-247, 0 broadcasts a write, Serial Line V1.02 §2.2");
    context c(o, *f);
    c.type = *parse_value_type(o.as);
    c.order = *parse_word_order(o.word_order);
    return fn(c);
}

} // namespace

void add_modbus(CLI::App& app, int& exit_status) {
    auto* mb_app = app.add_subcommand(
        "modbus",
        "Modbus RTU on a serial port (--port) or Modbus TCP (--host): read, write, diag, id");
    mb_app->require_subcommand(1);
    auto o = std::make_shared<modbus_options>();

    const auto add = [mb_app, o, &exit_status](const char* name, const char* help,
                                               int (*fn)(context&)) {
        auto* sub = mb_app->add_subcommand(name, help);
        // Modbus RTU fixes no rate: those a serial port takes.
        add_common_options(
            *sub, o->common,
            {1, integer_in(0, 255, "TCP unit ids 0-255; RTU units 1-247, 0 broadcasts a write"),
             host_baud_in(1200, 921600, "the rates of a serial port")},
            "--unit,--address,-a");
        sub->get_option("--unit")->description(
            "unit id (RTU: 1-247, 0 = broadcast a write; TCP: 0-255)");
        sub->add_option("--host", o->host,
                        "Modbus TCP server HOST[:PORT] (port 502 by default) instead of --port")
            ->check(host_port_check());
        sub->add_option("--gap", o->gap_ms,
                        "RTU: ms of silence before a request (default t3.5 of the format; 0 on "
                        "virtual links)")
            ->transform(number_in(0, max_ms));
        sub->callback([o, fn, &exit_status] { exit_status = run_modbus(*o, fn); });
        return sub;
    };
    const auto typed = [o](CLI::App* sub, std::vector<std::string> types) {
        sub->add_option("--type,-t", o->type, "data table")
            ->check(CLI::IsMember(std::move(types)))
            ->capture_default_str();
        sub->add_option("--start,-r", o->start, "first address, 0-based (0-65535; 0x… for hex)")
            ->transform(integer_in(0, 0xFFFF, "a 16-bit protocol address"))
            ->capture_default_str();
        sub->add_option("--as", o->as, "register value type: u16, i16, u32, i32, float, hex")
            ->check(CLI::IsMember({"u16", "i16", "u32", "i32", "float", "hex"}))
            ->capture_default_str();
        sub->add_option("--word-order", o->word_order,
                        "byte order of 32-bit values over two registers: abcd (big-endian), badc, "
                        "cdab (low word first), dcba")
            ->check(CLI::IsMember({"abcd", "badc", "cdab", "dcba"}))
            ->capture_default_str();
    };

    auto* read =
        add("read", "read coils (FC 1), discrete inputs (2), holding (3) or input registers (4)",
            cmd_read);
    typed(read, {"coil", "discrete", "holding", "input"});
    read->add_option("--count,-c", o->count,
                     "number of values: 1-2000 bits, 1-125 registers (32-bit types: 2 each)")
        ->transform(integer_in(1, mb::max_read_bits, "a read's most, of bits, AP §6.1"))
        ->capture_default_str();
    auto* write = add("write",
                      "write coils (FC 5 one, FC 15 several) or holding registers (FC 6 one, FC 16 "
                      "several)",
                      cmd_write);
    typed(write, {"coil", "holding"});
    write->add_option("values", o->values, "values: 0/1 for coils, else as --as")->required();
    auto* diag = add("diag", "diagnostics (FC 8): echo, counters, clear", cmd_diag);
    diag->add_option("what", o->diag, "echo (sub-function 00), counters (11-18), clear (10)")
        ->check(CLI::IsMember({"echo", "counters", "clear"}))
        ->capture_default_str();
    diag->add_option("--data", o->echo_data, "the data word echo sends")
        ->transform(integer_in(0, 0xFFFF, "one data word"))
        ->capture_default_str();
    auto* id = add("id", "read device identification (FC 43 / MEI 14)", cmd_id);
    id->add_option("--code", o->id_code, "basic, regular or extended objects")
        ->check(CLI::IsMember({"basic", "regular", "extended"}))
        ->capture_default_str();
}

} // namespace ferrule::cli
