// `ferrule decode memobus`: Extended MEMOBUS messages (218 header, MFC 0x20) of a TCP
// capture or of datagrams put back to back (protocols/memobus.md §2, §3).
//
// message_decoder frames the bytes by the header's total length; bytes that start no message
// (an unknown type, a total length out of range, a MEMOBUS length that does not agree) are
// reported with the reason and skipped. A response with the serial and SFC of the command
// before it is checked against that command and named by its addresses; any other is decoded
// from its own bytes. Register data of SFC 03 / 04 / 06 / 10 are shown big-endian (§3.3).
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <optional>
#include <vector>

#include "common.hpp"
#include "decode.hpp"
#include "ferrule/memobus/error.hpp"
#include "ferrule/memobus/header.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/names.hpp"

namespace ferrule::cli {
namespace {

namespace mb = ferrule::memobus;

const char* sfc_name(std::uint8_t f) {
    switch (static_cast<mb::sfc>(f)) {
    case mb::sfc::read_coils: return "read coils";
    case mb::sfc::read_input_relays: return "read input relays";
    case mb::sfc::read_holding_registers: return "read hold registers";
    case mb::sfc::read_input_registers: return "read input registers";
    case mb::sfc::write_coil: return "write single coil";
    case mb::sfc::write_holding_register: return "write single hold register";
    case mb::sfc::loopback: return "loopback";
    case mb::sfc::read_holding_registers_ext: return "read hold registers (extended)";
    case mb::sfc::read_input_registers_ext: return "read input registers (extended)";
    case mb::sfc::write_holding_registers_ext: return "write hold registers (extended)";
    case mb::sfc::read_holding_registers_random: return "read non-consecutive hold registers";
    case mb::sfc::write_holding_registers_random: return "write non-consecutive hold registers";
    case mb::sfc::write_coils: return "write coils";
    case mb::sfc::write_holding_registers: return "write hold registers";
    }
    return "unknown SFC";
}

std::string name(mb::register_kind k, std::uint32_t n) {
    mb::register_ref r{k, static_cast<std::uint16_t>(mb::is_bit(k) ? n / 16 : n),
                       static_cast<std::uint8_t>(mb::is_bit(k) ? n % 16 : 0)};
    std::array<char, mb::max_register_name> text{};
    const auto len = mb::format_register(r, text);
    return len ? std::string(text.data(), *len) : fmt::format("address {}", n);
}

// The register area an SFC addresses.
mb::register_kind area(mb::sfc f) {
    switch (f) {
    case mb::sfc::read_coils:
    case mb::sfc::write_coil:
    case mb::sfc::write_coils: return mb::register_kind::mb;
    case mb::sfc::read_input_relays: return mb::register_kind::ib;
    case mb::sfc::read_input_registers:
    case mb::sfc::read_input_registers_ext: return mb::register_kind::iw;
    default: return mb::register_kind::mw;
    }
}

std::string words_text(std::span<const std::uint8_t> data, bool le, nlohmann::json& j) {
    std::string s;
    nlohmann::json regs = nlohmann::json::array();
    for (std::size_t i = 0; i + 1 < data.size(); i += 2) {
        const std::uint16_t v = le ? load_le16(&data[i]) : load_be16(&data[i]);
        regs.push_back(v);
        s += fmt::format(" 0x{:04X}", v);
    }
    j["registers"] = regs;
    return s;
}

std::string bits_text(std::span<const std::uint8_t> packed, std::size_t n, nlohmann::json& j) {
    std::string s;
    nlohmann::json bits = nlohmann::json::array();
    for (std::size_t i = 0; i < n; ++i) {
        const int b = (packed[i / 8] >> (i % 8)) & 1;
        bits.push_back(b);
        s += fmt::format(" {}", b);
    }
    j["bits"] = bits;
    return s;
}

// "MW00100, count 10" with the address in JSON.
std::string range_text(mb::sfc f, std::uint16_t address, std::uint16_t count, nlohmann::json& j) {
    j["address"] = address;
    j["count"] = count;
    j["register"] = name(area(f), address);
    const bool bit = mb::is_bit(area(f));
    return fmt::format("{} ({} {}), count {}", name(area(f), address),
                       bit ? "bit address" : "address", address, count);
}

std::string request_text(const mb::request& r, nlohmann::json& j) {
    const mb::sfc f = r.function;
    switch (f) {
    case mb::sfc::read_coils:
    case mb::sfc::read_input_relays:
    case mb::sfc::read_holding_registers:
    case mb::sfc::read_input_registers:
    case mb::sfc::read_holding_registers_ext:
    case mb::sfc::read_input_registers_ext: return range_text(f, r.address, r.count, j);
    case mb::sfc::write_coil:
        j["address"] = r.address;
        j["register"] = name(area(f), r.address);
        j["value"] = r.value == mb::coil_on;
        return fmt::format("{} (bit address {}) = {}", name(area(f), r.address), r.address,
                           r.value == mb::coil_on ? "ON" : "OFF");
    case mb::sfc::write_holding_register:
        j["address"] = r.address;
        j["register"] = name(area(f), r.address);
        j["value"] = r.value;
        return fmt::format("{} = 0x{:04X} ({})", name(area(f), r.address), r.value, r.value);
    case mb::sfc::loopback:
        j["test_code"] = r.address;
        j["data"] = r.value;
        return fmt::format("test code 0x{:04X}, data 0x{:04X}", r.address, r.value);
    case mb::sfc::write_coils:
        return range_text(f, r.address, r.count, j) + ":" + bits_text(r.raw, r.count, j);
    case mb::sfc::write_holding_registers:
    case mb::sfc::write_holding_registers_ext:
        return range_text(f, r.address, r.count, j) + ":" +
               words_text(r.raw, mb::is_extended(f), j);
    case mb::sfc::read_holding_registers_random: {
        std::string s = fmt::format("count {}:", r.count);
        nlohmann::json names = nlohmann::json::array();
        for (std::size_t i = 0; i < r.count; ++i) {
            names.push_back(name(mb::register_kind::mw, mb::word_at(f, r.raw, i)));
            s += " " + names.back().get<std::string>();
        }
        j["count"] = r.count;
        j["names"] = names;
        return s;
    }
    case mb::sfc::write_holding_registers_random: {
        std::string s = fmt::format("count {}:", r.count);
        nlohmann::json pairs = nlohmann::json::array();
        for (std::size_t i = 0; i < r.count; ++i) {
            const auto a = mb::word_at(f, r.raw, 2 * i);
            const auto v = mb::word_at(f, r.raw, 2 * i + 1);
            pairs.push_back({name(mb::register_kind::mw, a), v});
            s += fmt::format(" {} = 0x{:04X}", name(mb::register_kind::mw, a), v);
        }
        j["count"] = r.count;
        j["writes"] = pairs;
        return s;
    }
    }
    return {};
}

// A response's body after the CPU byte, from its own bytes; `sent` names the addresses.
std::optional<std::string> response_text(mb::sfc f, std::span<const std::uint8_t> p,
                                         const mb::request* sent, nlohmann::json& j) {
    switch (f) {
    case mb::sfc::read_coils:
    case mb::sfc::read_input_relays: {
        const std::size_t n = sent ? sent->count : 8 * p.size();
        std::string s = sent ? range_text(f, sent->address, sent->count, j) + ":" : "";
        return s + bits_text(p, n, j);
    }
    case mb::sfc::read_holding_registers:
    case mb::sfc::read_input_registers:
        if (p.size() % 2) return std::nullopt;
        return (sent ? range_text(f, sent->address, sent->count, j) + ":" : "") +
               words_text(p, false, j);
    case mb::sfc::write_coil:
    case mb::sfc::write_holding_register:
    case mb::sfc::loopback: {
        if (p.size() != 4) return std::nullopt;
        mb::request echo;
        echo.function = f;
        echo.address = load_be16(&p[0]);
        echo.value = load_be16(&p[2]);
        return request_text(echo, j) + " done";
    }
    case mb::sfc::write_coils:
    case mb::sfc::write_holding_registers:
        if (p.size() != 4) return std::nullopt;
        return range_text(f, load_be16(&p[0]), load_be16(&p[2]), j) + " done";
    case mb::sfc::read_holding_registers_ext:
    case mb::sfc::read_input_registers_ext:
    case mb::sfc::read_holding_registers_random: {
        if (p.size() < 3 || p.size() != 3u + 2u * load_le16(&p[1])) return std::nullopt;
        const std::uint16_t n = load_le16(&p[1]);
        std::string s = sent && f != mb::sfc::read_holding_registers_random
                            ? range_text(f, sent->address, n, j)
                            : fmt::format("count {}", n);
        j["count"] = n;
        return s + ":" + words_text(p.subspan(3), true, j);
    }
    case mb::sfc::write_holding_registers_ext:
        if (p.size() != 5) return std::nullopt;
        return range_text(f, load_le16(&p[1]), load_le16(&p[3]), j) + " done";
    case mb::sfc::write_holding_registers_random:
        if (p.size() != 3) return std::nullopt;
        j["count"] = load_le16(&p[1]);
        return fmt::format("count {} done", load_le16(&p[1]));
    }
    return std::nullopt;
}

struct junk_run {
    std::size_t size = 0;
    std::string reason;
};

// How many of the bytes at the start of `b` form no message, and why: bytes up to the next
// that could start a header, or a header that announces no message and what it spans.
junk_run junk_at(std::span<const std::uint8_t> b) {
    const auto known = [](std::uint8_t t) { return t == 0x11 || t == 0x12 || t == 0x19; };
    if (!known(b[0])) {
        std::size_t n = 1;
        while (n < b.size() && !known(b[n])) ++n;
        return {n, fmt::format("no 218 header: type 0x{:02X}", b[0])};
    }
    if (b.size() < mb::header_size) return {b.size(), "incomplete 218 header"};
    const std::size_t total = load_le16(&b[6]);
    if (total < mb::header_size + (b[0] == 0x12 ? 0 : mb::length_size + 1) ||
        total > mb::max_message)
        return {mb::header_size, fmt::format("total length {} out of range", total)};
    if (total > b.size())
        return {b.size(),
                fmt::format("incomplete message: total length {}, {} bytes here", total, b.size())};
    return {total, fmt::format("MEMOBUS length {} does not agree with total length {}",
                               load_le16(&b[mb::header_size]), total)};
}

// Bytes between messages, run by run.
void print_junk(const decode_options& o, std::size_t offset, std::span<const std::uint8_t> b) {
    while (!b.empty()) {
        const auto j = junk_at(b);
        print_skipped(o, offset, b.first(j.size), j.reason);
        offset += j.size;
        b = b.subspan(j.size);
    }
}

struct pending {
    std::vector<std::uint8_t> body;
    std::uint8_t serial = 0;
};

const char* type_name(mb::command_type t) {
    switch (t) {
    case mb::command_type::command: return "command";
    case mb::command_type::response: return "response";
    case mb::command_type::general: return "general";
    }
    return "?";
}

// One message; false when its MEMOBUS part is not understood.
bool print_message(const decode_options& o, std::size_t offset, std::span<const std::uint8_t> m,
                   pending& asked) {
    const mb::header h = mb::load_header(m.data());
    nlohmann::json j{{"offset", offset},
                     {"bytes", hex(m)},
                     {"type", type_name(h.type)},
                     {"serial", h.serial},
                     {"destination_channel", h.destination_channel},
                     {"source_channel", h.source_channel},
                     {"total", h.total}};
    std::string text =
        fmt::format("@{:<4} {:<8} serial {}, channel {} -> {}, total {}", offset, type_name(h.type),
                    h.serial, h.source_channel, h.destination_channel, h.total);
    bool ok = true;
    const auto finish = [&](const std::string& fields) {
        j["text"] = fields;
        if (o.json)
            fmt::print("{}\n", j.dump());
        else
            fmt::print("{}\n       {}\n", text, fields);
        return ok;
    };
    if (h.type == mb::command_type::general) {
        const auto data = m.subspan(mb::header_size);
        return finish(fmt::format("general-purpose message (never answered), {} words:{}",
                                  data.size() / 2, words_text(data, true, j)));
    }
    const auto body = m.subspan(mb::header_size);
    const std::uint8_t mfc = body[2];
    j["length"] = load_le16(body.data());
    j["mfc"] = mfc;
    text += fmt::format(", MEMOBUS length {}, MFC {:02X}", load_le16(body.data()), mfc);
    if (body.size() < 5 || mfc != mb::mfc_extended) {
        ok = false;
        return finish(fmt::format("not decoded: {}", hex(body.subspan(2))));
    }
    const std::uint8_t f = body[3];
    const std::uint8_t cpu = body[4];
    j["sfc"] = f & 0x7F;
    j["cpu"] = cpu;
    j["cpu_destination"] = cpu >> 4;
    j["cpu_source"] = cpu & 0x0F;
    text += fmt::format(", CPU 0x{:02X}: dest {} src {}", cpu, cpu >> 4, cpu & 0x0F);
    const auto fn = static_cast<mb::sfc>(f & 0x7F);
    j["sfc_name"] = sfc_name(f & 0x7F);
    const std::string head = fmt::format("SFC {:02X} {}", f & 0x7F, sfc_name(f & 0x7F));
    if (h.type == mb::command_type::command) {
        const auto r = mb::parse_request(body);
        asked = {{body.begin(), body.end()}, h.serial};
        if (!r) {
            ok = false;
            j["error"] = std::error_code(r.error()).message();
            return finish(fmt::format("{}: a controller answers {}", head,
                                      std::error_code(r.error()).message()));
        }
        return finish(fmt::format("{}: {}", head, request_text(*r, j)));
    }
    if (f & mb::error_flag) {
        if (body.size() != mb::length_size + 4) {
            ok = false;
            return finish(fmt::format("{}: malformed error response", head));
        }
        const auto ec = std::error_code(body[5], mb::device_category());
        j["error_code"] = body[5];
        j["error"] = ec.message();
        return finish(fmt::format("{}: error {:02X}: {} (SFC {:02X} = {:02X} | 80)", head, body[5],
                                  ec.message(), f, f & 0x7F));
    }
    std::optional<mb::request> sent;
    if (!asked.body.empty() && asked.serial == h.serial && asked.body[3] == f) {
        if (const auto r = mb::parse_request(asked.body)) sent = *r;
    }
    if (sent) {
        const auto checked = mb::parse_response(*sent, body);
        if (!checked) {
            ok = false;
            j["error"] = std::error_code(checked.error()).message();
            return finish(fmt::format("{}: does not answer the command before it ({})", head,
                                      std::error_code(checked.error()).message()));
        }
    }
    const auto fields = response_text(fn, body.subspan(5), sent ? &*sent : nullptr, j);
    if (!fields) {
        ok = false;
        return finish(fmt::format("{}: malformed: {}", head, hex(body.subspan(5))));
    }
    return finish(fmt::format("{}: {}", head, *fields));
}

class memobus_decoder final : public capture_decoder {
public:
    explicit memobus_decoder(const decode_options& o) : o_(o) {}

