// libFuzzer target: lecom::frame_decoder (all three accept modes), parse_frame() and
// encode().
//
// Input layout
//   byte 0      bits 0-1 accept mode (0 replies, 1 requests, 2/3 both), bits 2-3 scheme,
//               bits 4-7 chunk size - 1
//   bytes 1..   schemes 0-2: the byte stream; scheme 3: a frame to build (see build_frame)
//
// Schemes
//   0  the whole stream in one span, fed until consumed
//   1  fixed chunks of (bits 4-7) + 1 bytes
//   2  records: a header byte (bits 0-4: number of data bytes that follow) and its data
//      bytes, fed as one chunk; the decoder sees the data bytes only
//   3  encode(): a frame made of the input's fields must encode within max_frame_length,
//      or be refused with invalid_argument; what encodes parses back to the same frame and
//      comes out of a decoder of its side whole. encode_value() writes the value exactly
//      when the factories of value.hpp could have made it (else 0); for a request,
//      is_valid_request() and encode_request() agree with encode(), byte for byte
// Schemes 0-2 end with finish().
//
// Invariants (violation -> __builtin_trap):
//   * a step consumes at most its chunk; need_more consumes it all; frame -> no ec, error
//     -> errc::malformed; a step that consumes nothing is a frame or an error, and the next
//     step moves
//   * every frame: 1 … max_frame_length bytes, exactly the last bytes consumed (nothing
//     invented or reordered), starting with a byte its mode accepts (requests: EOT; replies:
//     STX, ACK, NAK, EOT)
//   * every frame re-parses: parse_frame() gives a frame (requests mode: a request; replies
//     mode: a reply) or errc::malformed / errc::bad_checksum, never anything else
//   * a parsed frame encodes again (a RECEIVE to a group address excepted, which encode()
//     refuses): byte for byte when the text is canonical (no leading zeros, no "-0"),
//     otherwise to bytes that parse to the same frame
//   * conservation: after finish(), bytes consumed == bytes in frames + skipped()
//   * parse_frame() on the raw input obeys the same rules as on a framed telegram
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "ferrule/lecom/frame.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::lecom;
using accept = frame_decoder::accept;
using status = frame_decoder::status;

// Same telegram: the fields its kind carries, up to how many decimals a VD was written with.
bool same_frame(const frame& a, const frame& b) {
    if (a.kind != b.kind) return false;
    if (is_request(a.kind) && a.address != b.address) return false;
    const bool coded =
        a.kind != frame_kind::ack && a.kind != frame_kind::nak && a.kind != frame_kind::eot;
    if (coded && a.code != b.code) return false;
    if (a.kind != frame_kind::send && a.kind != frame_kind::data) return true;
    if (a.value.format != b.value.format) return false;
    switch (a.value.format) {
    case value_format::decimal: return a.value.fixed == b.value.fixed;
    case value_format::hex: return a.value.hex == b.value.hex && a.value.digits == b.value.digits;
    case value_format::string:
    case value_format::octets:
        return a.value.size == b.value.size &&
               std::memcmp(a.value.bytes.data(), b.value.bytes.data(), a.value.size) == 0;
    }
    return false;
}

// The value text of a SEND or data telegram: between the code field and ETX.
std::span<const std::uint8_t> value_text(const frame& f, std::span<const std::uint8_t> raw) {
    const std::size_t head = (f.kind == frame_kind::send ? 4 : 1) + f.code.length();
    return raw.subspan(head, raw.size() - head - 2);
}

// A VD text that encode_value() writes the same way: no leading zero, no "-0…".
bool canonical_decimal(std::span<const std::uint8_t> t, std::int32_t fixed) {
    const std::size_t sign = !t.empty() && t[0] == '-';
    if (sign && fixed == 0) return false;
    return !(t.size() > sign + 1 && t[sign] == '0' && t[sign + 1] != '.');
}

