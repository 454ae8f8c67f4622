// libFuzzer target: modbus::tcp_decoder and encode_tcp().
//
// Input layout
//   byte 0      bits 0-1 scheme, bits 2-7 chunk size - 1
//   bytes 1..   schemes 0-2: the byte stream; scheme 3: transaction (2), unit (1), PDU
//
// Schemes
//   0  the whole stream in one span
//   1  fixed chunks of (bits 2-7) + 1 bytes
//   2  records: a header byte (bits 0-5: data bytes that follow) and its data bytes
//   3  encode_tcp(): what encodes comes out of a decoder whole, fields unchanged
//
// Invariants (violation -> __builtin_trap):
//   * a step consumes at most its input; need_more consumes it all; frame -> no ec; error ->
//     errc::malformed; steps without input are bounded
//   * every frame: protocol id 0, length field = unit + PDU, PDU 1 … 253 bytes, exactly the
//     bytes of the stream after those already framed or skipped
//   * conservation: bytes consumed == bytes in frames + skipped() + bytes still buffered
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "ferrule/core/bytes.hpp"
#include "ferrule/modbus/tcp.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::modbus;
using status = tcp_decoder::status;

struct harness {
    tcp_decoder dec;
    std::array<std::uint8_t, 4096> fed{};
    std::size_t consumed = 0;
    std::size_t frame_bytes = 0;
    std::uint16_t last_transaction = 0; // of the last frame
    std::uint8_t last_unit = 0;
    std::array<std::uint8_t, max_pdu> last_pdu{};

    void on_frame() {
        const auto adu = dec.adu();
        FERRULE_CHECK(adu.size() >= mbap_size + 1 && adu.size() <= max_tcp_adu);
        FERRULE_CHECK(load_be16(&adu[2]) == 0);
        FERRULE_CHECK(load_be16(&adu[4]) == adu.size() - 6);
        FERRULE_CHECK(dec.transaction() == load_be16(&adu[0]));
        FERRULE_CHECK(dec.unit() == adu[6]);
        FERRULE_CHECK(dec.pdu().size() == adu.size() - mbap_size);
        const std::size_t start = frame_bytes + dec.skipped();
        FERRULE_CHECK(start + adu.size() <= consumed);
        FERRULE_CHECK(std::memcmp(fed.data() + start, adu.data(), adu.size()) == 0);
        frame_bytes += adu.size();
        last_transaction = dec.transaction();
        last_unit = dec.unit();
        std::memcpy(last_pdu.data(), dec.pdu().data(), dec.pdu().size());
    }

    void feed(std::span<const std::uint8_t> chunk) {
        std::size_t idle = 0;
        tcp_decoder::step s;
        do {
            s = dec.feed(chunk);
            FERRULE_CHECK(s.consumed <= chunk.size());
            if (s.what == status::need_more) FERRULE_CHECK(s.consumed == chunk.size() && !s.ec);
            idle = s.consumed == 0 ? idle + 1 : 0;
            FERRULE_CHECK(idle <= 2 * max_tcp_adu + 2);
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
        const std::size_t buffered = consumed - frame_bytes - dec.skipped();
        FERRULE_CHECK(buffered <= max_tcp_adu);
        FERRULE_CHECK(dec.in_frame() == (buffered > 0));
    }
};

void build(std::span<const std::uint8_t> in) {
    if (in.size() < 3) return;
    const auto transaction = load_be16(in.data());
    const std::uint8_t unit = in[2];
    const auto pdu = in.subspan(3);
    std::array<std::uint8_t, max_tcp_adu> out{};
    const auto n = encode_tcp(transaction, unit, pdu, out);
    if (!n) {
        FERRULE_CHECK(n.error() == errc::invalid_argument);
        FERRULE_CHECK(pdu.empty() || pdu.size() > max_pdu);
        return;
    }
    FERRULE_CHECK(*n == mbap_size + pdu.size());
    harness h;
    h.feed(std::span<const std::uint8_t>(out.data(), *n));
    FERRULE_CHECK(h.frame_bytes == *n && h.dec.skipped() == 0);
    FERRULE_CHECK(h.last_transaction == transaction && h.last_unit == unit);
    FERRULE_CHECK(std::memcmp(h.last_pdu.data(), pdu.data(), pdu.size()) == 0);
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const std::uint8_t ctl = data[0];
    const unsigned scheme = ctl & 3u;
    const std::size_t chunk = ((ctl >> 2) & 63u) + 1u;
    const std::span<const std::uint8_t> in(data + 1, size - 1);
    if (in.size() > 2048) return 0;
    if (scheme == 3) {
        build(in);
        return 0;
    }
    harness h;
    if (scheme == 0) {
        h.feed(in);
    } else if (scheme == 1) {
        for (std::size_t pos = 0; pos < in.size(); pos += chunk)
            h.feed(in.subspan(pos, std::min(chunk, in.size() - pos)));
    } else {
        std::size_t i = 0;
        while (i < in.size()) {
            std::size_t len = in[i++] & 0x3Fu;
            if (len > in.size() - i) len = in.size() - i;
            h.feed(in.subspan(i, len));
            i += len;
        }
    }
    return 0;
}
