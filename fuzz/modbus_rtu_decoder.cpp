// libFuzzer target: modbus::rtu_decoder (responses and requests), the PDU codec
// (parse_request, request_exception, encode_request, parse_response, expected lengths).
//
// Input layout
//   byte 0      bit 0 accept mode (0 responses, 1 requests), bits 1-2 scheme, bits 3-7
//               chunk size - 1
//   bytes 1..   schemes 0-2: the byte stream; scheme 3: a request to build from the bytes
//
// Schemes
//   0  the whole stream in one span
//   1  fixed chunks of (bits 3-7) + 1 bytes
//   2  records: a header byte (bits 0-5: data bytes that follow, bit 6: silence after them)
//   3  encode_request(): what encodes parses back to the same bytes, deserves no exception,
//      and has the length expected_request_length() predicts; wrapped by encode_rtu it comes
//      out of a requests decoder whole
// Schemes 0-2 end with a silence (finish() until need_more).
//
// Invariants (violation -> __builtin_trap):
//   * a step consumes at most its input; need_more consumes it all; frame -> no ec; error ->
//     malformed or bad_checksum; a step that consumes nothing is a frame or an error, and
//     the decoder never loops without progress
//   * every frame: 4 … 256 bytes with CRC 0 over it, exactly the bytes of the stream after
//     those already framed or skipped; its PDU has the length its mode predicts (or, at a
//     silence in requests mode, one that cannot be predicted)
//   * a request frame that parse_request() accepts encodes back byte for byte; one it
//     refuses deserves an exception (request_exception() != 0)
//   * parse_response() against a request of the same function code gives a response or an
//     error of ferrule::errc / modbus::device_category(), never reads outside the PDU
//   * conservation: after the silence, bytes consumed == bytes in frames + skipped()
//   * rtu_receiver, the sessions' framing, pushed the same bytes one at a time and told the
//     same silences, finds the same frames in the same order as a decoder of its mode (both
//     are front-ends of one framing rule, detail::scan_rtu: this checks what each front-end
//     adds, the decoder's stop at every event and the receiver's byte-wise pushes)
//     (requests: this one; responses: basic_rtu_decoder<all_functions,
//     rtu_frames::responses>, which like it frames no response of the codes outside
//     `function`), and holds nothing after a silence
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "ferrule/core/checksum.hpp"
#include "ferrule/modbus/pdu.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::modbus;
using accept = rtu_decoder::accept;
using status = rtu_decoder::status;

void check_request(std::span<const std::uint8_t> pdu) {
    const auto r = parse_request(pdu);
    const std::uint8_t ex = request_exception(pdu);
    if (!r) {
        FERRULE_CHECK(r.error() == errc::malformed);
        FERRULE_CHECK(ex != 0 || pdu.empty());
        return;
    }
    FERRULE_CHECK(ex == 0);
    std::array<std::uint8_t, max_pdu> out{};
    const auto n = encode_request(*r, out);
    FERRULE_CHECK(n.has_value() && *n == pdu.size());
    FERRULE_CHECK(std::memcmp(out.data(), pdu.data(), pdu.size()) == 0);
    FERRULE_CHECK(expected_request_length(pdu) == pdu.size());
}

void check_response(std::span<const std::uint8_t> pdu, std::span<const std::uint8_t> seed) {
    if (pdu.empty()) return;
    // A request of the response's function code, its fields from the seed bytes.
    std::array<std::uint8_t, 8> s{};
    for (std::size_t i = 0; i < s.size() && i < seed.size(); ++i) s[i] = seed[i];
    request r;
    r.function = static_cast<function>(pdu[0] & 0x7F);
    r.address = static_cast<std::uint16_t>(s[0] << 8 | s[1]);
    r.quantity = static_cast<std::uint16_t>(s[2] << 8 | s[3]);
    r.value = static_cast<std::uint16_t>(s[4] << 8 | s[5]);
    r.read_device_id_code = s[6];
    r.data = std::span<const std::uint8_t>(s).first(s[7] % 3);
    const auto p = parse_response(r, pdu);
    if (!p) {
        const auto& cat = std::error_code(p.error()).category();
        FERRULE_CHECK(cat == errc_category() || cat == device_category());
        return;
    }
    FERRULE_CHECK(p->data.empty() || (p->data.data() >= pdu.data() &&
                                      p->data.data() + p->data.size() <= pdu.data() + pdu.size()));
}

