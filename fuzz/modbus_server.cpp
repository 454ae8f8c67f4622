// libFuzzer target: the Modbus server session (modbus::server over a memory_model) fed
// arbitrary request bytes over RTU or TCP, in virtual time.
//
// The input (read through FuzzedDataProvider) picks the transport, the unit ids answered,
// the baud rate and processing time, then a bounded number of steps, each one of: deliver
// random bytes, deliver a request built from the input (every function code the server
// knows, valid or not, to a unit in the set, another one or broadcast; in one or two chunks;
// maybe with a flipped byte), let time pass (less or more than t3.5), or call next(now).
// Then it is drained with no input. Seeds: fuzz/corpus/modbus_server/.
//
// Invariants (violation -> __builtin_trap):
//   * next(): `wait` deadlines lie in the future; a send only once reply_at() has come
//   * every reply is one well-formed response ADU: RTU frames it whole with a good CRC
//     (rtu_decoder, responses), from a unit of the set, never 0; TCP frames it whole (MBAP
//     protocol id 0, the length right); its PDU is a normal response of the length its
//     function code predicts, or an exception (FC | 0x80, code 1-4, 6, 7)
//   * a request built here and delivered whole after a silence (RTU) or on a clean stream
//     (TCP: no random bytes and no held bytes dropped yet) is answered by the next reply: same unit
//     (TCP: transaction id too), and parse_response() accepts it as the answer to that request or
//     gives the exception
//   * broadcasts and requests for other units are never answered
//   * with no input the session becomes idle within a bounded amount of virtual time
#include <fuzzer/FuzzedDataProvider.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/modbus/memory_model.hpp"
#include "ferrule/modbus/pdu.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/server.hpp"
#include "ferrule/modbus/tcp.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::modbus;
using namespace std::chrono_literals;

using model = memory_model<64, 32, 64, 16>;

constexpr std::uint8_t functions[] = {1, 2, 3, 4, 5, 6, 8, 15, 16, 23, 43, 7, 0x41, 0, 0x83};

struct harness {
    FuzzedDataProvider& in;
    server_config cfg;
    server<model> s;
    time_point now{};
    bool rtu = true;

    // The request the next reply must answer.
    bool expecting = false;
    request expected{};
    std::array<std::uint8_t, max_pdu> expected_pdu{};
    std::uint8_t expected_unit = 0;
    std::uint16_t expected_transaction = 0;
    bool tcp_clean = true; // TCP: no random bytes yet, so framing is known
    std::uint16_t transaction = 0;

    harness(FuzzedDataProvider& p, const server_config& c)
        : in(p), cfg(c), s(c), rtu(c.transport == transport::rtu) {}

    std::uint8_t pick_unit() {
        switch (in.ConsumeIntegralInRange<unsigned>(0, 4)) {
        case 0: return 0;
        case 1: return in.ConsumeIntegral<std::uint8_t>();
        default: return in.ConsumeBool() ? 1 : 2;
        }
    }

    // A request PDU from the input: encodable ones through encode_request, else raw bytes.
    std::size_t build(std::span<std::uint8_t> out, request& r, bool& valid) {
        std::array<std::uint8_t, 64> data{};
        r = request{};
        r.function =
            static_cast<function>(functions[in.ConsumeIntegralInRange<std::size_t>(0, 14)]);
        r.address = in.ConsumeBool() ? in.ConsumeIntegralInRange<std::uint16_t>(0, 70)
                                     : in.ConsumeIntegral<std::uint16_t>();
        r.quantity = in.ConsumeBool() ? in.ConsumeIntegralInRange<std::uint16_t>(0, 30)
                                      : in.ConsumeIntegral<std::uint16_t>();
        r.write_address = in.ConsumeIntegralInRange<std::uint16_t>(0, 70);
        r.write_quantity = in.ConsumeIntegralInRange<std::uint16_t>(0, 30);
        r.value = in.ConsumeBool() ? std::uint16_t{0xFF00} : in.ConsumeIntegral<std::uint16_t>();
        if (r.function == function::diagnostics)
            r.value = in.ConsumeIntegralInRange<std::uint16_t>(0, 20);
        r.read_device_id_code = in.ConsumeIntegralInRange<std::uint8_t>(0, 5);
        r.object_id = in.ConsumeIntegralInRange<std::uint8_t>(0, 4);
        for (auto& b : data) b = in.ConsumeIntegral<std::uint8_t>();
        std::size_t n = 0;
        switch (r.function) {
        case function::diagnostics: n = 2; break;
        case function::write_multiple_coils: n = packed_size(r.quantity); break;
        case function::write_multiple_registers: n = 2u * r.quantity; break;
        case function::read_write_multiple_registers: n = 2u * r.write_quantity; break;
        default: break;
        }
        if (n <= data.size()) r.data = std::span<const std::uint8_t>(data.data(), n);
        const auto size = encode_request(r, out);
        valid = size.has_value();
        if (valid) {
            // r.data must outlive this call: point it into the encoded PDU.
            const auto parsed = parse_request(out.first(*size));
            FERRULE_CHECK(parsed.has_value());
            r = *parsed;
            return *size;
        }
        const std::size_t raw = in.ConsumeIntegralInRange<std::size_t>(1, 12);
        out[0] = static_cast<std::uint8_t>(r.function);
        for (std::size_t i = 1; i < raw; ++i) out[i] = in.ConsumeIntegral<std::uint8_t>();
        return raw;
    }

