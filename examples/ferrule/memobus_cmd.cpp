// `ferrule memobus read|write`: Yaskawa Extended MEMOBUS over TCP or UDP to an MP2000 /
// MP3000 controller (218IF / 218IFA, MP2310 built-in Ethernet; protocols/memobus.md).
//
// MW and IW registers travel in the extended SFCs 09 / 0A / 0B, whose fields are
// little-endian without doubt (§3.3); --classic takes the MEMOBUS-compatible 03 / 04 / 06 / 10
// instead, whose register data travel in --data-order (uncertain, §11.1). MB and IB bits
// travel in SFC 01 / 02 / 05 / 0F at bit address word x 16 + bit.
#include <asio/ip/tcp.hpp>
#include <asio/ip/udp.hpp>

#include <array>
#include <optional>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/host/udp_stream.hpp"
#include "ferrule/memobus/error.hpp"
#include "ferrule/memobus/master.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/names.hpp"
#include "tcp_link.hpp"

namespace ferrule::cli {
namespace {

namespace mb = ferrule::memobus;

// The Yaskawa sample's example port (§6); no port is fixed by the protocol.
constexpr const char* default_port = "10001";

struct memobus_options {
    common_options common;
    std::string host;
    bool udp = false;
    std::optional<std::uint16_t> local_port;
    unsigned cpu = mb::default_cpu;
    std::string data_order = "big";
    bool classic = false;
    std::string name;
    unsigned count = 1;
    std::vector<std::string> values;
};

// One TCP connection (tcp_link) or one connected UDP socket, with its blocking stream.
class link {
public:
    // Resolves, binds --local-port, connects; on failure prints why and returns nullptr.
    static std::unique_ptr<link> open(const memobus_options& o) {
        std::unique_ptr<link> l(new link());
        if (!o.udp) {
            l->tcp_ = tcp_link::open(
                o.host, std::chrono::milliseconds(o.common.timeout_ms.value_or(3000)),
                o.common.trace, {default_port, "MEMOBUS controller", o.local_port});
            return l->tcp_ ? std::move(l) : nullptr;
        }
        const auto [name, port] = split_host_port(o.host, default_port);
        if (const auto ec = l->open_udp(name, port, o)) {
            fmt::print(stderr, "ferrule: cannot connect to {} (UDP): {}\n", o.host, ec.message());
            return nullptr;
        }
        if (o.common.trace) l->udp_stream_.set_tap(trace_tap(host::steady_now()));
        return l;
    }

    std::error_code transact(mb::master& m) {
        return tcp_ ? run(tcp_->stream(), m) : run(udp_stream_, m);
    }

private:
    link() : udp_(ctx_), udp_stream_(ctx_, udp_) {}

    std::error_code open_udp(const std::string& name, const std::string& port,
                             const memobus_options& o) {
        std::error_code ec;
        ::asio::ip::udp::resolver resolver(ctx_);
        const auto found = resolver.resolve(::asio::ip::udp::v4(), name, port, ec);
        if (ec) return ec;
        const auto to = found.begin()->endpoint();
        udp_.open(to.protocol(), ec);
        if (!ec && o.local_port) udp_.bind({to.protocol(), *o.local_port}, ec);
        if (!ec) udp_.connect(to, ec);
        return ec;
    }

