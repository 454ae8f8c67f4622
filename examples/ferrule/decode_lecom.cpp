// `ferrule decode lecom`: requests and replies of a LECOM-A/B line, in either direction.
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>

#include "common.hpp"
#include "decode.hpp"
#include "ferrule/core/checksum.hpp"
#include "ferrule/lecom/error.hpp"
#include "ferrule/lecom/frame.hpp"
#include "lecom_text.hpp"

namespace ferrule::cli {
namespace {

namespace lc = ferrule::lecom;

const char* kind_text(lc::frame_kind k) {
    switch (k) {
    case lc::frame_kind::receive: return "RECEIVE";
    case lc::frame_kind::send: return "SEND";
    case lc::frame_kind::data: return "reply";
    case lc::frame_kind::fault: return "reply ?";
    case lc::frame_kind::no_code: return "reply EOT";
    case lc::frame_kind::ack: return "ACK";
    case lc::frame_kind::nak: return "NAK";
    case lc::frame_kind::eot: return "EOT";
    }
    return "?";
}

std::string address_text(std::uint8_t a) {
    if (a == lc::broadcast_address) return "00 (broadcast, no reply)";
    if (lc::is_group_address(a))
        return fmt::format("{:02} (group {}1-{}9, no reply)", a, a / 10, a / 10);
    return fmt::format("{:02}", a);
}

// Where a telegram has STX … ETX BCC: the BCC it carries and the one it should carry.
std::pair<std::uint8_t, std::uint8_t> bcc_of(std::span<const std::uint8_t> f) {
    const auto stx_at = std::find(f.begin(), f.end(), lc::stx);
    const std::span<const std::uint8_t> covered(stx_at + 1, f.end() - 1);
    return {f.back(), xor_bcc(covered)};
}

bool print_frame(const decode_options& o, std::size_t offset, std::span<const std::uint8_t> f) {
    nlohmann::json j{{"offset", offset}, {"bytes", hex(f)}};
    std::string text = fmt::format("@{:<4} {:<36}", offset, hex(f));
    const auto parsed = lc::parse_frame(f);
    if (!parsed) {
        j["error"] = std::error_code(parsed.error()).message();
        if (parsed.error() == errc::bad_checksum) {
            const auto [got, want] = bcc_of(f);
            j["bcc"] = "bad";
            text += fmt::format(" BCC bad: 0x{:02X}, the bytes give 0x{:02X}", got, want);
        } else {
            text += fmt::format(" not a LECOM telegram ({})",
                                std::error_code(parsed.error()).message());
        }
        if (o.json)
            fmt::print("{}\n", j.dump());
        else
            fmt::print("{}\n", text);
        return false;
    }
    const lc::frame& t = *parsed;
    j["kind"] = kind_text(t.kind);
    text += fmt::format(" {}", kind_text(t.kind));
    if (lc::is_request(t.kind)) {
        j["direction"] = "request";
        j["address"] = t.address;
        text += fmt::format(" to drive {}", address_text(t.address));
    } else {
        j["direction"] = "reply";
    }
    const bool has_code = t.kind != lc::frame_kind::ack && t.kind != lc::frame_kind::nak &&
                          t.kind != lc::frame_kind::eot;
    if (has_code) {
        j["code"] = t.code.code;
        j["subcode"] = t.code.subcode;
        j["extended"] = t.code.extended;
        text += fmt::format(" {}", code_text(t.code));
    }
    if (t.kind == lc::frame_kind::send || t.kind == lc::frame_kind::data) {
        j["value"] = value_text(t.value);
        j["format"] = format_name(t.value.format);
        if (t.value.format == lc::value_format::decimal) j["number"] = t.value.fixed / 10000.0;
        if (t.value.format == lc::value_format::hex) j["number"] = t.value.hex;
        text += fmt::format(" = {}", value_text(t.value));
    }
    const bool has_bcc = t.kind == lc::frame_kind::send || t.kind == lc::frame_kind::data ||
                         t.kind == lc::frame_kind::fault;
    if (has_bcc) {
        j["bcc"] = "ok";
        text += ", BCC ok";
    }
    std::string meaning;
    switch (t.kind) {
    case lc::frame_kind::fault:
        meaning = ferrule::error(lc::device_errc::checksum_fault).message();
        break;
    case lc::frame_kind::no_code:
        meaning = ferrule::error(lc::device_errc::code_does_not_exist).message();
        break;
    case lc::frame_kind::ack: meaning = "the drive accepted the write"; break;
    case lc::frame_kind::nak:
        meaning = ferrule::error(lc::device_errc::write_refused).message();
        break;
    case lc::frame_kind::eot:
        meaning = "4900 reply to RECEIVE: the code does not exist (or the start of a request)";
        break;
    default: break;
    }
    if (!meaning.empty()) {
        j["meaning"] = meaning;
        text += ": " + meaning;
    }
    if (o.json)
        fmt::print("{}\n", j.dump());
    else
        fmt::print("{}\n", text);
    return true;
}

// Telegrams are taken back to back; bytes between them that form none are shown as such.
class lecom_decoder final : public capture_decoder {
public:
    explicit lecom_decoder(const decode_options& o) : o_(o) {}

    std::size_t decode(std::span<const std::uint8_t> bytes, std::size_t offset, bool end) override {
        const std::size_t stop = offset + bytes.size();
        while (pos_ < stop) {
            const auto s = d_.feed(capture_span(bytes, offset, pos_, stop));
            pos_ += s.consumed;
            if (s.what == lc::frame_decoder::status::frame) take(bytes, offset);
        }
        if (!end) return last_end_;
        if (d_.finish().what == lc::frame_decoder::status::frame) take(bytes, offset);
        if (last_end_ < stop) {
            print_skipped(o_, last_end_, capture_span(bytes, offset, last_end_, stop),
                          "incomplete or not a telegram");
            clean_ = false;
            last_end_ = stop;
        }
        return last_end_;
    }

private:
    // The telegram d_ yielded, ending at pos_, and the bytes before it that form none.
    void take(std::span<const std::uint8_t> bytes, std::size_t offset) {
        const std::size_t start = pos_ - d_.frame().size();
        if (start > last_end_) {
            print_skipped(o_, last_end_, capture_span(bytes, offset, last_end_, start),
                          "not a LECOM telegram");
            clean_ = false;
        }
        clean_ = print_frame(o_, start, d_.frame()) && clean_;
        last_end_ = pos_;
    }

    const decode_options& o_;
    lc::frame_decoder d_{lc::frame_decoder::accept::both};
    std::size_t pos_ = 0;      // bytes fed to d_
    std::size_t last_end_ = 0; // the end of the last telegram
};

} // namespace

std::unique_ptr<capture_decoder> lecom_capture(const decode_options& o) {
    return std::make_unique<lecom_decoder>(o);
}

} // namespace ferrule::cli
