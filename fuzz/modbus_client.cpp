// libFuzzer target: the Modbus client session (modbus::client, RTU or TCP) against random
// responses and random timing.
//
// The input (read through FuzzedDataProvider) picks a client_config — link, serial format,
// response timeout, inter-frame gap, inter-byte timeout, turnaround, retries, echo
// suppression — then up to four transactions: a request of any function code with fields
// near and beyond the spec's limits, to a unit that may be 0 (broadcast) or beyond 247. Each
// runs for a bounded number of steps, each one of: next(now); advance virtual time (a
// little, a lot, or to the deadline last announced); deliver random bytes; deliver a
// response built from the request (a normal one, an exception, another unit, a stale TCP
// transaction, a corrupted byte, our own request as an echo, garbage in front; split in
// two chunks); a transport error; a second start while busy; clear(). Then it is drained
// with no input at all.
//
// Invariants (violation -> __builtin_trap):
//   * start() fails with errc::busy exactly while busy; otherwise it fails exactly when
//     encode_request() refuses the request, the RTU unit is beyond 247, or a broadcast is not
//     a write (FC 5, 6, 15, 16), and then with that error
//   * next(): `wait` deadlines lie in the future; asked again with nothing new, next() gives
//     the same answer; a send is request_bytes(): RTU unit + pdu() + a CRC that checks, TCP
//     an MBAP header with transaction(), protocol 0, the length and the unit, then pdu()
//   * at most 1 + retries sends per transaction; attempts() <= 1 + retries, always
//   * outcome at `done`: success -> response_pdu() is a response that parse_response()
//     accepts for the request, and reply() is what it gives; an exception -> a 2-byte
//     response_pdu() with the exception bit; no_response_expected exactly for broadcasts and
//     FC 8 sub-function 04; any other failure -> an empty response_pdu()
//   * with no input the session reaches `done` after a bounded number of deadlines
//   * stats: transactions = starts that succeeded; succeeded, failed and broadcasts match
//     the outcomes seen
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "ferrule/core/checksum.hpp"
#include "ferrule/modbus/client.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::modbus;
using namespace std::chrono_literals;

constexpr function all_codes[] = {
    function::read_coils,
    function::read_discrete_inputs,
    function::read_holding_registers,
    function::read_input_registers,
    function::write_single_coil,
    function::write_single_register,
    function::diagnostics,
    function::write_multiple_coils,
    function::write_multiple_registers,
    function::read_write_multiple_registers,
    function::encapsulated_interface,
};

bool is_write(function f) {
    return f == function::write_single_coil || f == function::write_single_register ||
           f == function::write_multiple_coils || f == function::write_multiple_registers;
}

struct harness {
    FuzzedDataProvider& in;
    client_config cfg;
    client c;
    time_point now{};

    std::uint32_t started = 0, succeeded = 0, failed = 0, broadcasts = 0;

    bool active = false; // a started transaction not yet seen `done`
    request sent{};
    std::array<std::uint8_t, max_pdu> sent_data{};
    std::uint8_t unit = 0;
    bool no_reply = false;
    unsigned sends = 0;
    bool have_wait = false; // the last next() said wait, and nothing happened since
    time_point wait_deadline{};

    harness(FuzzedDataProvider& p, const client_config& cf) : in(p), cfg(cf), c(cf) {}

    void check_always() {
        FERRULE_CHECK(c.attempts() <= 1 + cfg.retries);
        const client_stats& s = c.stats();
        FERRULE_CHECK(s.transactions == started);
        // The session counts an outcome when it happens; the harness when it sees `done`.
        FERRULE_CHECK(s.succeeded >= succeeded && s.succeeded <= succeeded + 1);
        FERRULE_CHECK(s.failed >= failed && s.failed <= failed + 1);
        FERRULE_CHECK(s.broadcasts >= broadcasts);
    }

    // ---- starting a transaction ------------------------------------------------------

    std::uint16_t quantity_for(function f) {
        switch (in.ConsumeIntegralInRange<int>(0, 3)) {
        case 0: return in.ConsumeIntegralInRange<std::uint16_t>(1, 4);
        case 1:
            return f == function::read_coils || f == function::read_discrete_inputs ||
                           f == function::write_multiple_coils
                       ? 2000
                       : 125;
        case 2: return 0;
        default: return in.ConsumeIntegral<std::uint16_t>();
        }
    }