using frame_list = std::vector<std::vector<std::uint8_t>>; // address + PDU each

// What an rtu_receiver hands its session.
struct receiver_log {
    frame_list frames;
    bool on_frame(std::uint8_t address, std::span<const std::uint8_t> pdu) {
        std::vector<std::uint8_t> f{address};
        f.insert(f.end(), pdu.begin(), pdu.end());
        frames.push_back(std::move(f));
        return true;
    }
    void on_garbage(errc why) {
        FERRULE_CHECK(why == errc::malformed || why == errc::bad_checksum);
    }
};

// The responses decoder that frames what rtu_receiver<responses> frames, fed like `dec`.
struct response_reference {
    using decoder = basic_rtu_decoder<all_functions, rtu_frames::responses>;
    decoder dec;
    frame_list frames;

    void take(const decoder::step& s) {
        if (s.what != decoder::status::frame) return;
        std::vector<std::uint8_t> f{dec.address()};
        f.insert(f.end(), dec.pdu().begin(), dec.pdu().end());
        frames.push_back(std::move(f));
    }
    void feed(std::span<const std::uint8_t> chunk) {
        decoder::step s;
        do {
            s = dec.feed(chunk);
            chunk = chunk.subspan(s.consumed);
            take(s);
        } while (s.what != decoder::status::need_more);
    }
    void silence() {
        decoder::step s;
        do {
            s = dec.finish();
            take(s);
        } while (s.what != decoder::status::need_more);
    }
};

struct harness {
    rtu_decoder dec;
    accept mode;
    std::array<std::uint8_t, 4096> fed{};
    std::size_t consumed = 0;
    std::size_t frame_bytes = 0;
    frame_list frames; // dec's, in requests mode
    rtu_receiver<rtu_frames::requests> request_rx;
    rtu_receiver<rtu_frames::responses> response_rx;
    receiver_log rx_log;
    response_reference response_ref;

    explicit harness(accept m) : dec(m), mode(m) {}

    // The receiver of this mode takes the bytes the decoder took; both have found the same
    // frames so far.
    void compare(std::span<const std::uint8_t> taken, bool at_silence) {
        if (mode == accept::requests) {
            for (const std::uint8_t b : taken) request_rx.push(b, rx_log);
            if (at_silence) request_rx.finish(rx_log);
            FERRULE_CHECK(rx_log.frames == frames);
            if (at_silence) FERRULE_CHECK(request_rx.empty());
        } else {
            for (const std::uint8_t b : taken) response_rx.push(b, rx_log);
            response_ref.feed(taken);
            if (at_silence) {
                response_rx.finish(rx_log);
                response_ref.silence();
            }
            FERRULE_CHECK(rx_log.frames == response_ref.frames);
            if (at_silence) FERRULE_CHECK(response_rx.empty());
        }
    }

    void on_frame(bool at_silence) {
        const auto adu = dec.adu();
        FERRULE_CHECK(adu.size() >= 4 && adu.size() <= max_rtu_adu);
        FERRULE_CHECK(crc16_modbus(adu) == 0);
        FERRULE_CHECK(dec.address() == adu[0]);
        FERRULE_CHECK(dec.pdu().size() == adu.size() - 3);
        const std::size_t start = frame_bytes + dec.skipped();
        FERRULE_CHECK(start + adu.size() <= consumed);
        FERRULE_CHECK(std::memcmp(fed.data() + start, adu.data(), adu.size()) == 0);
        frame_bytes += adu.size();
        const auto pdu = dec.pdu();
        if (mode == accept::requests) {
            frames.emplace_back(adu.begin(), adu.end() - 2);
            const std::size_t want = expected_request_length(pdu);
            FERRULE_CHECK(want == pdu.size() || (at_silence && want == no_frame));
            check_request(pdu);
        } else {
            FERRULE_CHECK(expected_response_length(pdu) == pdu.size());
            check_response(pdu, std::span<const std::uint8_t>(fed).first(consumed));
        }
    }