void check_parsed(std::span<const std::uint8_t> raw, accept mode, bool framed) {
    const auto p = parse_frame(raw);
    if (!p) {
        FERRULE_CHECK(p.error() == errc::malformed || p.error() == errc::bad_checksum);
        return;
    }
    const frame& f = *p;
    FERRULE_CHECK(is_request(f.kind) == (raw.size() > 1 && raw[0] == eot));
    if (framed && mode == accept::requests) FERRULE_CHECK(is_request(f.kind));
    if (framed && mode == accept::replies) FERRULE_CHECK(!is_request(f.kind));
    if (is_request(f.kind)) FERRULE_CHECK(is_valid_address(f.address));

    std::array<std::uint8_t, max_frame_length> out{};
    const auto n = encode(f, out);
    if (f.kind == frame_kind::receive && is_group_address(f.address)) {
        FERRULE_CHECK(!n && n.error() == errc::invalid_argument);
        return;
    }
    FERRULE_CHECK(n.has_value());
    const std::span<const std::uint8_t> again(out.data(), *n);
    const bool has_value = f.kind == frame_kind::send || f.kind == frame_kind::data;
    const bool canonical = !has_value || f.value.format != value_format::decimal ||
                           canonical_decimal(value_text(f, raw), f.value.fixed);
    if (canonical) {
        FERRULE_CHECK(again.size() == raw.size());
        FERRULE_CHECK(std::memcmp(again.data(), raw.data(), raw.size()) == 0);
    }
    const auto back = parse_frame(again);
    FERRULE_CHECK(back.has_value() && same_frame(*back, f));
    // Too small a buffer is an error, never an overrun.
    const auto small = encode(f, std::span<std::uint8_t>(out.data(), *n - 1));
    FERRULE_CHECK(!small && small.error() == errc::buffer_too_small);
}

bool starts_ok(accept mode, std::uint8_t b) {
    const bool reply_start = b == stx || b == ack || b == nak || b == eot;
    switch (mode) {
    case accept::replies: return reply_start;
    case accept::requests: return b == eot;
    case accept::both: return reply_start;
    }
    return false;
}

struct harness {
    frame_decoder dec;
    accept mode;
    std::array<std::uint8_t, 4096> fed{}; // every byte consumed, in order
    std::size_t consumed = 0;
    std::size_t frame_bytes = 0;
    bool stalled = false; // the last step consumed nothing

    explicit harness(accept m) : dec(m), mode(m) {}

    void on_frame() {
        const auto f = dec.frame();
        FERRULE_CHECK(!f.empty() && f.size() <= max_frame_length);
        FERRULE_CHECK(consumed >= f.size());
        FERRULE_CHECK(std::memcmp(f.data(), fed.data() + consumed - f.size(), f.size()) == 0);
        FERRULE_CHECK(starts_ok(mode, f[0]));
        if (mode == accept::requests) FERRULE_CHECK(f.size() >= 5);
        frame_bytes += f.size();
        check_parsed(f, mode, true);
    }

    void feed(std::span<const std::uint8_t> chunk) {
        while (!chunk.empty()) {
            const auto s = dec.feed(chunk);
            FERRULE_CHECK(s.consumed <= chunk.size());
            if (s.consumed == 0) {
                // A cut at the chunk's first byte, or a lone EOT decided by it (both mode).
                FERRULE_CHECK(s.what != status::need_more && !stalled);
                stalled = true;
            } else {
                stalled = false;
            }
            std::memcpy(fed.data() + consumed, chunk.data(), s.consumed);
            consumed += s.consumed;
            chunk = chunk.subspan(s.consumed);
            switch (s.what) {
            case status::need_more: FERRULE_CHECK(chunk.empty() && !s.ec); break;
            case status::frame:
                FERRULE_CHECK(!s.ec);
                on_frame();
                break;
            case status::error:
                FERRULE_CHECK(s.ec == errc::malformed);
                FERRULE_CHECK(!dec.in_frame());
                break;
            }
        }
    }

    void finish() {
        const auto s = dec.finish();
        switch (s.what) {
        case status::frame: on_frame(); break;
        case status::error: FERRULE_CHECK(s.ec == errc::malformed); break;
        case status::need_more: FERRULE_CHECK(!s.ec); break;
        }
        FERRULE_CHECK(!dec.in_frame());
        FERRULE_CHECK(consumed == frame_bytes + dec.skipped());
    }
};