    void start_transaction() {
        if (active && !c.busy()) call_next(); // see the outcome before it is replaced
        request r;
        const std::uint8_t k = in.ConsumeIntegral<std::uint8_t>();
        r.function = k < 240 ? all_codes[k % std::size(all_codes)]
                             : static_cast<function>(in.ConsumeIntegral<std::uint8_t>());
        r.address = in.ConsumeBool() ? in.ConsumeIntegral<std::uint16_t>()
                                     : in.ConsumeIntegralInRange<std::uint16_t>(0, 16);
        r.quantity = quantity_for(r.function);
        r.write_address = in.ConsumeIntegral<std::uint16_t>() % 32;
        r.write_quantity = in.ConsumeIntegralInRange<std::uint16_t>(0, 3);
        r.value = in.ConsumeBool() ? (in.ConsumeBool() ? coil_on : coil_off)
                                   : in.ConsumeIntegral<std::uint16_t>();
        r.read_device_id_code = in.ConsumeIntegralInRange<std::uint8_t>(0, 5);
        r.object_id = in.ConsumeIntegral<std::uint8_t>();
        if (in.ConsumeIntegral<std::uint8_t>() >= 250)
            r.mei_type = in.ConsumeIntegral<std::uint8_t>();
        // Data of the size the function needs, or of another.
        std::size_t want = 0;
        if (r.function == function::diagnostics) want = 2;
        if (r.function == function::write_multiple_coils) want = packed_size(r.quantity);
        if (r.function == function::write_multiple_registers) want = 2u * r.quantity;
        if (r.function == function::read_write_multiple_registers) want = 2u * r.write_quantity;
        if (in.ConsumeIntegral<std::uint8_t>() >= 240)
            want = in.ConsumeIntegralInRange<std::size_t>(0, 8);
        std::array<std::uint8_t, 512> data{};
        want = std::min(want, data.size());
        for (std::size_t i = 0; i < want; ++i) data[i] = in.ConsumeIntegral<std::uint8_t>();
        r.data = {data.data(), want};
        if (r.function == function::diagnostics && in.ConsumeBool())
            r.value = static_cast<std::uint16_t>(diag_sub::force_listen_only);
        const std::uint8_t u = in.ConsumeIntegral<std::uint8_t>();
        const std::uint8_t to = u < 200 ? static_cast<std::uint8_t>(u % 4) : u; // 0 = broadcast

        const bool busy_before = c.busy();
        std::array<std::uint8_t, max_pdu> scratch{};
        const auto encoded = encode_request(r, scratch);
        const bool broadcast = cfg.rtu && to == broadcast_address;
        const std::error_code ec = c.start(to, r);
        have_wait = false;
        if (busy_before) {
            FERRULE_CHECK(ec == errc::busy);
            return;
        }
        if (!encoded) {
            FERRULE_CHECK(ec == encoded.error() || (cfg.rtu && to > max_unit_address) ||
                          (broadcast && !is_write(r.function)));
            FERRULE_CHECK(ec);
            return;
        }
        const bool refused =
            (cfg.rtu && to > max_unit_address) || (broadcast && !is_write(r.function));
        FERRULE_CHECK(!ec == !refused);
        if (ec) {
            FERRULE_CHECK(ec == errc::invalid_argument);
            return;
        }
        ++started;
        check_always();
        FERRULE_CHECK(c.busy());
        FERRULE_CHECK(c.attempts() == 0);
        FERRULE_CHECK(std::equal(c.pdu().begin(), c.pdu().end(), scratch.begin()) &&
                      c.pdu().size() == *encoded);
        active = true;
        sent = r;
        std::copy(r.data.begin(), r.data.end(), sent_data.begin());
        sent.data = {sent_data.data(), r.data.size()};
        unit = to;
        no_reply =
            broadcast || (r.function == function::diagnostics &&
                          r.value == static_cast<std::uint16_t>(diag_sub::force_listen_only));
        sends = 0;
    }

    // ---- next() ---------------------------------------------------------------------

    void check_send(std::span<const std::uint8_t> bytes) {
        FERRULE_CHECK(active);
        ++sends;
        FERRULE_CHECK(sends <= 1 + cfg.retries);
        FERRULE_CHECK(bytes.data() == c.request_bytes().data() &&
                      bytes.size() == c.request_bytes().size());
        const auto pdu = c.pdu();
        if (cfg.rtu) {
            FERRULE_CHECK(bytes.size() == pdu.size() + 3);
            FERRULE_CHECK(bytes[0] == unit);
            FERRULE_CHECK(crc16_modbus(bytes) == 0);
            FERRULE_CHECK(std::equal(pdu.begin(), pdu.end(), bytes.begin() + 1));
        } else {
            FERRULE_CHECK(bytes.size() == pdu.size() + 7);
            FERRULE_CHECK(load_be16(&bytes[0]) == c.transaction());
            FERRULE_CHECK(load_be16(&bytes[2]) == 0);
            FERRULE_CHECK(load_be16(&bytes[4]) == pdu.size() + 1);
            FERRULE_CHECK(bytes[6] == unit);
            FERRULE_CHECK(std::equal(pdu.begin(), pdu.end(), bytes.begin() + 7));
        }
    }

