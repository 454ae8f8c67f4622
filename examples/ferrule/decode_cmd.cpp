// `ferrule decode <protocol> <hex…> | --file capture.bin`: frames and decodes captured bytes.
// A file is read in pieces and decoded as they come, so a pipe or a device works too and
// memory stays bounded (docs/cli.md).
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <system_error>
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

// Status word 1's high byte as bits 1 and 5 say (movilink.md §3.3): a fault's number
// (not ready), a warning's number (ready), else the unit status.
std::string status_high_byte(ml::status_word sw) {
    if (sw.fault()) return fmt::format("FAULT {}", sw.fault_number());
    if (sw.warning()) return fmt::format("WARNING {}", sw.warning_number());
    return fmt::format("unit status {}", sw.unit_status());
}

nlohmann::json status_json(ml::status_word sw) {
    return {{"value", sw.value},
            {"state", ml::name(sw.state())},
            {"ready", sw.ready()},
            {"output_stage_enabled", sw.output_stage_enabled()},
            {"fault_number", sw.fault_number()},
            {"warning_number", sw.warning_number()},
            {"unit_status", sw.unit_status()}};
}

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
            const std::error_code ec = ml::make_device_error(p);
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
                fmt::format("  status word 1: ready {}, output stage {}, {}", sw.ready() ? 1 : 0,
                            sw.output_stage_enabled() ? 1 : 0, status_high_byte(sw));
            j["status_word"] = status_json(sw);
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
class movilink_decoder final : public capture_decoder {
public:
    explicit movilink_decoder(const decode_options& o) : o_(o) {}

    std::size_t decode(std::span<const std::uint8_t> bytes, std::size_t offset, bool end) override {
        const std::size_t stop = offset + bytes.size();
        const auto at = [&](std::size_t from, std::size_t to) {
            return capture_span(bytes, offset, from, to);
        };
        while (pos_ < stop) {
            ml::decoder d;
            d.idle();
            const auto s = d.feed(at(pos_, stop));
            if (s.what == ml::decoder::status::frame) {
                flush_junk(at(junk_from_, pos_));
                print_movilink_frame(o_, pos_, d.frame());
                pos_ += s.consumed;
                junk_from_ = pos_;
            } else if (s.what == ml::decoder::status::need_more) {
                if (!end) return junk_from_; // the rest of the telegram is still to come
                flush_junk(at(junk_from_, pos_));
                junk_from_ = pos_;
                junk_reason_ = "incomplete telegram";
                pos_ = stop;
            } else {
                if (junk_from_ == pos_) junk_reason_ = std::error_code(s.ec).message();
                ++pos_;
            }
        }
        if (end) {
            flush_junk(at(junk_from_, pos_));
            junk_from_ = pos_;
        }
        return junk_from_;
    }

private:
    void flush_junk(std::span<const std::uint8_t> junk) {
        if (junk.empty()) return;
        print_skipped(o_, junk_from_, junk, junk_reason_);
        clean_ = false;
    }

    const decode_options& o_;
    std::size_t pos_ = 0;       // the next byte that may start a telegram
    std::size_t junk_from_ = 0; // bytes from here to pos_ form none
    std::string junk_reason_;
};