    std::unique_ptr<tcp_link> tcp_;
    ::asio::io_context ctx_;
    ::asio::ip::udp::socket udp_;
    host::udp_stream udp_stream_;
};

int usage(const std::string& why) {
    fmt::print(stderr, "ferrule: {}\n", why);
    return exit_usage;
}

mb::data_order order_of(const memobus_options& o) {
    return o.data_order == "little" ? mb::data_order::little_endian : mb::data_order::big_endian;
}

mb::master_config master_config(const memobus_options& o) {
    mb::master_config c;
    if (o.common.timeout_ms) c.response_timeout = std::chrono::milliseconds(*o.common.timeout_ms);
    if (o.common.retries) c.retries = *o.common.retries;
    c.cpu = static_cast<std::uint8_t>(o.cpu);
    c.order = order_of(o);
    return c;
}

std::string name_of(const mb::register_ref& r) {
    std::array<char, mb::max_register_name> text{};
    const auto n = mb::format_register(r, text);
    return n ? std::string(text.data(), *n) : std::string("?");
}

// The i-th register or bit from `first`.
mb::register_ref nth(const mb::register_ref& first, std::size_t i) {
    mb::register_ref r = first;
    if (mb::is_bit(first.kind)) {
        const auto a = mb::bit_address(first) + i;
        r.word = static_cast<std::uint16_t>(a / 16);
        r.bit = static_cast<std::uint8_t>(a % 16);
    } else {
        r.word = static_cast<std::uint16_t>(first.word + i);
    }
    return r;
}

// "1", "0x04D2", "-1": a register value, signed or unsigned 16 bits, or nullopt.
std::optional<std::uint16_t> parse_word(const std::string& s) {
    const auto v = parse_integer(s);
    if (!v || *v < -32768 || *v > 65535) return std::nullopt;
    return static_cast<std::uint16_t>(*v);
}

std::string sfc_text(mb::sfc f) {
    return fmt::format("SFC {:02X}", static_cast<unsigned>(f));
}

// What runs a request: --dry-run prints it, else it goes to the controller.
struct context {
    const memobus_options& o;
    mb::master master;
    std::unique_ptr<link> line;

    explicit context(const memobus_options& opts) : o(opts), master(master_config(opts)) {}