    void run(rtu_decoder::step s, bool at_silence) {
        switch (s.what) {
        case status::need_more: FERRULE_CHECK(!s.ec); break;
        case status::frame:
            FERRULE_CHECK(!s.ec);
            on_frame(at_silence);
            break;
        case status::error:
            FERRULE_CHECK(s.ec == errc::malformed || s.ec == errc::bad_checksum);
            break;
        }
    }

    void feed(std::span<const std::uint8_t> chunk) {
        const std::span<const std::uint8_t> all = chunk;
        std::size_t idle = 0;
        rtu_decoder::step s;
        do {
            s = dec.feed(chunk);
            FERRULE_CHECK(s.consumed <= chunk.size());
            if (s.what == status::need_more) FERRULE_CHECK(s.consumed == chunk.size());
            // Steps without input are bounded by the bytes buffered.
            idle = s.consumed == 0 ? idle + 1 : 0;
            FERRULE_CHECK(idle <= 2 * max_rtu_adu + 2);
            std::memcpy(fed.data() + consumed, chunk.data(), s.consumed);
            consumed += s.consumed;
            chunk = chunk.subspan(s.consumed);
            run(s, false);
        } while (s.what != status::need_more);
        compare(all, false);
    }

    void silence() {
        rtu_decoder::step s;
        std::size_t steps = 0;
        do {
            s = dec.finish();
            FERRULE_CHECK(s.consumed == 0);
            FERRULE_CHECK(++steps <= 2 * max_rtu_adu + 2);
            run(s, true);
        } while (s.what != status::need_more);
        FERRULE_CHECK(!dec.in_frame());
        FERRULE_CHECK(consumed == frame_bytes + dec.skipped());
        compare({}, true);
    }
};

void build_request(std::span<const std::uint8_t> in) {
    auto take = [&in]() -> std::uint8_t {
        if (in.empty()) return 0;
        const std::uint8_t b = in[0];
        in = in.subspan(1);
        return b;
    };
    auto take16 = [&take]() {
        const std::uint8_t hi = take();
        return static_cast<std::uint16_t>(hi << 8 | take());
    };
    request r;
    r.function = static_cast<function>(take());
    r.address = take16();
    r.quantity = take16();
    r.write_address = take16();
    r.write_quantity = take16();
    r.value = take16();
    r.mei_type = take();
    r.read_device_id_code = take();
    r.object_id = take();
    const std::uint8_t unit = take();
    const std::size_t len = take();
    r.data = in.first(std::min(in.size(), len));

    std::array<std::uint8_t, max_pdu> pdu{};
    const auto n = encode_request(r, pdu);
    if (!n) {
        FERRULE_CHECK(n.error() == errc::invalid_argument);
        return;
    }
    const std::span<const std::uint8_t> p(pdu.data(), *n);
    FERRULE_CHECK(expected_request_length(p) == *n);
    FERRULE_CHECK(request_exception(p) == 0);
    check_request(p);
    std::array<std::uint8_t, max_rtu_adu> adu{};
    const auto m = encode_rtu(unit, p, adu);
    FERRULE_CHECK(m.has_value() && *m == *n + 3);
    harness h(accept::requests);
    h.feed(std::span<const std::uint8_t>(adu.data(), *m));
    FERRULE_CHECK(h.frame_bytes == *m && h.dec.skipped() == 0);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const std::uint8_t ctl = data[0];
    const accept mode = (ctl & 1u) ? accept::requests : accept::responses;
    const unsigned scheme = (ctl >> 1) & 3u;
    const std::size_t chunk = ((ctl >> 3) & 31u) + 1u;
    const std::span<const std::uint8_t> in(data + 1, size - 1);
    if (in.size() > 2048) return 0;
    check_request(in);
    check_response(in, in);
    (void)expected_response_length(in);

    if (scheme == 3) {
        build_request(in);
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
            const std::uint8_t header = in[i++];
            std::size_t len = header & 0x3Fu;
            if (len > in.size() - i) len = in.size() - i;
            h.feed(in.subspan(i, len));
            i += len;
            if (header & 0x40u) h.silence();
        }
    }
    h.silence();
    return 0;
}
