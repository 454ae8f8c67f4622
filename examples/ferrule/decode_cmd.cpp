// `ferrule decode <protocol> <hex…> | --file capture.bin`: frames and decodes captured bytes.
#include <fstream>
#include <iterator>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "decode.hpp"
#include "ferrule/dimetix/reply.hpp"
#include "ferrule/movilink/error.hpp"
#include "ferrule/movilink/frame.hpp"
#include "ferrule/movilink/process_data.hpp"

namespace ferrule::cli {

void print_skipped(const decode_options& o, std::size_t offset, std::span<const std::uint8_t> b,
                   const std::string& reason) {
    if (o.json)
        fmt::print("{}\n",
                   nlohmann::json{{"offset", offset}, {"bytes", hex(b)}, {"error", reason}}.dump());
    else
        fmt::print("@{:<4} not a telegram ({}): {}\n", offset, reason, hex(b));
}

namespace {

namespace ml = ferrule::movilink;
namespace dx = ferrule::dimetix;

void print_movilink_frame(const decode_options& o, std::size_t offset,
                          std::span<const std::uint8_t> f) {
    const ml::telegram t = *ml::parse(f);
    const bool request = t.dir == ml::direction::request;
    nlohmann::json j{{"offset", offset},
                     {"bytes", hex(f)},
                     {"direction", request ? "request" : "response"},
                     {"address", t.address},
                     {"address_kind", ml::name(ml::kind_of(t.address))},
                     {"typ", static_cast<unsigned>(t.type)},
                     {"pdu", ml::name(t.type)},
                     {"bcc", "ok"}};
    std::string text =
        fmt::format("@{:<4} {} ADR {} ({}), TYP 0x{:02X} {}, BCC ok\n", offset,
                    request ? "request " : "response", t.address, ml::name(ml::kind_of(t.address)),
                    static_cast<unsigned>(t.type), ml::name(t.type));
    if (ml::has_param(t.type)) {
        const auto& p = t.param;
        nlohmann::json pj{{"service", ml::name(p.svc())},
                          {"data_length", p.data_length()},
                          {"handshake", p.handshake()},
                          {"error", p.is_error()},
                          {"index", p.index},
                          {"subindex", p.subindex},
                          {"data", p.data}};
        text += fmt::format("       param: {} index {} (0x{:04X}) subindex {}, data 0x{:08X}, "
                            "handshake {}, length {}",
                            ml::name(p.svc()), p.index, p.index, p.subindex, p.data,
                            p.handshake() ? 1 : 0, p.data_length());
        if (p.is_error() && !request) {
            const auto ec = ml::make_device_error(p);
            pj["error_text"] = ec.message();
            text += fmt::format("\n       ERROR: {}", ec.message());
        }
        text += "\n";
        j["param"] = pj;
    }
    nlohmann::json pd = nlohmann::json::array();
    for (std::size_t i = 0; i < ml::pd_words(t.type); ++i) {
        pd.push_back(t.pd[i]);
        text += fmt::format("       {}{} 0x{:04X}", request ? "PO" : "PI", i + 1, t.pd[i]);
        // The factory mapping: PO1 control word / PI1 status word, word 2 speed.
        if (i == 0 && request) {
            const ml::control_word cw{t.pd[0]};
            text += fmt::format("  control word 1: {}{}", ml::name(cw.requested()),
                                cw.reset() ? ", reset" : "");
        } else if (i == 0) {
            const ml::status_word sw{t.pd[0]};
            text +=
                fmt::format("  status word 1: ready {}, output stage {}, {} {}", sw.ready() ? 1 : 0,
                            sw.output_stage_enabled() ? 1 : 0, sw.fault() ? "FAULT" : "unit status",
                            sw.fault() ? sw.fault_number() : sw.unit_status());
        } else if (i == 1) {
            text += fmt::format("  as speed: {:.1f} rpm", ml::digits_to_rpm(t.pd[1]));
        }
        text += "\n";
    }
    if (!pd.empty()) j["pd"] = pd;
    if (o.json)
        fmt::print("{}\n", j.dump());
    else
        fmt::print("{}", text);
}

// A capture has no idle gaps, so telegrams are taken back to back: after each telegram the
// next byte may start one; after an error one byte is skipped and framing tries again.
// Exit code 1 when any bytes were not a telegram.
int decode_movilink(const decode_options& o, std::span<const std::uint8_t> bytes) {
    bool clean = true;
    std::size_t pos = 0;
    std::size_t junk_from = 0;
    std::string junk_reason;
    const auto flush_junk = [&] {
        if (pos > junk_from) {
            print_skipped(o, junk_from, bytes.subspan(junk_from, pos - junk_from), junk_reason);
            clean = false;
        }
    };
    while (pos < bytes.size()) {
        ml::decoder d;
        d.idle();
        const auto s = d.feed(bytes.subspan(pos));
        if (s.status == ml::decoder::status::frame) {
            flush_junk();
            print_movilink_frame(o, pos, d.frame());
            pos += s.consumed;
            junk_from = pos;
        } else if (s.status == ml::decoder::status::need_more) {
            flush_junk();
            junk_from = pos;
            junk_reason = "incomplete telegram";
            pos = bytes.size();
        } else {
            if (junk_from == pos) junk_reason = s.ec.message();
            ++pos;
        }
    }
    flush_junk();
    return clean ? exit_ok : exit_device_error;
}

// Dimetix: lines ended by CR LF; each is a request (sN…) or an answer (gN…).
int decode_dimetix(const decode_options& o, std::span<const std::uint8_t> bytes) {
    bool clean = true;
    dx::line_decoder d;
    std::size_t pos = 0;
    while (pos < bytes.size()) {
        const std::size_t start = pos;
        const auto s = d.feed(bytes.subspan(pos));
        pos += s.consumed;
        if (s.what == dx::line_decoder::status::need_more) {
            print_skipped(o, start, bytes.subspan(start), "no CR LF at the end");
            return exit_device_error;
        }
        if (s.what == dx::line_decoder::status::error) {
            print_skipped(o, start, bytes.subspan(start, pos - start), "not a Dimetix line");
            clean = false;
            continue;
        }
        const auto line = d.line();
        const std::string text(reinterpret_cast<const char*>(line.data()), line.size());
        nlohmann::json j{{"offset", start}, {"text", text}};
        std::string out = fmt::format("@{:<4} {:<34}", start, text);
        if (!line.empty() && line[0] == 's') {
            const auto c = dx::parse_request(line);
            if (!c) {
                j["error"] = c.error().message();
                out += fmt::format(" request, not understood ({})", c.error().message());
                clean = false;
            } else {
                j["direction"] = "request";
                j["mnemonic"] = std::string(c->mnemonic.view());
                j["params"] =
                    std::vector<std::int32_t>(c->parameters().begin(), c->parameters().end());
                if (c->id != dx::command::no_id) j["id"] = c->id;
                out += fmt::format(" request to {} command '{}'",
                                   c->id == dx::command::no_id ? std::string("all")
                                                               : fmt::format("sensor {}", c->id),
                                   c->mnemonic.view());
                for (auto v : c->parameters()) out += fmt::format(" {}", v);
            }
        } else {
            const auto r = dx::parse_reply(line);
            if (!r) {
                j["error"] = r.error().message();
                out += fmt::format(" not an answer ({})", r.error().message());
                clean = false;
            } else {
                j["direction"] = "answer";
                j["id"] = r->id;
                j["mnemonic"] = std::string(r->mnemonic.view());
                j["values"] =
                    std::vector<std::int32_t>(r->value_span().begin(), r->value_span().end());
                switch (r->kind) {
                case dx::reply_kind::startup_or_ack:
                    out += fmt::format(" answer of sensor {}: ok / startup", r->id);
                    break;
                case dx::reply_kind::set_ack:
                    out += fmt::format(" answer of sensor {}: '{}' set", r->id, r->mnemonic.view());
                    break;
                case dx::reply_kind::value:
                    out += fmt::format(" answer of sensor {} to '{}':", r->id, r->mnemonic.view());
                    for (auto v : r->value_span()) out += fmt::format(" {}", v);
                    if (r->mnemonic.view() == "g" && r->count > 0)
                        out += fmt::format(" (distance {:.1f} mm)", r->values[0] / 10.0);
                    break;
                case dx::reply_kind::error: {
                    const auto ec = dx::make_device_error(r->error_code);
                    j["error_code"] = r->error_code;
                    j["error"] = ec.message();
                    out += fmt::format(" ERROR of sensor {}: {}", r->id, ec.message());
                    break;
                }
                }
                if (r->buffer_status >= 0) {
                    j["buffer_status"] = r->buffer_status;
                    out += fmt::format(", buffer status {}", r->buffer_status);
                }
            }
        }
        if (o.json)
            fmt::print("{}\n", j.dump());
        else
            fmt::print("{}\n", out);
    }
    return clean ? exit_ok : exit_device_error;
}

} // namespace

void add_decode(CLI::App& app, int& exit_status) {
    auto* sub = app.add_subcommand("decode", "split captured bytes into frames and decode them");
    auto o = std::make_shared<decode_options>();
    sub->add_option("protocol", o->protocol,
                    "movilink, dimetix, lecom, modbus-rtu, modbus-tcp, profibus or memobus")
        ->required()
        ->check(CLI::IsMember(
            {"movilink", "dimetix", "lecom", "modbus-rtu", "modbus-tcp", "profibus", "memobus"}));
    sub->add_option("bytes", o->hex, "hex bytes, e.g. 02 01 05 00 06 3A 98 01 F4 57");
    sub->add_option("--file", o->file, "binary capture file instead of hex bytes");
    sub->add_flag("--json", o->json, "one JSON object per frame");
    sub->callback([o, &exit_status] {
        std::vector<std::uint8_t> bytes;
        if (!o->file.empty()) {
            std::ifstream in(o->file, std::ios::binary);
            if (!in) {
                fmt::print(stderr, "ferrule decode: cannot read {}\n", o->file);
                exit_status = exit_usage;
                return;
            }
            bytes.assign(std::istreambuf_iterator<char>(in), {});
        } else if (!parse_hex(o->hex, bytes)) {
            fmt::print(stderr, "ferrule decode: {}\n", tools::hex_error(o->hex));
            exit_status = exit_usage;
            return;
        } else if (bytes.empty()) {
            fmt::print(stderr, "ferrule decode: give hex bytes (e.g. 02 01 05 ...) or --file\n");
            exit_status = exit_usage;
            return;
        }
        if (o->protocol == "dimetix")
            exit_status = decode_dimetix(*o, bytes);
        else if (o->protocol == "lecom")
            exit_status = decode_lecom(*o, bytes);
        else if (o->protocol == "modbus-rtu")
            exit_status = decode_modbus_rtu(*o, bytes);
        else if (o->protocol == "modbus-tcp")
            exit_status = decode_modbus_tcp(*o, bytes);
        else if (o->protocol == "profibus")
            exit_status = decode_profibus(*o, bytes);
        else if (o->protocol == "memobus")
            exit_status = decode_memobus(*o, bytes);
        else
            exit_status = decode_movilink(*o, bytes);
    });
}

} // namespace ferrule::cli
