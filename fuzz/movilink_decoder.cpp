// libFuzzer target: movilink::decoder, movilink::parse and movilink::encode.
//
// Input layout
//   byte 0      mode: bits 0-1 accept (0 requests, 1 responses, 2/3 both)
//                     bits 2-3 feeding scheme (below), bits 4-7 chunk size - 1
//   bytes 1..   the byte stream ("records" scheme: record headers interleaved, see below)
//
// Feeding schemes
//   0  records: each record is a header byte (bit 7 = idle gap before the record,
//      bit 6 = idle gap after each frame / error inside it, bits 0-4 = number of data
//      bytes that follow, 0 = gap only) and its data bytes, fed to the decoder as one
//      chunk (what the decoder leaves unconsumed is fed again, as a driver would)
//   1  fixed chunks of (bits 4-7) + 1 bytes; an idle gap after every frame or error
//      (what a receiver that detects gaps does when the line is noisy)
//   2  the whole stream as one span, fed until consumed; idle gap after frame / error
//   3  fixed chunks, a single idle gap at the start only: after the first error the
//      decoder must skip (and count) everything that follows
//
// Invariants (violation -> __builtin_trap):
//   * step.consumed <= chunk size; a non-empty chunk makes progress (consumed >= 1);
//     need_more only when the whole chunk was consumed; frame / error carry / lack ec
//   * every frame: size == telegram_size(TYP), valid TYP, SD accepted by the mode, BCC
//     correct, bytes equal the last bytes fed (nothing invented), parse() succeeds with
//     the direction of its SD, encode() and encode_fixed<TYP>() reproduce it byte for byte
//   * skipped() never decreases and grows by at most the bytes buffered + consumed
//   * conservation: bytes fed == bytes in frames + skipped() + bytes dropped by idle()
//     in the middle of a telegram + bytes of the telegram in progress
//   * parse() on the raw input: result matches an independent oracle; on success,
//     encode() gives back the same bytes; a fresh decoder frames it identically
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "ferrule/movilink/frame.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::movilink;

template <pdu_type T>
void check_fixed(const telegram& t, std::span<const std::uint8_t> expected) {
    std::array<std::uint8_t, telegram_size(T)> out{};
    encode_fixed<T>(t, std::span<std::uint8_t, telegram_size(T)>(out));
    FERRULE_CHECK(expected.size() == out.size());
    FERRULE_CHECK(std::memcmp(out.data(), expected.data(), out.size()) == 0);
}

void check_encode_fixed(const telegram& t, std::span<const std::uint8_t> expected) {
    switch (t.type) {
    case pdu_type::param_1pd: return check_fixed<pdu_type::param_1pd>(t, expected);
    case pdu_type::pd1: return check_fixed<pdu_type::pd1>(t, expected);
    case pdu_type::param_2pd: return check_fixed<pdu_type::param_2pd>(t, expected);
    case pdu_type::pd2: return check_fixed<pdu_type::pd2>(t, expected);
    case pdu_type::param_3pd: return check_fixed<pdu_type::param_3pd>(t, expected);
    case pdu_type::pd3: return check_fixed<pdu_type::pd3>(t, expected);
    case pdu_type::param: return check_fixed<pdu_type::param>(t, expected);
    case pdu_type::param_1pd_acyclic: return check_fixed<pdu_type::param_1pd_acyclic>(t, expected);
    case pdu_type::pd1_acyclic: return check_fixed<pdu_type::pd1_acyclic>(t, expected);
    case pdu_type::param_2pd_acyclic: return check_fixed<pdu_type::param_2pd_acyclic>(t, expected);
    case pdu_type::pd2_acyclic: return check_fixed<pdu_type::pd2_acyclic>(t, expected);
    case pdu_type::param_3pd_acyclic: return check_fixed<pdu_type::param_3pd_acyclic>(t, expected);
    case pdu_type::pd3_acyclic: return check_fixed<pdu_type::pd3_acyclic>(t, expected);
    case pdu_type::param_acyclic: return check_fixed<pdu_type::param_acyclic>(t, expected);
    }
    __builtin_trap(); // parse() produced an undocumented TYP
}