// Dimetix: lines ended by CR LF; each is a request (sN…) or an answer (gN…). Prints one line;
// false when it is not understood.
bool print_dimetix_line(const decode_options& o, std::size_t start,
                        std::span<const std::uint8_t> line) {
    bool clean = true;
    const std::string text(reinterpret_cast<const char*>(line.data()), line.size());
    nlohmann::json j{{"offset", start}, {"text", text}};
    std::string out = fmt::format("@{:<4} {:<34}", start, text);
    if (!line.empty() && line[0] == 's') {
        const auto c = dx::parse_request(line);
        if (!c) {
            j["error"] = std::error_code(c.error()).message();
            out +=
                fmt::format(" request, not understood ({})", std::error_code(c.error()).message());
            clean = false;
        } else {
            j["direction"] = "request";
            j["mnemonic"] = std::string(c->mnemonic.view());
            j["params"] = std::vector<std::int32_t>(c->parameters().begin(), c->parameters().end());
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
            j["error"] = std::error_code(r.error()).message();
            out += fmt::format(" not an answer ({})", std::error_code(r.error()).message());
            clean = false;
        } else {
            j["direction"] = "answer";
            j["id"] = r->id;
            j["mnemonic"] = std::string(r->mnemonic.view());
            j["values"] = std::vector<std::int32_t>(r->value_span().begin(), r->value_span().end());
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
                const std::error_code ec = dx::make_device_error(r->error_code);
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
    return clean;
}

class dimetix_decoder final : public capture_decoder {
public:
    explicit dimetix_decoder(const decode_options& o) : o_(o) {}

    std::size_t decode(std::span<const std::uint8_t> bytes, std::size_t offset, bool end) override {
        const std::size_t stop = offset + bytes.size();
        while (pos_ < stop) {
            const auto s = d_.feed(capture_span(bytes, offset, pos_, stop));
            pos_ += s.consumed;
            if (s.what == dx::line_decoder::status::need_more) break;
            if (s.what == dx::line_decoder::status::error) {
                print_skipped(o_, start_, capture_span(bytes, offset, start_, pos_),
                              "not a Dimetix line");
                clean_ = false;
            } else {
                clean_ = print_dimetix_line(o_, start_, d_.line()) && clean_;
            }
            start_ = pos_;
        }
        if (end && start_ < stop) {
            print_skipped(o_, start_, capture_span(bytes, offset, start_, stop),
                          "no CR LF at the end");
            clean_ = false;
            start_ = stop;
        }
        return start_;
    }

private:
    const decode_options& o_;
    dx::line_decoder d_;
    std::size_t pos_ = 0;   // bytes fed to d_
    std::size_t start_ = 0; // where the line d_ is on began
};

std::unique_ptr<capture_decoder> make_decoder(const decode_options& o) {
    if (o.protocol == "dimetix") return std::make_unique<dimetix_decoder>(o);
    if (o.protocol == "lecom") return lecom_capture(o);
    if (o.protocol == "modbus-rtu") return modbus_rtu_capture(o);
    if (o.protocol == "modbus-tcp") return modbus_tcp_capture(o);
    if (o.protocol == "profibus") return profibus_capture(o);
    if (o.protocol == "memobus") return memobus_capture(o);
    return std::make_unique<movilink_decoder>(o);
}

int usage(const std::string& why) {
    fmt::print(stderr, "ferrule decode: {}\n", why);
    return exit_usage;
}

class file_descriptor {
public:
    explicit file_descriptor(int fd) noexcept : fd_(fd) {}
    file_descriptor(const file_descriptor&) = delete;
    file_descriptor& operator=(const file_descriptor&) = delete;
    ~file_descriptor() {
        if (fd_ >= 0) ::close(fd_);
    }
    int get() const noexcept { return fd_; }

private:
    int fd_;
};

// Reads into `out`: how many bytes (0 at the end of the file), or -1 with errno.
ssize_t read_some(int fd, std::span<std::uint8_t> out) {
    for (;;) {
        const ssize_t n = ::read(fd, out.data(), out.size());
        if (n >= 0 || errno != EINTR) return n;
    }
}

std::string read_error(const std::string& file, std::size_t read, std::error_code ec) {
    if (read == 0) return fmt::format("cannot read {}: {}", file, ec.message());
    return fmt::format("cannot read {} beyond offset {}: {}", file, read, ec.message());
}

// The capture in --file, read a piece at a time and decoded as it comes: the bytes held are
// those the decoder is not done with, never more than --max-junk.
int decode_file(const decode_options& o, capture_decoder& d) {
    constexpr std::size_t piece = 4096;
    const file_descriptor file(::open(o.file.c_str(), O_RDONLY | O_CLOEXEC));
    if (file.get() < 0) return usage(read_error(o.file, 0, {errno, std::generic_category()}));
    std::vector<std::uint8_t> held;
    held.reserve(o.max_junk);
    std::size_t offset = 0; // of held[0] in the capture
    for (;;) {
        const std::size_t before = held.size();
        held.resize(before + std::min(piece, o.max_junk - before));
        const ssize_t n = read_some(file.get(), std::span(held).subspan(before));
        if (n < 0) {
            const std::error_code ec(errno, std::generic_category());
            held.resize(before);
            d.decode(held, offset, true);
            return usage(read_error(o.file, offset + before, ec));
        }
        held.resize(before + static_cast<std::size_t>(n));
        if (n == 0) break;
        const std::size_t done = d.decode(held, offset, false);
        held.erase(held.begin(), held.begin() + static_cast<std::ptrdiff_t>(done - offset));
        offset = done;
        std::fflush(stdout);
        if (held.size() == o.max_junk) {
            d.decode(held, offset, true);
            return usage(fmt::format("{}: no {} telegram in the {} bytes from offset {}; stopped "
                                     "there (--max-junk sets how many)",
                                     o.file, o.protocol, o.max_junk, offset));
        }
    }
    if (offset + held.size() == 0) return usage(fmt::format("{} is empty: no bytes", o.file));
    d.decode(held, offset, true);
    return d.clean() ? exit_ok : exit_device_error;
}

int decode_hex(const decode_options& o, capture_decoder& d) {
    std::vector<std::uint8_t> bytes;
    if (!parse_hex(o.hex, bytes)) return usage(tools::hex_error(o.hex));
    if (bytes.empty()) return usage("give hex bytes (e.g. 02 01 05 ...) or --file");
    d.decode(bytes, 0, true);
    return d.clean() ? exit_ok : exit_device_error;
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
    auto* hex_bytes =
        sub->add_option("bytes", o->hex, "hex bytes, e.g. 02 01 05 00 06 3A 98 01 F4 57");
    sub->add_option("--file", o->file,
                    "binary capture file (or pipe, device) instead of hex bytes, decoded as it "
                    "is read")
        ->excludes(hex_bytes);
    sub->add_option("--max-junk", o->max_junk,
                    "--file: stop after this many bytes in a row that hold no telegram")
        ->transform(integer_in(min_max_junk, std::int64_t{16} << 20))
        ->capture_default_str();
    sub->add_flag("--json", o->json, "one JSON object per frame");
    sub->callback([o, &exit_status] {
        const auto d = make_decoder(*o);
        exit_status = o->file.empty() ? decode_hex(*o, *d) : decode_file(*o, *d);
    });
}

} // namespace ferrule::cli
