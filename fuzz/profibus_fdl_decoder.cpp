// libFuzzer target: profibus::fdl_decoder and encode() (protocols/modbus_profibus.md §B.2,
// §B.3).
//
// Input layout
//   byte 0      bits 0-1 scheme, bits 2-7 chunk size - 1
//   bytes 1..   schemes 0-2: the byte stream; scheme 3: a telegram to build from the bytes
//
// Schemes
//   0  the whole stream in one span
//   1  fixed chunks of (bits 2-7) + 1 bytes
//   2  records: a header byte (bits 0-5: data bytes that follow, bit 6: an idle line after
//      them, finish())
//   3  encode(): what encodes decodes back whole to the same fields
// Schemes 0-2 end with an idle line (finish() until need_more), and the stream is also
// decoded in one piece and byte by byte.
//
// Invariants (violation -> __builtin_trap):
//   * a step consumes at most its input; need_more consumes it all; frame -> no ec; error ->
//     malformed or bad_checksum; the decoder never loops without progress
//   * every telegram: the bytes() reported are exactly the bytes of the stream after those
//     already yielded or skipped, never more than were fed; SD1 6, SD3 14, SD4 3, SC 1, SD2
//     LE + 6 bytes with LEr = LE; ED and FCS right; addresses ≤ 127, SAPs ≤ 63 or no_sap;
//     its data spans bytes() and ends before the FCS
//   * encode() of the telegram (SD2 asked for when it came as SD2) gives bytes() back exactly
//   * conservation: after the idle line, bytes consumed == bytes yielded + skipped()
//   * without idle lines inside the stream, the scheme's chunks, one piece and byte by byte
//     yield the same telegrams (bytes) and the same errors in the same order
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <system_error>
#include <vector>

#include "ferrule/profibus/fdl.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::profibus;
using status = fdl_decoder::status;

// An event of a run: a telegram's bytes, or an error (empty bytes).
struct event {
    std::vector<std::uint8_t> bytes;
    std::error_code ec;
    bool operator==(const event&) const = default;
};

void check_telegram(const fdl_decoder& d) {
    const auto f = d.bytes();
    const telegram& t = d.telegram();
    FERRULE_CHECK(!f.empty() && f.size() <= max_telegram);
    FERRULE_CHECK(t.da <= broadcast_address && t.sa <= broadcast_address);
    FERRULE_CHECK(t.dsap == no_sap || t.dsap <= sap_mask);
    FERRULE_CHECK(t.ssap == no_sap || t.ssap <= sap_mask);
    switch (t.frame) {
    case frame::short_ack: FERRULE_CHECK(f.size() == 1 && f[0] == sc); break;
    case frame::sd4: FERRULE_CHECK(f.size() == 3 && f[0] == sd4); break;
    case frame::sd1: FERRULE_CHECK(f.size() == 6 && f[0] == sd1); break;
    case frame::sd3: FERRULE_CHECK(f.size() == 6 + sd3_data && f[0] == sd3); break;
    case frame::sd2:
        FERRULE_CHECK(f.size() >= 10 && f[0] == sd2 && f[3] == sd2 && f[1] == f[2]);
        FERRULE_CHECK(f[1] >= sd2_min_le && f[1] <= sd2_max_le && f.size() == f[1] + 6u);
        break;
    }
    if (f.size() >= 6) {
        const std::size_t header = f[0] == sd2 ? 4 : 1;
        FERRULE_CHECK(f.back() == ed);
        FERRULE_CHECK(fcs(f.subspan(header, f.size() - header - 2)) == f[f.size() - 2]);
        FERRULE_CHECK(t.da == (f[header] & 0x7F) && t.sa == (f[header + 1] & 0x7F));
        FERRULE_CHECK(t.fc == f[header + 2]);
        FERRULE_CHECK((t.dsap != no_sap) == ((f[header] & address_extension) != 0));
        FERRULE_CHECK((t.ssap != no_sap) == ((f[header + 1] & address_extension) != 0));
        FERRULE_CHECK(t.data.empty() || (t.data.data() >= f.data() + header + 3 &&
                                         t.data.data() + t.data.size() == f.data() + f.size() - 2));
    } else {
        FERRULE_CHECK(t.data.empty() && t.dsap == no_sap && t.ssap == no_sap);
    }
    std::array<std::uint8_t, max_telegram> out{};
    const auto n = encode(t, out, {.sd2_for_8_bytes = t.frame == frame::sd2});
    FERRULE_CHECK(n.has_value());
    FERRULE_CHECK(*n == f.size() && std::memcmp(out.data(), f.data(), *n) == 0);
}

struct harness {
    fdl_decoder dec;
    std::vector<std::uint8_t> fed;
    std::size_t yielded = 0;
    std::vector<event> events;

    void run(fdl_decoder::step s) {
        switch (s.what) {
        case status::need_more: FERRULE_CHECK(!s.ec); break;
        case status::frame: {
            FERRULE_CHECK(!s.ec);
            check_telegram(dec);
            const auto f = dec.bytes();
            const std::size_t start = yielded + dec.skipped();
            FERRULE_CHECK(start + f.size() <= fed.size());
            FERRULE_CHECK(std::memcmp(fed.data() + start, f.data(), f.size()) == 0);
            yielded += f.size();
            events.push_back({{f.begin(), f.end()}, {}});
            break;
        }
        case status::error:
            FERRULE_CHECK(s.ec == errc::malformed || s.ec == errc::bad_checksum);
            events.push_back({{}, s.ec});
            break;
        }
    }

