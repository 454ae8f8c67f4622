// libFuzzer target: memobus::message_decoder (the 218 header framing of a TCP stream),
// parse_message(), parse_request() and encode_command().
//
// Input layout
//   byte 0      bit 0 data order (0 big-endian, 1 little-endian), bit 1 chunking scheme,
//               bits 2-7 chunk size - 1
//   bytes 1..   the byte stream
//
// Chunking schemes
//   0  fixed chunks of (bits 2-7) + 1 bytes
//   1  records: a header byte (bits 0-5: data bytes that follow) and its data bytes
// The same stream is also fed in one piece and byte by byte.
//
// Invariants (violation -> __builtin_trap):
//   * a step consumes at most its input; need_more consumes it all; frame -> no ec; error ->
//     errc::malformed; steps without input are bounded
//   * every message: a known type (0x11, 0x19, 0x12), size == the header's total length,
//     commands and responses: size == 12 + 2 + the MEMOBUS length; exactly the bytes of the
//     stream after those already yielded or skipped; header() and body() agree with it;
//     parse_message() accepts it with the same header
//   * at the end of the stream: bytes fed == bytes yielded + skipped() + bytes still buffered,
//     and the buffered bytes (the stream's tail) can still begin a message: a known type and,
//     from 12 bytes on, a total length in its limits beyond them (the MEMOBUS length is
//     checked once the whole message is in)
//   * one piece, byte by byte and the chunking of the input yield the same messages and
//     skip the same number of bytes
//   * commands and responses: parse_request() fails with a memobus::device_category() code
//     01, 02 or 03, or gives a request that encode_command() (same data order, serial and
//     channels) encodes to the same MEMOBUS part and header fields; SFC 09…0E: but for
//     the spare byte, which parse_request() ignores and encode_command() sets to 0
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "ferrule/core/bytes.hpp"
#include "ferrule/memobus/header.hpp"
#include "ferrule/memobus/message.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::memobus;
using status = message_decoder::status;
using octets = std::vector<std::uint8_t>;

constexpr std::size_t max_input = 8192;

bool known_type(std::uint8_t t) {
    return t == 0x11 || t == 0x19 || t == 0x12;
}

// parse_request() on a command or response, and the request it gives encoded again, its data
// (raw) as words / bits for encode_command().
void check_reencode(std::span<const std::uint8_t> m, data_order order) {
    const auto body = m.subspan(header_size);
    const auto req = parse_request(body, order);
    if (!req) {
        FERRULE_CHECK(std::error_code(req.error()).category() == device_category());
        const int code = req.error().value();
        FERRULE_CHECK(code >= 1 && code <= 3);
        return;
    }
    request r = *req;
    std::array<std::uint16_t, 2 * std::size_t{max_write_random}> words{};
    std::size_t n_words = 0;
    switch (r.function) {
    case sfc::write_holding_registers:
    case sfc::write_holding_registers_ext:
    case sfc::read_holding_registers_random: n_words = r.count; break;
    case sfc::write_holding_registers_random: n_words = 2u * r.count; break;
    case sfc::write_coils: r.bits = r.raw; break;
    default: break;
    }
    if (n_words > 0) FERRULE_CHECK(r.raw.size() == 2 * n_words);
    for (std::size_t i = 0; i < n_words; ++i) words[i] = word_at(r.function, r.raw, i, order);
    r.words = std::span<const std::uint16_t>(words.data(), n_words);

    const header h = load_header(m.data());
    std::array<std::uint8_t, max_message> out{};
    const auto n = encode_command(r, h.serial, out, order, h.destination_channel, h.source_channel);
    FERRULE_CHECK(n.has_value());
    FERRULE_CHECK(*n == m.size());
    const header e = load_header(out.data());
    FERRULE_CHECK(e.type == command_type::command);
    FERRULE_CHECK(e.serial == h.serial && e.destination_channel == h.destination_channel &&
                  e.source_channel == h.source_channel && e.total == h.total);
    // parse_request() ignores the spare byte of SFC 09…0E (§3.3: "not used") and
    // encode_command() writes 0 there: the one byte that may differ.
    constexpr std::size_t spare = header_size + length_size + 3;
    if (is_extended(r.function)) {
        FERRULE_CHECK(out[spare] == 0);
        out[spare] = m[spare];
    }
    FERRULE_CHECK(std::memcmp(out.data() + header_size, body.data(), body.size()) == 0);
}

struct harness {
    data_order order = data_order::big_endian;
    message_decoder dec;
    std::array<std::uint8_t, max_input> fed{};
    std::size_t consumed = 0;
    std::size_t frame_bytes = 0;
    std::vector<octets> messages;