    // Prints the command (serial 0) for --dry-run; else connects and runs it.
    std::optional<int> execute(mb::request r, const std::string& what) {
        if (o.common.dry_run) {
            std::array<std::uint8_t, mb::max_message> out{};
            r.cpu = static_cast<std::uint8_t>(o.cpu);
            const auto n = mb::encode_command(r, 0, out, order_of(o));
            if (!n)
                return usage(fmt::format("cannot encode the request: {}",
                                         std::error_code(n.error()).message()));
            fmt::print("{}\n", hex({out.data(), *n}));
            return exit_ok;
        }
        if (!line) line = link::open(o);
        if (!line) return exit_transport;
        if (auto ec = master.start(r)) return usage(fmt::format("{}: {}", what, ec.message()));
        if (auto ec = line->transact(master)) {
            // A controller whose channels are all in use accepts and closes at once over TCP,
            // and drops a command from a new UDP master unanswered.
            const bool closed = ec == ::asio::error::eof || ec == ::asio::error::connection_reset;
            std::string failed =
                closed ? what + "; the controller closed the connection (all channels in use?)"
                       : what;
            if (o.udp && ec == ferrule::error(errc::timeout))
                failed = what + " over UDP; the controller may be unreachable or have no free "
                                "channel (all in use by other masters)";
            return report_error(o.common, failed, ec, ec.category() == mb::device_category());
        }
        return std::nullopt;
    }
};

// The usage error of a name that is no register: beyond its area (MW65535), or no name at all.
int name_refused(const std::string& name, std::string_view examples) {
    const auto area = mb::area_of(name);
    if (area && mb::parse_register(name).error() == errc::out_of_range)
        return usage(
            fmt::format("{}: register number out of range 0..{}", name, mb::last_word(*area)));
    return usage(fmt::format("'{}' is no register name ({})", name, examples));
}

int cmd_read(const memobus_options& o) {
    const auto first = mb::try_parse_register(o.name);
    if (!first) return name_refused(o.name, "MW00100, IW0010, MB00100A, IB00100");
    mb::request r;
    r.count = static_cast<std::uint16_t>(o.count);
    const bool bits = mb::is_bit(first->kind);
    std::size_t limit = 0;
    if (bits) {
        r.function =
            first->kind == mb::register_kind::mb ? mb::sfc::read_coils : mb::sfc::read_input_relays;
        limit = mb::max_read_bits;
        if (mb::bit_address(*first) + o.count > 0x10000u)
            return refuse("--count", std::to_string(o.count),
                          fmt::format("1-{}", 0x10000u - mb::bit_address(*first)),
                          fmt::format("from {} the bits end at bit address 65535 (word 4095)",
                                      name_of(*first)));
        r.address = static_cast<std::uint16_t>(mb::bit_address(*first));
    } else {
        const bool hold = first->kind == mb::register_kind::mw;
        r.function =
            o.classic
                ? (hold ? mb::sfc::read_holding_registers : mb::sfc::read_input_registers)
                : (hold ? mb::sfc::read_holding_registers_ext : mb::sfc::read_input_registers_ext);
        limit = o.classic ? mb::max_read_registers : mb::max_read_registers_ext;
        const unsigned last = hold ? 65534u : 65535u;
        if (first->word + o.count - 1 > last)
            return refuse("--count", std::to_string(o.count),
                          fmt::format("1-{}", last - first->word + 1),
                          fmt::format("from {} the registers end at {}", name_of(*first),
                                      hold ? "MW65534" : "IW65535"));
        r.address = first->word;
    }
    if (o.count > limit)
        return refuse("--count", std::to_string(o.count), fmt::format("1-{}", limit),
                      fmt::format("{} reads at most {}", sfc_text(r.function), limit));
    context c(o);
    const std::string what =
        fmt::format("read {} x {} ({})", name_of(*first), o.count, sfc_text(r.function));
    if (const auto rc = c.execute(r, what)) return *rc;
    std::string text;
    nlohmann::json values = nlohmann::json::array();
    nlohmann::json names = nlohmann::json::array();
    for (unsigned i = 0; i < o.count; ++i) {
        const std::string name = name_of(nth(*first, i));
        names.push_back(name);
        if (!text.empty()) text += '\n';
        if (bits) {
            const int b = c.master.bit(i) ? 1 : 0;
            values.push_back(b);
            text += fmt::format("{}: {}", name, b);
        } else {
            const std::uint16_t v = c.master.word(i);
            values.push_back(v);
            text += fmt::format("{}: {:5}  0x{:04X}", name, v, v);
        }
    }
    emit(o.common,
         {{"ok", true},
          {"sfc", static_cast<unsigned>(r.function)},
          {"register", name_of(*first)},
          {"count", o.count},
          {"names", names},
          {"values", values}},
         text);
    return exit_ok;
}

int cmd_write(const memobus_options& o) {
    const auto first = mb::try_parse_register(o.name);
    if (!first) return name_refused(o.name, "MW00100, MB00100A");
    if (first->kind != mb::register_kind::mw && first->kind != mb::register_kind::mb)
        return usage("only MW registers and MB bits can be written");
    const std::size_t n = o.values.size();
    mb::request r;
    r.count = static_cast<std::uint16_t>(n);
    std::vector<std::uint16_t> words;
    std::array<std::uint8_t, mb::packed_size(mb::max_write_bits)> packed{};
    if (first->kind == mb::register_kind::mb) {
        if (n > mb::max_write_bits) return usage("one request writes 1-800 bits (SFC 0F)");
        if (mb::bit_address(*first) + n > 0x10000u)
            return usage("the bits go beyond bit address 65535 (word 4095)");
        for (std::size_t i = 0; i < n; ++i) {
            if (o.values[i] != "0" && o.values[i] != "1")
                return usage(fmt::format("values: '{}' is no bit value: give 0 or 1", o.values[i]));
            if (o.values[i] == "1")
                packed[i / 8] = static_cast<std::uint8_t>(packed[i / 8] | 1u << (i % 8));
        }
        r.address = static_cast<std::uint16_t>(mb::bit_address(*first));
        if (n == 1) {
            r.function = mb::sfc::write_coil;
            r.value = o.values[0] == "1" ? mb::coil_on : 0;
        } else {
            r.function = mb::sfc::write_coils;
            r.bits = std::span<const std::uint8_t>(packed).first(mb::packed_size(n));
        }
    } else {
        for (const auto& v : o.values) {
            const auto w = parse_word(v);
            if (!w)
                return usage(fmt::format(
                    "values: '{}' is no register value: give -32768 to 65535 (16 bits, signed "
                    "or unsigned)",
                    v));
            words.push_back(*w);
        }
        const std::size_t limit = o.classic ? mb::max_write_registers : mb::max_write_registers_ext;
        if (n > limit) return usage(fmt::format("one request writes 1-{} registers", limit));
        if (first->word + n - 1 > 65534u) return usage("the registers go beyond MW65534");
        r.address = first->word;
        if (!o.classic) {
            r.function = mb::sfc::write_holding_registers_ext;
            r.words = words;
        } else if (n == 1) {
            r.function = mb::sfc::write_holding_register;
            r.value = words[0];
        } else {
            r.function = mb::sfc::write_holding_registers;
            r.words = words;
        }
    }
    std::string list;
    for (const auto& v : o.values) list += (list.empty() ? "" : " ") + v;
    const std::string what =
        fmt::format("write {} = {} ({})", name_of(*first), list, sfc_text(r.function));
    context c(o);
    if (const auto rc = c.execute(r, what)) return *rc;
    nlohmann::json j{{"ok", true},
                     {"sfc", static_cast<unsigned>(r.function)},
                     {"register", name_of(*first)},
                     {"values", o.values}};
    if (!words.empty()) j["registers"] = words;
    emit(o.common, j, fmt::format("{}: ok", what));
    return exit_ok;
}

int run_memobus(const memobus_options& o, int (*fn)(const memobus_options&)) {
    if (o.host.empty() && !o.common.dry_run)
        return usage("--host: give the controller's IP[:PORT]");
    return fn(o);
}

} // namespace

void add_memobus(CLI::App& app, int& exit_status) {
    auto* sub = app.add_subcommand(
        "memobus", "Yaskawa Extended MEMOBUS to an MP2000 / MP3000 controller over TCP or UDP");
    sub->require_subcommand(1);
    auto o = std::make_shared<memobus_options>();
    const auto add = [sub, o, &exit_status](const char* name, const char* help,
                                            int (*fn)(const memobus_options&)) {
        auto* cmd = sub->add_subcommand(name, help);
        cmd->add_option("--host", o->host,
                        std::string("controller IP[:PORT] (port ") + default_port + " by default)")
            ->check(host_port_check());
        cmd->add_flag("--udp", o->udp, "UDP instead of TCP");
        cmd->add_option("--local-port", o->local_port,
                        "bind this local port (the controller's connection table may fix it)")
            ->transform(integer_in(1, 65535, "a UDP or TCP port"));
        cmd->add_option("--cpu", o->cpu,
                        "CPU byte: destination << 4 | source (0x10: CPU 1 from a PC)")
            ->transform(integer_in(0, 0xFF, "one byte: destination CPU << 4 | source CPU, §3.2"))
            ->capture_default_str();
        cmd->add_option("--timeout", o->common.timeout_ms, "response timeout in ms (default 1000)")
            ->transform(integer_in(1, max_ms));
        cmd->add_option("--retries", o->common.retries, "resends after a failed attempt")
            ->transform(integer_in(0, max_retries));
        cmd->add_option("--data-order", o->data_order,
                        "byte order of register data in SFC 03 / 04 / 06 / 10 (uncertain)")
            ->check(CLI::IsMember({"big", "little"}))
            ->capture_default_str();
        cmd->add_flag("--classic", o->classic,
                      "MW / IW in SFC 03 / 04 / 06 / 10 instead of the extended 09 / 0A / 0B");
        cmd->add_flag("--trace", o->common.trace,
                      "print every message as hex with direction and time (stderr)");
        cmd->add_flag("--json", o->common.json, "one JSON object per result");
        cmd->add_flag("--dry-run", o->common.dry_run, "print the command as hex; open nothing");
        cmd->add_option("register", o->name,
                        "MW00100, IW0010, MB00100A (bit A of MW00100), IB00100")
            ->required();
        cmd->callback([o, fn, &exit_status] { exit_status = run_memobus(*o, fn); });
        return cmd;
    };
    auto* read = add("read", "read MW / IW registers or MB / IB bits", cmd_read);
    read->add_option("--count,-c", o->count,
                     "number of registers or bits (bits 1-2000; MW / IW 1-2044, --classic 1-125)")
        ->transform(integer_in(1, mb::max_read_registers_ext, "SFC 09 / 0A's most"))
        ->capture_default_str();
    auto* write = add("write", "write MW registers or MB bits", cmd_write);
    write->add_option("values", o->values, "register values (decimal, 0x hex) or bits 0 / 1")
        ->required();
}

} // namespace ferrule::cli