// A successfully parsed telegram must re-encode to exactly `bytes`.
void check_roundtrip(const telegram& t, std::span<const std::uint8_t> bytes) {
    std::array<std::uint8_t, max_telegram_size + 4> out{};
    const auto n = encode(t, out);
    FERRULE_CHECK(n.has_value());
    FERRULE_CHECK(*n == bytes.size());
    FERRULE_CHECK(std::memcmp(out.data(), bytes.data(), *n) == 0);
    // Too small a buffer is an error, never an overrun.
    const auto small = encode(t, std::span<std::uint8_t>(out.data(), *n - 1));
    FERRULE_CHECK(!small.has_value() && small.error() == errc::buffer_too_small);
    check_encode_fixed(t, bytes);
    // parse(encode(t)) == t
    const auto again = parse(std::span<const std::uint8_t>(out.data(), *n));
    FERRULE_CHECK(again.has_value() && *again == t);
}

bool sd_ok(decoder::accept a, std::uint8_t b) {
    switch (a) {
    case decoder::accept::requests: return b == sd1_request;
    case decoder::accept::responses: return b == sd2_response;
    case decoder::accept::both: return b == sd1_request || b == sd2_response;
    }
    return false;
}

// Independent statement of what parse() must accept.
bool parse_oracle(std::span<const std::uint8_t> in) {
    if (in.size() < 4) return false;
    if (in[0] != 0x02 && in[0] != 0x1D) return false;
    const std::uint8_t typ = in[2];
    static constexpr std::size_t sizes[7] = {14, 6, 16, 8, 18, 10, 12}; // SC01 p.23
    if ((typ & 0x7F) > 6) return false;
    if (in.size() != sizes[typ & 0x7F]) return false;
    std::uint8_t x = 0;
    for (auto b : in) x ^= b;
    return x == 0;
}

void fuzz_parse(std::span<const std::uint8_t> in) {
    const auto r = parse(in);
    FERRULE_CHECK(r.has_value() == parse_oracle(in));
    if (!r) {
        FERRULE_CHECK(r.error() == errc::malformed || r.error() == errc::bad_checksum);
        return;
    }
    FERRULE_CHECK(r->dir == (in[0] == sd1_request ? direction::request : direction::response));
    FERRULE_CHECK(r->address == in[1]);
    FERRULE_CHECK(static_cast<std::uint8_t>(r->type) == in[2]);
    check_roundtrip(*r, in);

    // A fresh decoder after an idle gap frames the same telegram in one go.
    decoder d;
    d.idle();
    const auto s = d.feed(in);
    FERRULE_CHECK(s.what == decoder::status::frame && s.consumed == in.size());
    FERRULE_CHECK(d.frame().size() == in.size() &&
                  std::memcmp(d.frame().data(), in.data(), in.size()) == 0);
}

struct harness {
    decoder dec;
    decoder::accept mode;
    std::span<const std::uint8_t> stream; // every data byte in feeding order
    std::size_t fed = 0;                  // data bytes handed to the decoder so far
    std::size_t frame_bytes = 0;
    std::size_t dropped_by_idle = 0;
    std::size_t frames = 0;
    std::size_t errors = 0;

    explicit harness(decoder::accept m) : dec(m), mode(m) {}

    void idle() {
        if (dec.in_frame()) dropped_by_idle += dec.buffered();
        dec.idle();
        FERRULE_CHECK(!dec.in_frame());
    }