    std::size_t decode(std::span<const std::uint8_t> bytes, std::size_t offset, bool end) override {
        const std::size_t stop = offset + bytes.size();
        while (pos_ < stop) {
            const auto s = d_.feed(capture_span(bytes, offset, pos_, stop));
            pos_ += s.consumed;
            if (s.what == mb::message_decoder::status::frame) take(bytes, offset);
        }
        if (end && last_end_ < stop) {
            print_junk(o_, last_end_, capture_span(bytes, offset, last_end_, stop));
            clean_ = false;
            last_end_ = stop;
        }
        return last_end_;
    }

private:
    // The message d_ yielded, ending at pos_, and the bytes before it that form none.
    void take(std::span<const std::uint8_t> bytes, std::size_t offset) {
        const auto m = d_.message();
        const std::size_t start = pos_ - m.size();
        if (start > last_end_) {
            print_junk(o_, last_end_, capture_span(bytes, offset, last_end_, start));
            clean_ = false;
        }
        last_end_ = pos_;
        clean_ = print_message(o_, start, m, asked_) && clean_;
    }

    const decode_options& o_;
    pending asked_;
    mb::message_decoder d_;
    std::size_t pos_ = 0;      // bytes fed to d_
    std::size_t last_end_ = 0; // the end of the last message
};

} // namespace

std::unique_ptr<capture_decoder> memobus_capture(const decode_options& o) {
    return std::make_unique<memobus_decoder>(o);
}

} // namespace ferrule::cli