    void on_frame() {
        const auto m = dec.message();
        FERRULE_CHECK(m.size() >= header_size && m.size() <= max_message);
        FERRULE_CHECK(known_type(m[0]));
        const header h = dec.header();
        FERRULE_CHECK(static_cast<std::uint8_t>(h.type) == m[0]);
        FERRULE_CHECK(h.total == m.size() && load_le16(&m[6]) == m.size());
        FERRULE_CHECK(h.serial == m[1] && h.destination_channel == m[2] &&
                      h.source_channel == m[3]);
        const bool memobus = h.type != command_type::general;
        if (memobus) {
            FERRULE_CHECK(m.size() >= header_size + length_size + 1);
            FERRULE_CHECK(m.size() == header_size + length_size + load_le16(&m[header_size]));
        }
        FERRULE_CHECK(dec.body().size() == m.size() - header_size);
        FERRULE_CHECK(dec.body().data() == m.data() + header_size);
        const std::size_t start = frame_bytes + dec.skipped();
        FERRULE_CHECK(start + m.size() <= consumed);
        FERRULE_CHECK(std::memcmp(fed.data() + start, m.data(), m.size()) == 0);
        frame_bytes += m.size();

        const auto parsed = parse_message(m);
        FERRULE_CHECK(parsed.has_value());
        FERRULE_CHECK(parsed->type == h.type && parsed->serial == h.serial &&
                      parsed->destination_channel == h.destination_channel &&
                      parsed->source_channel == h.source_channel && parsed->total == h.total);
        if (memobus) check_reencode(m, order);
        messages.emplace_back(m.begin(), m.end());
    }

    void feed(std::span<const std::uint8_t> chunk) {
        std::size_t idle = 0;
        message_decoder::step s;
        do {
            s = dec.feed(chunk);
            FERRULE_CHECK(s.consumed <= chunk.size());
            if (s.what == status::need_more) FERRULE_CHECK(s.consumed == chunk.size() && !s.ec);
            idle = s.consumed == 0 ? idle + 1 : 0;
            FERRULE_CHECK(idle <= 2 * max_message + 2);
            std::memcpy(fed.data() + consumed, chunk.data(), s.consumed);
            consumed += s.consumed;
            chunk = chunk.subspan(s.consumed);
            if (s.what == status::frame) {
                FERRULE_CHECK(!s.ec);
                on_frame();
            } else if (s.what == status::error) {
                FERRULE_CHECK(s.ec == errc::malformed);
            }
        } while (s.what != status::need_more);
    }

    // The stream has ended: what is neither yielded nor skipped is the stream's tail, still
    // buffered, and it can still be the beginning of a message.
    void finish(std::size_t stream_size) {
        FERRULE_CHECK(consumed == stream_size);
        FERRULE_CHECK(frame_bytes + dec.skipped() <= consumed);
        const std::size_t buffered = consumed - frame_bytes - dec.skipped();
        FERRULE_CHECK(dec.in_message() == (buffered > 0));
        if (buffered == 0) return;
        const auto tail = std::span<const std::uint8_t>(fed.data() + consumed - buffered, buffered);
        FERRULE_CHECK(known_type(tail[0]));
        if (tail.size() < header_size) return;
        const std::size_t total = load_le16(&tail[6]);
        const std::size_t least = tail[0] == 0x12 ? header_size : header_size + length_size + 1;
        FERRULE_CHECK(total >= least && total <= max_message && total > buffered);
    }
};

void same(const harness& a, const harness& b) {
    FERRULE_CHECK(a.messages == b.messages);
    FERRULE_CHECK(a.dec.skipped() == b.dec.skipped());
    FERRULE_CHECK(a.dec.in_message() == b.dec.in_message());
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const std::uint8_t ctl = data[0];
    const std::span<const std::uint8_t> in(data + 1, size - 1);
    if (in.size() > max_input) return 0;
    const data_order order = ctl & 1u ? data_order::little_endian : data_order::big_endian;
    const bool records = ctl & 2u;
    const std::size_t chunk = ((ctl >> 2) & 63u) + 1u;

    // The stream is the input after byte 0, or the data bytes of the records alone.
    static std::array<std::uint8_t, max_input> joined{};
    std::size_t stream = 0;
    harness chunked;
    chunked.order = order;
    if (!records) {
        for (std::size_t pos = 0; pos < in.size(); pos += chunk)
            chunked.feed(in.subspan(pos, std::min(chunk, in.size() - pos)));
        std::memcpy(joined.data(), in.data(), in.size());
        stream = in.size();
    } else {
        std::size_t i = 0;
        while (i < in.size()) {
            std::size_t len = in[i++] & 0x3Fu;
            if (len > in.size() - i) len = in.size() - i;
            chunked.feed(in.subspan(i, len));
            std::memcpy(joined.data() + stream, in.data() + i, len);
            stream += len;
            i += len;
        }
    }
    chunked.finish(stream);
    const std::span<const std::uint8_t> bytes(joined.data(), stream);

    harness whole;
    whole.order = order;
    whole.feed(bytes);
    whole.finish(stream);
    same(chunked, whole);

    harness bytewise;
    bytewise.order = order;
    for (std::size_t pos = 0; pos < stream; ++pos) bytewise.feed(bytes.subspan(pos, 1));
    bytewise.finish(stream);
    same(whole, bytewise);
    return 0;
}
