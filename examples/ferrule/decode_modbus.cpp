// `ferrule decode modbus-rtu|modbus-tcp`: requests and responses of a Modbus capture.
//
// RTU frames carry no direction. At each offset the bytes are framed both ways, by the
// length a request and a response of their function code would have (rtu_decoder in each
// mode); the framing whose CRC checks wins. When both check (FC 5, 6 and 8 echo the request
// whole), a frame that follows a request of the same unit and function is its response,
// any other a request. TCP frames likewise: a frame with the transaction id, unit and
// function of the request before it is its response; otherwise one that parses as a request
// is a request.
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <optional>
#include <vector>

#include "common.hpp"
#include "decode.hpp"
#include "ferrule/core/checksum.hpp"
#include "ferrule/modbus/error.hpp"
#include "ferrule/modbus/pdu.hpp"
#include "ferrule/modbus/registers.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/tcp.hpp"
#include "modbus_text.hpp"

namespace ferrule::cli {
namespace {

namespace mb = ferrule::modbus;

// The request a response answers: its PDU bytes (the parsed request spans them).
struct pending {
    std::vector<std::uint8_t> pdu;
    std::uint8_t unit = 0;
    std::uint16_t transaction = 0;
};

std::string bits_text(std::span<const std::uint8_t> packed, std::size_t n) {
    std::string s;
    for (std::size_t i = 0; i < n; ++i)
        s += fmt::format("{}{}", i ? " " : "", (packed[i / 8] >> (i % 8)) & 1);
    return s;
}

std::string registers_text(std::span<const std::uint8_t> data, nlohmann::json& j) {
    std::string s;
    nlohmann::json regs = nlohmann::json::array();
    for (std::size_t i = 0; i + 1 < data.size(); i += 2) {
        const std::uint16_t r = mb::register_at(data, i / 2);
        regs.push_back(r);
        s += fmt::format(" 0x{:04X}", r);
    }
    j["registers"] = regs;
    return s;
}

const char* diag_name(std::uint16_t sub) {
    switch (static_cast<mb::diag_sub>(sub)) {
    case mb::diag_sub::return_query_data: return "return query data";
    case mb::diag_sub::restart_comm: return "restart communications";
    case mb::diag_sub::return_diagnostic_register: return "return diagnostic register";
    case mb::diag_sub::force_listen_only: return "force listen only mode";
    case mb::diag_sub::clear_counters: return "clear counters";
    case mb::diag_sub::bus_message_count: return "bus message count";
    case mb::diag_sub::bus_comm_error_count: return "bus communication error count";
    case mb::diag_sub::bus_exception_count: return "bus exception error count";
    case mb::diag_sub::server_message_count: return "server message count";
    case mb::diag_sub::server_no_response_count: return "server no response count";
    case mb::diag_sub::server_nak_count: return "server NAK count";
    case mb::diag_sub::server_busy_count: return "server busy count";
    case mb::diag_sub::bus_char_overrun_count: return "bus character overrun count";
    }
    return "sub-function";
}

// A request PDU's fields; false when it is none.
bool describe_request(std::span<const std::uint8_t> pdu, nlohmann::json& j, std::string& text) {
    const auto r = mb::parse_request(pdu);
    if (!r) return false;
    const auto fc = static_cast<std::uint8_t>(r->function);
    text = function_name(fc);
    switch (r->function) {
    case mb::function::read_coils:
    case mb::function::read_discrete_inputs:
    case mb::function::read_holding_registers:
    case mb::function::read_input_registers:
        j["address"] = r->address;
        j["quantity"] = r->quantity;
        text += fmt::format(" 0x{:04X}, quantity {}", r->address, r->quantity);
        break;
    case mb::function::write_single_coil:
        j["address"] = r->address;
        j["value"] = r->value == mb::coil_on;
        text += fmt::format(" 0x{:04X} = {}", r->address, r->value == mb::coil_on ? "ON" : "OFF");
        break;
    case mb::function::write_single_register:
        j["address"] = r->address;
        j["value"] = r->value;
        text += fmt::format(" 0x{:04X} = 0x{:04X} ({})", r->address, r->value, r->value);
        break;
    case mb::function::diagnostics:
        j["sub_function"] = r->value;
        j["data"] = load_be16(r->data.data());
        text += fmt::format(" {:02}: {}, data 0x{:04X}", r->value, diag_name(r->value),
                            load_be16(r->data.data()));
        break;
    case mb::function::write_multiple_coils:
        j["address"] = r->address;
        j["quantity"] = r->quantity;
        text += fmt::format(" 0x{:04X}, quantity {}: {}", r->address, r->quantity,
                            bits_text(r->data, r->quantity));
        break;
    case mb::function::write_multiple_registers:
        j["address"] = r->address;
        j["quantity"] = r->quantity;
        text += fmt::format(" 0x{:04X}, quantity {}:{}", r->address, r->quantity,
                            registers_text(r->data, j));
        break;
    case mb::function::read_write_multiple_registers:
        j["address"] = r->address;
        j["quantity"] = r->quantity;
        j["write_address"] = r->write_address;
        text += fmt::format(": read 0x{:04X}, quantity {}; write 0x{:04X}:{}", r->address,
                            r->quantity, r->write_address, registers_text(r->data, j));
        break;
    case mb::function::encapsulated_interface:
        j["read_device_id_code"] = r->read_device_id_code;
        j["object_id"] = r->object_id;
        text +=
            fmt::format(", code {}, from object 0x{:02X}", r->read_device_id_code, r->object_id);
        break;
    }
    return true;
}

// A response PDU's fields, checked against its request when that is known.
bool describe_response(std::span<const std::uint8_t> pdu, const pending* asked, nlohmann::json& j,
                       std::string& text) {
    const std::uint8_t fc = pdu[0];
    if (fc > mb::exception_flag && pdu.size() == 2) {
        const auto ec = std::error_code(pdu[1], mb::device_category());
        j["exception"] = pdu[1];
        j["exception_text"] = ec.message();
        text = fmt::format("{}: {}", function_name(static_cast<std::uint8_t>(fc & 0x7F)),
                           error_text(ec));
        return true;
    }
    std::optional<mb::request> sent;
    if (asked && !asked->pdu.empty() && asked->pdu[0] == fc) {
        const auto r = mb::parse_request(asked->pdu);
        if (r) sent = *r;
    }
    text = function_name(fc);
    if (sent) {
        const auto parsed = mb::parse_response(*sent, pdu);
        if (!parsed) {
            j["error"] = std::error_code(parsed.error()).message();
            text += fmt::format(": does not answer the request before it ({})",
                                std::error_code(parsed.error()).message());
            return false;
        }
    }
    switch (static_cast<mb::function>(fc)) {
    case mb::function::read_coils:
    case mb::function::read_discrete_inputs: {
        const std::size_t n = sent ? sent->quantity : 8u * (pdu.size() - 2);
        j["bits"] = bits_text(pdu.subspan(2), n);
        text += sent
                    ? fmt::format(" from 0x{:04X}: {}", sent->address, bits_text(pdu.subspan(2), n))
                    : fmt::format(", {} bytes: {}", pdu[1], bits_text(pdu.subspan(2), n));
        return true;
    }
    case mb::function::read_holding_registers:
    case mb::function::read_input_registers:
    case mb::function::read_write_multiple_registers:
        if (sent) {
            j["address"] = sent->address;
            text += fmt::format(" from 0x{:04X}:", sent->address);
        } else {
            text += ":";
        }
        text += registers_text(pdu.subspan(2), j);
        return true;
    case mb::function::write_single_coil:
    case mb::function::write_single_register:
    case mb::function::write_multiple_coils:
    case mb::function::write_multiple_registers:
    case mb::function::diagnostics:
    case mb::function::encapsulated_interface: break;
    default: text += ", not decoded"; return true;
    }
    if (fc == 43) {
        mb::request q;
        q.function = mb::function::encapsulated_interface;
        q.read_device_id_code = pdu[2];
        const auto r = mb::parse_response(q, pdu);
        if (!r) return false;
        auto rest = r->data;
        mb::device_id_object o;
        nlohmann::json objects = nlohmann::json::object();
        while (mb::next_device_id_object(rest, o)) {
            const std::string v(reinterpret_cast<const char*>(o.value.data()), o.value.size());
            objects[object_name(o.id)] = v;
            text += fmt::format(", {} \"{}\"", object_name(o.id), v);
        }
        j["objects"] = objects;
        j["more_follows"] = r->more_follows;
        return true;
    }
    const std::uint16_t a = load_be16(&pdu[1]);
    const std::uint16_t v = load_be16(&pdu[3]);
    if (fc == 8) {
        j["sub_function"] = a;
        j["data"] = v;
        text += fmt::format(" {:02}: {}, data 0x{:04X} ({})", a, diag_name(a), v, v);
    } else if (fc == 5) {
        j["address"] = a;
        j["value"] = v == mb::coil_on;
        text += fmt::format(" 0x{:04X} = {} done", a, v == mb::coil_on ? "ON" : "OFF");
    } else if (fc == 6) {
        j["address"] = a;
        j["value"] = v;
        text += fmt::format(" 0x{:04X} = 0x{:04X} ({}) done", a, v, v);
    } else {
        j["address"] = a;
        j["quantity"] = v;
        text += fmt::format(" 0x{:04X}, quantity {} done", a, v);
    }
    return true;
}

void print(const decode_options& o, const nlohmann::json& j, const std::string& text) {
    if (o.json)
        fmt::print("{}\n", j.dump());
    else
        fmt::print("{}\n", text);
}

// rtu_frame_at(): the bytes end before it is known whether a frame starts there.
constexpr std::size_t undecided = static_cast<std::size_t>(-1);

// Where an RTU frame of `mode` with a good CRC starts at bytes[0]: its size; 0 when none
// does; `undecided` when more bytes are needed to tell.
std::size_t rtu_frame_at(std::span<const std::uint8_t> bytes, mb::rtu_decoder::accept mode) {
    mb::rtu_decoder d(mode);
    std::size_t used = 0;
    for (;;) {
        const auto s = d.feed(bytes.subspan(used));
        used += s.consumed;
        if (s.what == mb::rtu_decoder::status::frame) {
            const std::size_t start = used - d.adu().size();
            return start == 0 ? d.adu().size() : 0;
        }
        if (d.skipped() > 0) return 0;
        if (s.what == mb::rtu_decoder::status::need_more) return undecided;
    }
}

// The bytes are as long as a request or a response of their function code would be.
bool framed_exactly(std::span<const std::uint8_t> bytes) {
    if (bytes.size() < 4) return false;
    for (const std::size_t len : {mb::expected_request_length(bytes.subspan(1)),
                                  mb::expected_response_length(bytes.subspan(1))})
        if (len != 0 && len != mb::no_frame && len + 3 == bytes.size()) return true;
    return false;
}

class rtu_capture final : public capture_decoder {
public:
    explicit rtu_capture(const decode_options& o) : o_(o) {}