    void deliver(std::span<const std::uint8_t> bytes) {
        if (bytes.empty()) return;
        if (rtu) now += cfg.format.chars_time(bytes.size());
        const auto overflowed = s.stats().overflowed;
        s.on_receive(bytes, now);
        // TCP holds one request's worth behind a pending reply (a driver reads no more until
        // it is sent) and drops what is beyond: the stream's framing is then unknown.
        if (s.stats().overflowed != overflowed) tcp_clean = false;
    }

    void send_request() {
        std::array<std::uint8_t, max_pdu> pdu{};
        request r;
        bool valid = false;
        const std::size_t n = build(pdu, r, valid);
        const std::uint8_t unit = pick_unit();
        std::array<std::uint8_t, max_tcp_adu> adu{};
        const auto pdu_bytes = std::span<const std::uint8_t>(pdu.data(), n);
        const auto size = rtu ? encode_rtu(unit, pdu_bytes, adu)
                              : encode_tcp(++transaction, unit, pdu_bytes, adu);
        if (!size) return;
        const bool flip = in.ConsumeIntegral<std::uint8_t>() < 24;
        if (flip) {
            const auto at = in.ConsumeIntegralInRange<std::size_t>(0, *size - 1);
            adu[at] ^= static_cast<std::uint8_t>(in.ConsumeIntegralInRange<unsigned>(1, 255));
        }
        // RTU: a silence first, so that nothing buffered joins the request.
        if (rtu) {
            now += t35(cfg.format) + 1us;
            (void)call_next();
        }
        // Clean: the request alone decides the next reply. RTU: it drops a pending reply;
        // TCP: it waits behind pending ones, so nothing may be pending.
        const bool clean =
            valid && !flip &&
            (rtu ? unit != 0 && cfg.units.contains(unit) : tcp_clean && s.wake_at() == never);
        if (clean) {
            expecting = true;
            std::copy_n(pdu.begin(), n, expected_pdu.begin());
            expected = *parse_request(std::span<const std::uint8_t>(expected_pdu.data(), n));
            expected_unit = unit;
            expected_transaction = transaction;
        } else if (rtu) {
            expecting = false;
        }
        if (flip && !rtu) tcp_clean = false;
        const std::size_t split =
            in.ConsumeBool() ? in.ConsumeIntegralInRange<std::size_t>(0, *size) : *size;
        deliver(std::span<const std::uint8_t>(adu.data(), split));
        deliver(std::span<const std::uint8_t>(adu.data() + split, *size - split));
    }

    void send_random() {
        std::array<std::uint8_t, 48> buf{};
        const std::size_t n = in.ConsumeIntegralInRange<std::size_t>(1, buf.size());
        for (std::size_t i = 0; i < n; ++i) buf[i] = in.ConsumeIntegral<std::uint8_t>();
        // They may form a frame, join the pending request or break the TCP framing.
        expecting = false;
        if (!rtu) tcp_clean = false;
        deliver(std::span<const std::uint8_t>(buf.data(), n));
    }