    // Feeds one chunk, which must be the next bytes of `data` (the flattened stream).
    // Returns the step's status; `gap_after_event` calls idle() after a frame / error.
    decoder::step feed(std::span<const std::uint8_t> chunk, const std::uint8_t* flat,
                       bool gap_after_event) {
        const std::size_t skipped_before = dec.skipped();
        const std::size_t buffered_before = dec.in_frame() ? dec.buffered() : 0;
        const auto s = dec.feed(chunk);
        FERRULE_CHECK(s.consumed <= chunk.size());
        if (!chunk.empty()) FERRULE_CHECK(s.consumed >= 1);
        fed += s.consumed;
        FERRULE_CHECK(dec.skipped() >= skipped_before);
        FERRULE_CHECK(dec.skipped() - skipped_before <= buffered_before + s.consumed);
        switch (s.what) {
        case decoder::status::need_more:
            FERRULE_CHECK(s.consumed == chunk.size());
            FERRULE_CHECK(!s.ec);
            break;
        case decoder::status::frame: {
            FERRULE_CHECK(!s.ec);
            FERRULE_CHECK(!dec.in_frame());
            ++frames;
            const auto f = dec.frame();
            FERRULE_CHECK(f.size() >= 4 && f.size() <= max_telegram_size);
            FERRULE_CHECK(is_valid_pdu_type(f[2]));
            FERRULE_CHECK(f.size() == telegram_size(static_cast<pdu_type>(f[2])));
            FERRULE_CHECK(sd_ok(mode, f[0]));
            FERRULE_CHECK(xor_bcc(f.first(f.size() - 1)) == f.back());
            // The frame is exactly the last bytes fed: nothing invented or reordered.
            FERRULE_CHECK(fed >= f.size());
            FERRULE_CHECK(std::memcmp(f.data(), flat + fed - f.size(), f.size()) == 0);
            const auto t = parse(f);
            FERRULE_CHECK(t.has_value());
            FERRULE_CHECK(t->dir ==
                          (f[0] == sd1_request ? direction::request : direction::response));
            check_roundtrip(*t, f);
            frame_bytes += f.size();
            if (gap_after_event) idle();
            break;
        }
        case decoder::status::error:
            FERRULE_CHECK(static_cast<bool>(s.ec));
            FERRULE_CHECK(s.ec == errc::malformed || s.ec == errc::bad_checksum);
            FERRULE_CHECK(!dec.in_frame());
            ++errors;
            if (gap_after_event) idle();
            break;
        }
        check_conservation();
        return s;
    }

    void check_conservation() const {
        const std::size_t pending = dec.in_frame() ? dec.buffered() : 0;
        FERRULE_CHECK(fed == frame_bytes + dec.skipped() + dropped_by_idle + pending);
    }
};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::span<const std::uint8_t> all(data, size);
    fuzz_parse(all);
    if (size == 0) return 0;
    if (size > 1) fuzz_parse(all.subspan(1));

    const std::uint8_t ctl = data[0];
    const auto mode = static_cast<decoder::accept>((ctl & 3u) == 3u ? 2u : (ctl & 3u));
    const unsigned scheme = (ctl >> 2) & 3u;
    const std::size_t chunk = ((ctl >> 4) & 15u) + 1u;
    const auto in = all.subspan(1);

    harness h(mode);
    if (scheme == 0) {
        // Records: [hdr][data...]; the decoder sees the concatenated data bytes.
        std::array<std::uint8_t, 4096> flat{};
        std::size_t nflat = 0;
        std::size_t i = 0;
        while (i < in.size()) {
            const std::uint8_t hdr = in[i++];
            if (hdr & 0x80u) h.idle();
            std::size_t len = hdr & 0x1Fu;
            if (len > in.size() - i) len = in.size() - i;
            if (nflat + len > flat.size()) break;
            std::memcpy(flat.data() + nflat, in.data() + i, len);
            auto rest = std::span<const std::uint8_t>(flat.data() + nflat, len);
            nflat += len;
            i += len;
            while (!rest.empty()) {
                const auto s = h.feed(rest, flat.data(), (hdr & 0x40u) != 0);
                rest = rest.subspan(s.consumed);
            }
        }
    } else {
        const bool gap_after_event = scheme != 3;
        h.idle();
        auto rest = in;
        while (!rest.empty()) {
            const std::size_t n =
                scheme == 2 ? rest.size() : (rest.size() < chunk ? rest.size() : chunk);
            auto piece = rest.first(n);
            while (!piece.empty()) {
                const auto s = h.feed(piece, in.data(), gap_after_event);
                piece = piece.subspan(s.consumed);
            }
            rest = rest.subspan(n);
        }
        if (scheme == 3) {
            // One gap at the start only: a byte after a complete telegram is an error, and
            // after an error everything is skipped, so at most one frame and one error.
            FERRULE_CHECK(h.errors <= 1);
            FERRULE_CHECK(h.frames <= 1);
        }
    }
    h.check_conservation();
    return 0;
}