    std::size_t decode(std::span<const std::uint8_t> bytes, std::size_t offset, bool end) override {
        using accept = mb::rtu_decoder::accept;
        const std::size_t stop = offset + bytes.size();
        while (pos_ < stop) {
            const auto rest = capture_span(bytes, offset, pos_, stop);
            std::size_t as_request = rtu_frame_at(rest, accept::requests);
            std::size_t as_response = rtu_frame_at(rest, accept::responses);
            // Both framings are needed to choose: wait for the bytes that tell.
            if (!end && (as_request == undecided || as_response == undecided)) break;
            if (as_request == undecided) as_request = 0;
            if (as_response == undecided) as_response = 0;
            if (as_request == 0 && as_response == 0) {
                ++pos_;
                continue;
            }
            flush_junk(capture_span(bytes, offset, junk_from_, pos_));
            print_frame(rest, as_request, as_response);
            junk_from_ = pos_;
        }
        if (end) {
            flush_junk(capture_span(bytes, offset, junk_from_, pos_));
            junk_from_ = pos_;
        }
        return junk_from_;
    }

private:
    // Bytes between frames: a frame with a bad CRC at their end (its length right for its
    // function code), and before it bytes that form none.
    void flush_junk(std::span<const std::uint8_t> junk) {
        if (junk.empty()) return;
        clean_ = false;
        std::size_t k = 0;
        while (k < junk.size() && !framed_exactly(junk.subspan(k))) ++k;
        if (k > 0) print_skipped(o_, junk_from_, junk.first(k), "not a Modbus RTU frame");
        if (k == junk.size()) return;
        const auto f = junk.subspan(k);
        const auto got = static_cast<std::uint16_t>(f[f.size() - 2] | f[f.size() - 1] << 8);
        const std::uint16_t want = crc16_modbus(f.first(f.size() - 2));
        print(o_,
              {{"offset", junk_from_ + k},
               {"bytes", hex(f)},
               {"crc", "bad"},
               {"unit", f[0]},
               {"function", f[1] & 0x7F}},
              fmt::format("@{:<4} {:<26} unit {}: {}: CRC bad: 0x{:04X}, the bytes give 0x{:04X}",
                          junk_from_ + k, hex(f), f[0], function_name(f[1] & 0x7F), got, want));
    }

