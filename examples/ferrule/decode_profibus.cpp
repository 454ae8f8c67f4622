// `ferrule decode profibus`: FDL telegrams (protocols/modbus_profibus.md §B.2, §B.3) and the
// DP-V0 services they carry (§B.4, §B.5).
//
// fdl_decoder frames the bytes; after a bad FCS or bytes that start no telegram it drops one
// byte and looks again, so what follows is still found. A telegram with a bad FCS is shown
// whole with the FCS it should carry; the bytes skipped inside it are not shown again.
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <string>
#include <vector>

#include "common.hpp"
#include "decode.hpp"
#include "ferrule/profibus/constants.hpp"
#include "ferrule/profibus/fdl.hpp"
#include "profibus_text.hpp"

namespace ferrule::cli {
namespace {

namespace pb = ferrule::profibus;
using namespace ferrule::cli::profibus_text;

const char* frame_name(pb::frame f) {
    switch (f) {
    case pb::frame::sd1: return "SD1";
    case pb::frame::sd2: return "SD2";
    case pb::frame::sd3: return "SD3";
    case pb::frame::sd4: return "SD4";
    case pb::frame::short_ack: return "SC";
    }
    return "?";
}

// FC bits 3…0 of a request and of a response (§B.3); "" for a reserved value.
std::string request_name(std::uint8_t fn) {
    switch (static_cast<pb::request_fn>(fn)) {
    case pb::request_fn::time_event: return "TE";
    case pb::request_fn::sda_low: return "SDA_LO";
    case pb::request_fn::sdn_low: return "SDN_LO";
    case pb::request_fn::sda_high: return "SDA_HI";
    case pb::request_fn::sdn_high: return "SDN_HI";
    case pb::request_fn::msrd: return "MSRD";
    case pb::request_fn::fdl_status: return "FDL_Status";
    case pb::request_fn::srd_low: return "SRD_LO";
    case pb::request_fn::srd_high: return "SRD_HI";
    case pb::request_fn::ident: return "Ident";
    case pb::request_fn::lsap_status: return "LSAP_Status";
    }
    return fmt::format("reserved function {}", fn);
}

std::string response_name(std::uint8_t fn) {
    switch (static_cast<pb::response_fn>(fn)) {
    case pb::response_fn::ok: return "OK";
    case pb::response_fn::user_error: return "UE (user error)";
    case pb::response_fn::no_resource: return "RR (no resources)";
    case pb::response_fn::sap_not_active: return "RS (SAP not activated)";
    case pb::response_fn::data_low: return "DL (data low)";
    case pb::response_fn::no_response_data: return "NR (no response data)";
    case pb::response_fn::data_high: return "DH (data high: new diagnosis)";
    case pb::response_fn::rdl: return "RDL";
    case pb::response_fn::rdh: return "RDH";
    }
    return fmt::format("reserved function {}", fn);
}

// Response FC bits 5…4 (§B.3).
const char* station_type(std::uint8_t fc) {
    switch ((fc >> 4) & 3u) {
    case 0: return "slave";
    case 1: return "master not ready";
    case 2: return "master ready";
    }
    return "master in ring";
}

const char* sap_name(std::uint8_t s) {
    switch (static_cast<pb::sap>(s)) {
    case pb::sap::set_slave_address: return "Set_Slave_Add";
    case pb::sap::read_inputs: return "Rd_Inp";
    case pb::sap::read_outputs: return "Rd_Outp";
    case pb::sap::global_control: return "Global_Control";
    case pb::sap::get_cfg: return "Get_Cfg";
    case pb::sap::slave_diag: return "Slave_Diag";
    case pb::sap::set_prm: return "Set_Prm";
    case pb::sap::chk_cfg: return "Chk_Cfg";
    }
    return "";
}

// The DP service: the request's DSAP, the response's SSAP (§B.4: a response swaps them);
// without SAPs an SRD request or a DL/DH response is Data_Exchange.
std::string service_of(const pb::telegram& t) {
    const std::uint8_t s = t.is_request() ? t.dsap : t.ssap;
    if (s != pb::no_sap) return sap_name(s);
    if (t.dsap != pb::no_sap || t.ssap != pb::no_sap) return "";
    const auto is = [fn = t.function()](auto f) { return fn == static_cast<std::uint8_t>(f); };
    const bool data_exchange =
        t.is_request() ? is(pb::request_fn::srd_high) || is(pb::request_fn::srd_low)
                       : is(pb::response_fn::data_low) || is(pb::response_fn::data_high);
    return data_exchange ? "Data_Exchange" : "";
}

// Chk_Cfg / Get_Cfg identifier bytes (§B.5). Compact format: bits 3…0 length - 1, bits 5…4
// direction, bit 6 words, bit 7 consistency. A special-format byte (bits 5…4 = 00) and what
// follows it are left as hex.
std::string cfg_text(std::span<const std::uint8_t> ids, nlohmann::json& j) {
    std::string s;
    nlohmann::json list = nlohmann::json::array();
    for (std::size_t i = 0; i < ids.size(); ++i) {
        const std::uint8_t id = ids[i];
        const unsigned dir = (id >> 4) & 3u;
        if (dir == 0) {
            const std::string rest = hex(ids.subspan(i));
            list.push_back({{"special_format", rest}});
            s += fmt::format("{}special format, not decoded: {}", s.empty() ? "" : "; ", rest);
            break;
        }
        const unsigned n = (id & 0x0Fu) + 1;
        const bool words = (id & 0x40) != 0;
        const bool consistent = (id & 0x80) != 0;
        const char* d = dir == 1 ? "in" : dir == 2 ? "out" : "in/out";
        list.push_back({{"id", id},
                        {"length", n},
                        {"unit", words ? "words" : "bytes"},
                        {"direction", d},
                        {"consistent", consistent}});
        s += fmt::format("{}0x{:02X} {} {}{} {}{}", s.empty() ? "" : "; ", id, n,
                         words ? "word" : "byte", n > 1 ? "s" : "", d,
                         consistent ? ", consistent" : "");
    }
    j["identifiers"] = list;
    return s;
}

// The service fields of a DP-V0 telegram's data unit (§B.5); "" when there are none to show.
std::string service_text(const pb::telegram& t, const std::string& service, nlohmann::json& j) {
    const auto d = t.data;
    if (service == "Slave_Diag" && !t.is_request()) {
        if (d.size() < pb::diag::standard_size)
            return fmt::format("Slave_Diag: {} bytes, fewer than the {} standard ones", d.size(),
                               pb::diag::standard_size);
        const auto ident = static_cast<unsigned>(d[4] << 8 | d[5]);
        j["station_status_1"] = bit_names(d[0], station_status_1);
        j["station_status_2"] = bit_names(d[1], station_status_2);
        j["station_status_3"] = bit_names(d[2], station_status_3);
        j["master_address"] = d[3];
        j["ident_number"] = ident;
        const auto ext = d.subspan(pb::diag::standard_size);
        j["extended"] = hex(ext);
        return fmt::format("Slave_Diag: Station_Status_1 0x{:02X} {}; Station_Status_2 0x{:02X} "
                           "{}; Station_Status_3 0x{:02X} {}; Diag.Master_Add {}{}; "
                           "Ident_Number 0x{:04X}; extended diagnosis: {}",
                           d[0], join(bit_names(d[0], station_status_1)), d[1],
                           join(bit_names(d[1], station_status_2)), d[2],
                           join(bit_names(d[2], station_status_3)), d[3],
                           d[3] == pb::diag::no_master ? " (none)" : "", ident,
                           ext.empty() ? "-" : hex(ext));
    }
    if (service == "Set_Prm" && t.is_request()) {
        if (d.size() < pb::prm::standard_size)
            return fmt::format("Set_Prm: {} bytes, fewer than the {} standard ones", d.size(),
                               pb::prm::standard_size);
        const auto ident = static_cast<unsigned>(d[4] << 8 | d[5]);
        // Watchdog = WD_Fact_1 × WD_Fact_2 × 10 ms (§B.5; a DPV1 slave may be told 1 ms).
        const unsigned wd = d[1] * d[2] * 10u;
        const auto user = d.subspan(pb::prm::standard_size);
        j["station_status"] = bit_names(d[0], prm_status);
        j["wd_fact_1"] = d[1];
        j["wd_fact_2"] = d[2];
        j["watchdog_ms"] = wd;
        j["min_tsdr"] = d[3];
        j["ident_number"] = ident;
        j["group_ident"] = d[6];
        j["user_prm_data"] = hex(user);
        return fmt::format("Set_Prm: Station_Status 0x{:02X} {}; watchdog {} x {} x 10 ms = {} ms"
                           "{}; min_TSDR {}{}; Ident_Number 0x{:04X}; Group_Ident 0x{:02X}; "
                           "User_Prm_Data: {}",
                           d[0], join(bit_names(d[0], prm_status)), d[1], d[2], wd,
                           d[0] & pb::prm::wd_on ? "" : " (WD_On not set)", d[3],
                           d[3] == 0 ? " (no change)" : " tbit", ident, d[6],
                           user.empty() ? "-" : hex(user));
    }
    if ((service == "Chk_Cfg" && t.is_request()) || (service == "Get_Cfg" && !t.is_request()))
        return fmt::format("{}: {}", service, d.empty() ? "-" : cfg_text(d, j));
    if (service == "Global_Control" && t.is_request()) {
        if (d.size() < 2) return fmt::format("Global_Control: {} bytes, fewer than 2", d.size());
        j["control_command"] = bit_names(d[0], control_command);
        j["group_select"] = d[1];
        return fmt::format("Global_Control: Control_Command 0x{:02X} {}; Group_Select 0x{:02X}{}",
                           d[0], join(bit_names(d[0], control_command)), d[1],
                           d[1] == 0 ? " (all)" : "");
    }
    return "";
}

void print(const decode_options& o, const nlohmann::json& j, const std::string& text) {
    if (o.json)
        fmt::print("{}\n", j.dump());
    else
        fmt::print("{}\n", text);
}

void print_telegram(const decode_options& o, std::size_t offset, std::span<const std::uint8_t> f,
                    const pb::telegram& t) {
    nlohmann::json j{{"offset", offset}, {"bytes", hex(f)}, {"frame", frame_name(t.frame)}};
    std::string text = fmt::format("@{:<4} {:<26} {}", offset, hex(f), frame_name(t.frame));
    if (t.frame == pb::frame::short_ack) {
        print(o, j, text + " short acknowledgement");
        return;
    }
    j["da"] = t.da;
    j["sa"] = t.sa;
    if (t.frame == pb::frame::sd4) {
        print(o, j, text + fmt::format(" token DA {} SA {}", t.da, t.sa));
        return;
    }
    j["fc"] = t.fc;
    j["direction"] = t.is_request() ? "request" : "response";
    if (t.is_request()) {
        j["function"] = request_name(t.function());
        j["fcb"] = t.fcb();
        j["fcv"] = t.fcv();
    } else {
        j["function"] = response_name(t.function());
        j["station_type"] = station_type(t.fc);
    }
    text += fmt::format(" {} DA {}{} SA {}: FC 0x{:02X} ", t.is_request() ? "request " : "response",
                        t.da, t.da == pb::broadcast_address ? " (broadcast)" : "", t.sa, t.fc);
    text += t.is_request() ? fmt::format("{} FCB {} FCV {}", request_name(t.function()),
                                         t.fcb() ? 1 : 0, t.fcv() ? 1 : 0)
                           : fmt::format("{}, station type {}", response_name(t.function()),
                                         station_type(t.fc));
    if (t.dsap != pb::no_sap) {
        j["dsap"] = t.dsap;
        text += fmt::format(", DSAP {}", t.dsap);
    }
    if (t.ssap != pb::no_sap) {
        j["ssap"] = t.ssap;
        text += fmt::format(", SSAP {}", t.ssap);
    }
    const std::string service = service_of(t);
    if (!service.empty()) {
        j["service"] = service;
        text += fmt::format(", {}", service);
    }
    j["data"] = hex(t.data);
    j["fcs"] = "ok";
    text += fmt::format(", FCS ok\n       data: {}", t.data.empty() ? "-" : hex(t.data));
    const std::string fields = service_text(t, service, j);
    if (!fields.empty()) {
        j["text"] = fields;
        text += "\n       " + fields;
    }
    print(o, j, text);
}

// A telegram whose FCS does not match, starting at f[0]: the delimiter says how long it is.
void print_bad_fcs(const decode_options& o, std::size_t offset, std::span<const std::uint8_t> f) {
    const std::size_t header = f[0] == pb::sd2 ? 4 : 1;
    const std::uint8_t want = pb::fcs(f.subspan(header, f.size() - header - 2));
    const std::uint8_t got = f[f.size() - 2];
    const char* kind = f[0] == pb::sd1 ? "SD1" : f[0] == pb::sd2 ? "SD2" : "SD3";
    print(o,
          {{"offset", offset},
           {"bytes", hex(f)},
           {"frame", kind},
           {"fcs", "bad"},
           {"error", ferrule::error(errc::bad_checksum).message()}},
          fmt::format("@{:<4} {:<26} {} FCS bad: 0x{:02X}, the bytes give 0x{:02X}", offset, hex(f),
                      kind, got, want));
}

// The length a telegram with a bad FCS at bytes[0] has (the decoder checked its delimiters).
std::size_t telegram_length(std::span<const std::uint8_t> b) {
    if (b[0] == pb::sd1) return 6;
    if (b[0] == pb::sd3) return 6 + pb::sd3_data;
    return std::size_t{b[1]} + 6;
}

// Telegrams as fdl_decoder frames them. Offsets are counted from the capture's start: a
// telegram starts behind the bytes yielded before it and those the decoder dropped.
class profibus_decoder final : public capture_decoder {
public:
    explicit profibus_decoder(const decode_options& o) : o_(o) {}