// Could the factories of value.hpp have made `v`? (A model of its own, not is_encodable().)
bool factory_made(const value& v) {
    switch (v.format) {
    case value_format::decimal: return v.digits <= value::max_decimals;
    case value_format::hex:
        return (v.digits == 2 || v.digits == 4 || v.digits == 8) &&
               (v.digits == 8 || v.hex >> (4 * v.digits) == 0);
    case value_format::string:
        if (v.size > value::max_string) return false;
        for (std::size_t i = 0; i < v.size; ++i)
            if (v.bytes[i] < 0x20 || v.bytes[i] > 0x7E) return false;
        return true;
    case value_format::octets: return v.size <= value::max_octets;
    }
    return false;
}

// Scheme 3: a frame from the input's bytes, with fields inside and outside their ranges.
void build_frame(std::span<const std::uint8_t> in) {
    auto take = [&in]() -> std::uint8_t {
        if (in.empty()) return 0;
        const std::uint8_t b = in[0];
        in = in.subspan(1);
        return b;
    };
    frame f;
    f.kind = static_cast<frame_kind>(take() % 8);
    f.address = take();
    const std::uint8_t code_hi = take();
    f.code.code = static_cast<std::uint16_t>(code_hi << 8 | take());
    f.code.subcode = take();
    f.code.extended = take() & 1;
    value& v = f.value;
    v.format = static_cast<value_format>(take() % 5); // 4: no such format
    std::uint32_t word = 0;
    for (int i = 0; i < 4; ++i) word = word << 8 | take();
    v.fixed = static_cast<std::int32_t>(word);
    v.hex = word;
    v.digits = take();
    if (v.digits >= 16) v.digits %= 10;
    v.size = take() % 32; // beyond bytes.size() is never read: encode() refuses it first
    for (auto& b : v.bytes) b = take();

    std::array<std::uint8_t, max_value_length> text{};
    const std::size_t text_size = encode_value(v, text.data());
    FERRULE_CHECK((text_size != 0) == factory_made(v) && text_size <= max_value_length);

    std::array<std::uint8_t, max_frame_length + 8> out{};
    const auto n = encode(f, out);
    if (is_request(f.kind)) {
        const value* sent = f.kind == frame_kind::send ? &f.value : nullptr;
        std::array<std::uint8_t, max_request_length> direct{};
        const std::size_t m = encode_request(f.address, f.code, sent, direct.data());
        FERRULE_CHECK(is_valid_request(f.address, f.code, sent) == n.has_value());
        FERRULE_CHECK((m != 0) == n.has_value());
        if (n) FERRULE_CHECK(m == *n && std::memcmp(direct.data(), out.data(), m) == 0);
    }
    if (!n) {
        FERRULE_CHECK(n.error() == errc::invalid_argument);
        return;
    }
    FERRULE_CHECK(*n <= max_frame_length);
    const std::span<const std::uint8_t> raw(out.data(), *n);
    const auto p = parse_frame(raw);
    FERRULE_CHECK(p.has_value());
    FERRULE_CHECK(same_frame(*p, f));
    if (f.value.format == value_format::decimal &&
        (f.kind == frame_kind::send || f.kind == frame_kind::data))
        FERRULE_CHECK(p->value.digits >= needed_decimals(f.value.fixed));
    harness h(is_request(f.kind) ? accept::requests : accept::replies);
    h.feed(raw);
    h.finish();
    FERRULE_CHECK(h.frame_bytes == raw.size() && h.dec.skipped() == 0);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::span<const std::uint8_t> all(data, size);
    if (size == 0) return 0;
    const std::uint8_t ctl = data[0];
    const auto mode = static_cast<accept>((ctl & 3u) == 3u ? 2u : (ctl & 3u));
    const unsigned scheme = (ctl >> 2) & 3u;
    const std::size_t chunk = ((ctl >> 4) & 15u) + 1u;
    const auto in = all.subspan(1);
    if (in.size() > 2048) return 0;
    check_parsed(in, mode, false);

    if (scheme == 3) {
        build_frame(in);
        return 0;
    }
    harness h(mode);
    if (scheme == 0) {
        h.feed(in);
    } else if (scheme == 1) {
        for (std::size_t pos = 0; pos < in.size(); pos += chunk)
            h.feed(in.subspan(pos, std::min(chunk, in.size() - pos)));
    } else {
        std::size_t i = 0;
        while (i < in.size()) {
            std::size_t len = in[i++] & 0x1Fu;
            if (len > in.size() - i) len = in.size() - i;
            h.feed(in.subspan(i, len));
            i += len;
        }
    }
    h.finish();
    return 0;
}