    // The frame at pos_ (`rest` from there on), framed as a request and as a response (0:
    // not so); pos_ moves past it.
    void print_frame(std::span<const std::uint8_t> rest, std::size_t as_request,
                     std::size_t as_response) {
        const bool answers = as_response != 0 && !asked_.pdu.empty() && asked_.unit == rest[0] &&
                             (rest[1] & 0x7F) == asked_.pdu[0];
        const bool request = as_request != 0 && !answers;
        const std::size_t n = request ? as_request : as_response;
        const auto frame = rest.first(n);
        const auto pdu = frame.subspan(1, n - 3);
        nlohmann::json j{{"offset", pos_},
                         {"bytes", hex(frame)},
                         {"direction", request ? "request" : "response"},
                         {"unit", frame[0]},
                         {"function", pdu[0] & 0x7F},
                         {"crc", "ok"}};
        std::string fields;
        bool ok = true;
        if (request) {
            if (!describe_request(pdu, j, fields))
                fields = fmt::format("{}: deserves exception {:02X}", function_name(pdu[0]),
                                     mb::request_exception(pdu));
            asked_ = {{pdu.begin(), pdu.end()}, frame[0], 0};
        } else {
            ok = describe_response(pdu, answers ? &asked_ : nullptr, j, fields);
            asked_ = {};
        }
        clean_ = clean_ && ok;
        j["text"] = fields;
        const std::string to = frame[0] == mb::broadcast_address ? "unit 0 (broadcast)"
                                                                 : fmt::format("unit {}", frame[0]);
        print(o_, j,
              fmt::format("@{:<4} {:<26} {} {}: {}, CRC ok", pos_, hex(frame),
                          request ? "request " : "response", to, fields));
        pos_ += n;
    }