    std::size_t decode(std::span<const std::uint8_t> bytes, std::size_t offset, bool end) override {
        const std::size_t stop = offset + bytes.size();
        pb::fdl_decoder::step s;
        do {
            s = d_.feed(capture_span(bytes, offset, fed_, stop));
            fed_ += s.consumed;
            take(s, bytes, offset);
        } while (s.what != pb::fdl_decoder::status::need_more);
        if (!end) return std::min(shown_, held_from());
        do {
            s = d_.finish();
            take(s, bytes, offset);
        } while (s.what != pb::fdl_decoder::status::need_more);
        junk_until(stop, bytes, offset, "incomplete or not a PROFIBUS telegram");
        return stop;
    }

private:
    // Where the bytes the decoder holds begin: it may still find a telegram there.
    std::size_t held_from() const { return yielded_ + d_.skipped(); }

    void junk_until(std::size_t end, std::span<const std::uint8_t> bytes, std::size_t offset,
                    const char* reason) {
        if (end <= shown_) return;
        print_skipped(o_, shown_, capture_span(bytes, offset, shown_, end), reason);
        clean_ = false;
        shown_ = end;
    }

    void take(const pb::fdl_decoder::step& s, std::span<const std::uint8_t> bytes,
              std::size_t offset) {
        if (s.what == pb::fdl_decoder::status::frame) {
            const std::size_t start = held_from();
            junk_until(start, bytes, offset, "not a PROFIBUS telegram");
            print_telegram(o_, start, d_.bytes(), d_.telegram());
            yielded_ += d_.bytes().size();
            shown_ = std::max(shown_, start + d_.bytes().size());
        } else if (s.what == pb::fdl_decoder::status::error && s.ec == errc::bad_checksum) {
            const std::size_t start = held_from() - 1;
            junk_until(start, bytes, offset, "not a PROFIBUS telegram");
            const std::size_t end =
                start + telegram_length(capture_span(bytes, offset, start, fed_));
            if (end > shown_) print_bad_fcs(o_, start, capture_span(bytes, offset, start, end));
            clean_ = false;
            shown_ = std::max(shown_, end);
        }
    }

    const decode_options& o_;
    pb::fdl_decoder d_;
    std::size_t fed_ = 0;
    std::size_t yielded_ = 0;
    std::size_t shown_ = 0; // bytes before this offset are printed
};

} // namespace

std::unique_ptr<capture_decoder> profibus_capture(const decode_options& o) {
    return std::make_unique<profibus_decoder>(o);
}

} // namespace ferrule::cli