    void check_outcome() {
        FERRULE_CHECK(!c.busy());
        const std::error_code ec = c.error();
        const auto pdu = c.response_pdu();
        if (ec == errc::no_response_expected) {
            FERRULE_CHECK(no_reply);
            FERRULE_CHECK(sends == 1);
            ++broadcasts;
        } else {
            FERRULE_CHECK(!no_reply || ec); // a transport error can end it too
        }
        if (!ec) {
            ++succeeded;
            FERRULE_CHECK(!pdu.empty());
            response r;
            FERRULE_CHECK(!parse_response(sent, pdu, r));
            const response& got = c.reply();
            FERRULE_CHECK(got.function == r.function && got.address == r.address &&
                          got.value == r.value && got.quantity == r.quantity &&
                          got.data.data() == r.data.data() && got.data.size() == r.data.size());
        } else if (ec.category() == device_category()) {
            ++failed;
            FERRULE_CHECK(pdu.size() == 2 &&
                          pdu[0] == (static_cast<std::uint8_t>(sent.function) | exception_flag));
            FERRULE_CHECK(pdu[1] == ec.value());
        } else {
            if (ec != errc::no_response_expected) ++failed;
            FERRULE_CHECK(pdu.empty());
        }
        active = false;
    }

    session_action call_next() {
        const session_action a = c.next(now);
        if (have_wait && now < wait_deadline)
            FERRULE_CHECK(a.what == session_action::kind::wait && a.deadline == wait_deadline);
        have_wait = false;
        switch (a.what) {
        case session_action::kind::wait:
            FERRULE_CHECK(a.deadline > now);
            have_wait = true;
            wait_deadline = a.deadline;
            break;
        case session_action::kind::send:
            check_send(a.bytes);
            FERRULE_CHECK(a.discard_input == cfg.discard_stale_input);
            break;
        case session_action::kind::done:
            if (active) check_outcome();
            break;
        case session_action::kind::idle: FERRULE_CHECK(!active); break;
        }
        check_always();
        return a;
    }

    // ---- input -----------------------------------------------------------------------

    void receive(std::span<const std::uint8_t> bytes) {
        c.on_receive(bytes, now);
        have_wait = false;
        check_always();
    }

    // A response to the request (or a near miss), wrapped for the link, in one or two chunks.
    void respond() {
        std::array<std::uint8_t, max_pdu> pdu{};
        std::size_t n = 0;
        const auto fc = static_cast<std::uint8_t>(sent.function);
        const auto req = c.pdu();
        switch (in.ConsumeIntegralInRange<int>(0, 3)) {
        case 0: { // a normal response
            pdu[0] = fc;
            switch (sent.function) {
            case function::read_coils:
            case function::read_discrete_inputs:
            case function::read_holding_registers:
            case function::read_input_registers:
            case function::read_write_multiple_registers: {
                const bool bits = sent.function == function::read_coils ||
                                  sent.function == function::read_discrete_inputs;
                const std::size_t bytes = std::min<std::size_t>(
                    bits ? packed_size(sent.quantity) : 2u * sent.quantity, 250);
                pdu[1] = static_cast<std::uint8_t>(bytes);
                for (std::size_t i = 0; i < bytes; ++i)
                    pdu[2 + i] = in.ConsumeIntegral<std::uint8_t>();
                n = 2 + bytes;
                break;
            }
            case function::encapsulated_interface:
                pdu[1] = mei_read_device_id;
                pdu[2] = sent.read_device_id_code;
                pdu[3] = 0x81;
                n = 7; // no more, next 0, no objects
                break;
            default: // echoes: FC 5, 6, 8 whole, FC 15, 16 address and quantity
                n = std::min<std::size_t>(req.size(), 5);
                std::copy(req.begin(), req.begin() + n, pdu.begin());
                break;
            }
            break;
        }
        case 1: // an exception
            pdu[0] = static_cast<std::uint8_t>(fc | exception_flag);
            pdu[1] = in.ConsumeIntegral<std::uint8_t>();
            n = 2;
            break;
        case 2: // our own request, as an adapter that hears itself hands it back
            n = req.size();
            std::copy(req.begin(), req.end(), pdu.begin());
            break;
        default: // any PDU
            n = in.ConsumeIntegralInRange<std::size_t>(1, 12);
            for (std::size_t i = 0; i < n; ++i) pdu[i] = in.ConsumeIntegral<std::uint8_t>();
            break;
        }
        std::uint8_t to = unit;
        if (in.ConsumeIntegral<std::uint8_t>() >= 230) to = in.ConsumeIntegral<std::uint8_t>();
        std::array<std::uint8_t, 8 + max_tcp_adu> adu{};
        std::size_t front = 0;
        if (in.ConsumeIntegral<std::uint8_t>() >= 230) {
            front = in.ConsumeIntegralInRange<std::size_t>(1, 6);
            for (std::size_t i = 0; i < front; ++i) adu[i] = in.ConsumeIntegral<std::uint8_t>();
        }
        const std::span<std::uint8_t> out(adu.data() + front, adu.size() - front);
        std::uint16_t tid = c.transaction();
        if (in.ConsumeIntegral<std::uint8_t>() >= 230) tid = in.ConsumeIntegral<std::uint16_t>();
        const auto size = cfg.rtu ? encode_rtu(to, {pdu.data(), n}, out)
                                  : encode_tcp(tid, to, {pdu.data(), n}, out);
        if (!size) return;
        std::size_t total = front + *size;
        if (in.ConsumeIntegral<std::uint8_t>() >= 220) // a damaged byte
            adu[in.ConsumeIntegralInRange<std::size_t>(0, total - 1)] ^=
                in.ConsumeIntegralInRange<std::uint8_t>(1, 255);
        const std::size_t split = in.ConsumeIntegralInRange<std::size_t>(0, total);
        if (split > 0) receive({adu.data(), split});
        if (in.ConsumeBool()) now += in.ConsumeIntegralInRange<std::int64_t>(0, 3'000'000) * 1ns;
        if (split < total) receive({adu.data() + split, total - split});
    }