    const decode_options& o_;
    pending asked_;
    std::size_t pos_ = 0;       // the next byte that may start a frame
    std::size_t junk_from_ = 0; // bytes from here to pos_ form none
};

// TCP frames are split by their MBAP header.
class tcp_capture final : public capture_decoder {
public:
    explicit tcp_capture(const decode_options& o) : o_(o) {}

    std::size_t decode(std::span<const std::uint8_t> bytes, std::size_t offset, bool end) override {
        const std::size_t stop = offset + bytes.size();
        while (pos_ < stop) {
            const auto s = d_.feed(capture_span(bytes, offset, pos_, stop));
            pos_ += s.consumed;
            if (s.what == mb::tcp_decoder::status::frame) take(bytes, offset);
        }
        if (end && last_end_ < stop) {
            print_skipped(o_, last_end_, capture_span(bytes, offset, last_end_, stop),
                          "incomplete or not a Modbus TCP frame");
            clean_ = false;
            last_end_ = stop;
        }
        return last_end_;
    }

private:
    // The frame d_ yielded, ending at pos_, and the bytes before it that form none.
    void take(std::span<const std::uint8_t> bytes, std::size_t offset) {
        const auto frame = d_.adu();
        const std::size_t start = pos_ - frame.size();
        if (start > last_end_) {
            print_skipped(o_, last_end_, capture_span(bytes, offset, last_end_, start),
                          "not a Modbus TCP frame");
            clean_ = false;
        }
        last_end_ = pos_;
        const auto pdu = d_.pdu();
        const bool answers = !asked_.pdu.empty() && asked_.transaction == d_.transaction() &&
                             asked_.unit == d_.unit() && (pdu[0] & 0x7F) == asked_.pdu[0];
        nlohmann::json j{{"offset", start},
                         {"bytes", hex(frame)},
                         {"transaction", d_.transaction()},
                         {"unit", d_.unit()},
                         {"function", pdu[0] & 0x7F}};
        std::string fields;
        bool request = false;
        if (!answers) {
            nlohmann::json rj = j;
            request = describe_request(pdu, rj, fields);
            if (request) j = rj;
        }
        bool ok = true;
        if (request) {
            asked_ = {{pdu.begin(), pdu.end()}, d_.unit(), d_.transaction()};
        } else {
            ok = describe_response(pdu, answers ? &asked_ : nullptr, j, fields);
            asked_ = {};
        }
        clean_ = clean_ && ok;
        j["direction"] = request ? "request" : "response";
        j["text"] = fields;
        print(o_, j,
              fmt::format("@{:<4} {} transaction {} unit {}: {}", start,
                          request ? "request " : "response", d_.transaction(), d_.unit(), fields));
    }

    const decode_options& o_;
    pending asked_;
    mb::tcp_decoder d_;
    std::size_t pos_ = 0;      // bytes fed to d_
    std::size_t last_end_ = 0; // the end of the last frame
};

} // namespace

std::unique_ptr<capture_decoder> modbus_rtu_capture(const decode_options& o) {
    return std::make_unique<rtu_capture>(o);
}

std::unique_ptr<capture_decoder> modbus_tcp_capture(const decode_options& o) {
    return std::make_unique<tcp_capture>(o);
}

} // namespace ferrule::cli