    void feed(std::span<const std::uint8_t> chunk) {
        std::size_t idle = 0;
        fdl_decoder::step s;
        do {
            s = dec.feed(chunk);
            FERRULE_CHECK(s.consumed <= chunk.size());
            if (s.what == status::need_more) FERRULE_CHECK(s.consumed == chunk.size());
            // Steps without input are bounded by the bytes buffered.
            idle = s.consumed == 0 ? idle + 1 : 0;
            FERRULE_CHECK(idle <= 2 * max_telegram + 2);
            fed.insert(fed.end(), chunk.begin(), chunk.begin() + s.consumed);
            chunk = chunk.subspan(s.consumed);
            run(s);
        } while (s.what != status::need_more);
    }

    void idle_line() {
        fdl_decoder::step s;
        std::size_t steps = 0;
        do {
            s = dec.finish();
            FERRULE_CHECK(s.consumed == 0);
            FERRULE_CHECK(++steps <= 2 * max_telegram + 2);
            run(s);
        } while (s.what != status::need_more);
        FERRULE_CHECK(!dec.in_frame());
        FERRULE_CHECK(fed.size() == yielded + dec.skipped());
    }
};

std::vector<event> in_chunks(std::span<const std::uint8_t> in, std::size_t chunk) {
    harness h;
    for (std::size_t pos = 0; pos < in.size(); pos += chunk)
        h.feed(in.subspan(pos, std::min(chunk, in.size() - pos)));
    h.idle_line();
    return h.events;
}

void build_telegram(std::span<const std::uint8_t> in) {
    std::array<std::uint8_t, 8> s{};
    for (std::size_t i = 0; i < s.size() && i < in.size(); ++i) s[i] = in[i];
    const auto data = in.subspan(std::min(in.size(), s.size()));
    telegram t;
    t.frame = static_cast<frame>(s[0] % 5);
    t.da = s[1];
    t.sa = s[2];
    t.fc = s[3];
    t.dsap = s[4] & 1 ? no_sap : s[5];
    t.ssap = s[4] & 2 ? no_sap : s[6];
    t.data = data.first(std::min<std::size_t>(data.size(), s[7]));
    const encode_options o{.sd2_for_8_bytes = (s[4] & 4) != 0};
    std::array<std::uint8_t, max_telegram> out{};
    const auto n = encode(t, out, o);
    if (!n) {
        FERRULE_CHECK(n.error() == errc::invalid_argument);
        return;
    }
    harness h;
    h.feed(std::span<const std::uint8_t>(out.data(), *n));
    h.idle_line();
    FERRULE_CHECK(h.events.size() == 1 && !h.events[0].ec && h.dec.skipped() == 0);
    FERRULE_CHECK(h.events[0].bytes.size() == *n);
    // The decoder's telegram is valid until the next feed(): decode once more to look at it.
    fdl_decoder d;
    const auto st = d.feed(std::span<const std::uint8_t>(out.data(), *n));
    FERRULE_CHECK(st.what == status::frame && st.consumed == *n);
    const telegram& r = d.telegram();
    if (t.frame == frame::short_ack) {
        FERRULE_CHECK(r.frame == frame::short_ack);
        return;
    }
    FERRULE_CHECK(r.da == t.da && r.sa == t.sa);
    if (t.frame == frame::sd4) {
        FERRULE_CHECK(r.frame == frame::sd4);
        return;
    }
    FERRULE_CHECK(r.fc == t.fc && r.dsap == t.dsap && r.ssap == t.ssap);
    FERRULE_CHECK(r.data.size() == t.data.size() &&
                  std::memcmp(r.data.data(), t.data.data(), t.data.size()) == 0);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const std::uint8_t ctl = data[0];
    const unsigned scheme = ctl & 3u;
    const std::size_t chunk = (ctl >> 2) + 1u;
    const std::span<const std::uint8_t> in(data + 1, size - 1);
    if (in.size() > 4096) return 0;

    if (scheme == 3) {
        build_telegram(in);
        return 0;
    }
    const auto whole = in_chunks(in, in.size() + 1);
    FERRULE_CHECK(in_chunks(in, 1) == whole);
    if (scheme == 1) FERRULE_CHECK(in_chunks(in, chunk) == whole);
    if (scheme != 2) return 0;
    harness h;
    bool idle_inside = false;
    std::size_t i = 0;
    while (i < in.size()) {
        const std::uint8_t header = in[i++];
        std::size_t len = header & 0x3Fu;
        if (len > in.size() - i) len = in.size() - i;
        h.feed(in.subspan(i, len));
        i += len;
        if (header & 0x40u) {
            h.idle_line();
            idle_inside = true;
        }
    }
    h.idle_line();
    if (!idle_inside) {
        // The records' payload without their headers, in one piece, yields the same.
        std::vector<std::uint8_t> payload = h.fed;
        FERRULE_CHECK(in_chunks(payload, payload.size() + 1) == h.events);
    }
    return 0;
}