    void step() {
        switch (in.ConsumeIntegralInRange<int>(0, 9)) {
        case 0:
        case 1: call_next(); break;
        case 2: now += in.ConsumeIntegralInRange<std::int64_t>(0, 2'000'000) * 1ns; break;
        case 3:
            if (have_wait) now = wait_deadline;
            call_next();
            break;
        case 4: now += 1s; break;
        case 5: {
            std::array<std::uint8_t, 16> b{};
            const std::size_t n = in.ConsumeIntegralInRange<std::size_t>(1, b.size());
            for (std::size_t i = 0; i < n; ++i) b[i] = in.ConsumeIntegral<std::uint8_t>();
            receive({b.data(), n});
            break;
        }
        case 6:
        case 7:
            if (active) respond();
            break;
        case 8:
            if (in.ConsumeIntegral<std::uint8_t>() >= 200) {
                c.on_transport_error(ferrule::error(errc::timeout));
                have_wait = false;
                if (active) call_next();
            } else {
                start_transaction(); // while busy: refused
            }
            break;
        default:
            if (active && !c.busy()) call_next(); // see the outcome before clear() drops it
            c.clear();
            have_wait = false;
            call_next();
            break;
        }
    }

    // With no input, `done` comes after a bounded number of deadlines: per attempt the gap
    // before the request, the response deadline and the silence after a broken frame.
    void drain() {
        const unsigned bound = 4 * (1 + cfg.retries) + 4;
        for (unsigned i = 0; i < bound && active; ++i) {
            const session_action a = call_next();
            if (a.what == session_action::kind::wait) now = a.deadline;
        }
        FERRULE_CHECK(!active);
    }
};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    FuzzedDataProvider in(data, size);
    client_config cfg;
    cfg.rtu = in.ConsumeBool();
    constexpr std::uint32_t bauds[] = {9600, 19200, 115200};
    cfg.format.baud = bauds[in.ConsumeIntegralInRange<int>(0, 2)];
    cfg.inter_frame_gap = in.ConsumeBool() ? t35(cfg.format) : duration::zero();
    cfg.response_timeout = in.ConsumeIntegralInRange<std::int64_t>(1, 50) * 1ms;
    cfg.inter_byte_timeout = in.ConsumeBool()
                                 ? cfg.format.chars_time(in.ConsumeIntegralInRange<int>(1, 4))
                                 : duration::zero();
    cfg.turnaround = in.ConsumeIntegralInRange<std::int64_t>(0, 100) * 1ms;
    cfg.retries = in.ConsumeIntegralInRange<unsigned>(0, 3);
    cfg.discard_stale_input = in.ConsumeBool();
    cfg.echo_suppression = in.ConsumeBool();
    harness h(in, cfg);
    for (int t = 0; t < 4 && in.remaining_bytes() > 0; ++t) {
        h.start_transaction();
        for (int s = 0; s < 48 && in.remaining_bytes() > 0; ++s) h.step();
        h.drain();
        h.c.clear();
    }
    return 0;
}