    void check_pdu(std::span<const std::uint8_t> pdu) {
        FERRULE_CHECK(!pdu.empty());
        if (pdu[0] & exception_flag) {
            FERRULE_CHECK(pdu.size() == 2);
            const std::uint8_t code = pdu[1];
            FERRULE_CHECK((code >= 1 && code <= 4) || code == 6 || code == 7);
        } else {
            FERRULE_CHECK(expected_response_length(pdu) == pdu.size());
        }
    }

    void on_send(std::span<const std::uint8_t> bytes) {
        std::span<const std::uint8_t> pdu;
        std::uint8_t unit = 0;
        std::uint16_t tid = 0;
        if (rtu) {
            rtu_decoder d;
            const auto st = d.feed(bytes);
            FERRULE_CHECK(st.what == rtu_decoder::status::frame && st.consumed == bytes.size());
            unit = d.address();
            FERRULE_CHECK(unit != 0 && cfg.units.contains(unit));
            check_pdu(d.pdu());
            pdu = bytes.subspan(1, bytes.size() - 3);
        } else {
            tcp_decoder d;
            const auto st = d.feed(bytes);
            FERRULE_CHECK(st.what == tcp_decoder::status::frame && st.consumed == bytes.size());
            unit = d.unit();
            tid = d.transaction();
            check_pdu(d.pdu());
            pdu = bytes.subspan(mbap_size);
        }
        if (!expecting) return;
        expecting = false;
        FERRULE_CHECK(unit == expected_unit);
        if (!rtu) FERRULE_CHECK(tid == expected_transaction);
        const auto parsed = parse_response(expected, pdu);
        if (pdu[0] & exception_flag) {
            FERRULE_CHECK(!parsed &&
                          std::error_code(parsed.error()).category() == device_category());
            FERRULE_CHECK((pdu[0] & 0x7F) == static_cast<std::uint8_t>(expected.function));
        } else {
            FERRULE_CHECK(parsed.has_value());
        }
    }

    session_action call_next() {
        const time_point due = s.reply_at();
        const auto a = s.next(now);
        switch (a.what) {
        case session_action::kind::wait: FERRULE_CHECK(a.deadline > now); break;
        case session_action::kind::send:
            FERRULE_CHECK(due == never || now >= due);
            on_send(a.bytes);
            break;
        case session_action::kind::done: FERRULE_CHECK(false); break;
        case session_action::kind::idle: FERRULE_CHECK(s.reply_at() == never); break;
        }
        return a;
    }

    void step() {
        switch (in.ConsumeIntegralInRange<unsigned>(0, 9)) {
        case 0:
        case 1:
        case 2: send_request(); break;
        case 3: send_random(); break;
        case 4:
            now += std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 4000));
            break;
        default: (void)call_next(); break;
        }
    }

    // No input: idle within t3.5 + processing time per reply and held request (at most
    // held_capacity / 8 of them: the shortest TCP request has 8 bytes).
    void drain() {
        constexpr int most = 2 + server<model>::held_capacity / 8;
        const time_point limit = now + most * (t35(cfg.format) + cfg.processing_time);
        for (int i = 0; i < 2 * most; ++i) {
            const auto a = call_next();
            if (a.what == session_action::kind::idle) return;
            if (a.what == session_action::kind::wait) now = a.deadline;
            FERRULE_CHECK(now <= limit);
        }
        FERRULE_CHECK(false);
    }
};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    FuzzedDataProvider in(data, size);
    server_config cfg;
    cfg.transport = in.ConsumeBool() ? transport::rtu : transport::tcp;
    constexpr std::uint32_t bauds[] = {19200, 9600, 1200, 115200};
    cfg.format.baud = bauds[in.ConsumeIntegralInRange<std::size_t>(0, 3)];
    cfg.processing_time =
        std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 3000));
    cfg.units = {1};
    if (in.ConsumeBool()) cfg.units.add(2);
    if (in.ConsumeBool()) cfg.units.add(in.ConsumeIntegral<std::uint8_t>());

    harness h(in, cfg);
    for (int i = 0; i < 64 && in.remaining_bytes() > 0; ++i) h.step();
    h.drain();
    return 0;
}
