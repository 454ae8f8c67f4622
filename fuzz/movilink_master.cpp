// libFuzzer target: the MOVILINK master session (movilink::master) against random replies.
//
// The input (read through FuzzedDataProvider) picks a master_config, then up to four
// transactions: address (single, group, 254, broadcast, undefined, local, or any byte),
// PDU type (documented or any byte), process-data exchange or parameter service, PO words.
// Each transaction runs for a bounded number of steps, each one of: next(now), advance
// virtual time (small, large, or to the deadline last announced), deliver random bytes,
// deliver a reply built from the request (wrong ADR/TYP, stale handshake, device error,
// a corrupted byte, trailing garbage, SD1 instead of SD2; split into chunks with gaps),
// a transport error, a second start while busy, or clear(). Then it is drained with no
// input at all. Seeds: fuzz/corpus/movilink_master/ (golden vectors of movilink.md §4).
//
// Invariants (violation -> __builtin_trap):
//   * start_*() succeeds exactly when the arguments are valid and the session is neither
//     busy nor latched; errc::busy / errc::fault_latched only when that is the case
//   * next(): `wait` deadlines lie in the future; with nothing received, asking again
//     before the announced deadline gives the same answer; no send and no `done` while a
//     reply is awaited and its deadline (end of request + response_timeout) has not passed
//   * every send is the request: the bytes parse as SD1 + the request's ADR / TYP / PO /
//     parameter channel (cyclic PARAM services toggle the handshake bit per address),
//     discard_input follows the config, sends per transaction <= 1 + retries +
//     handshake_polls; with realistic timing a send keeps >= start_pause after the last
//     byte on the bus and >= broadcast_spacing after a request that gets no reply
//   * attempts() <= 1 + retries, always
//   * with no input the session reaches `done` within a bounded amount of virtual time
//   * outcome: success -> the reply is the last telegram received, SD2, the request's TYP
//     and ADR (any ADR for 254), echoed handshake for cyclic PARAM services, no error bit,
//     consecutive_failures() == 0; group / broadcast -> no_response_expected after one
//     send; a device error -> the reply's error word; any other failure -> retries used up,
//     fault latched, or a device error that is not retried
//   * fault_latched() -> fault_threshold != 0 and consecutive_failures() >= threshold
//   * stats: transactions / succeeded / failed match what the harness saw
#include <fuzzer/FuzzedDataProvider.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "ferrule/movilink/master.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::movilink;
using namespace std::chrono_literals;

constexpr pdu_type all_types[] = {
    pdu_type::param_1pd,   pdu_type::pd1,
    pdu_type::param_2pd,   pdu_type::pd2,
    pdu_type::param_3pd,   pdu_type::pd3,
    pdu_type::param,       pdu_type::param_1pd_acyclic,
    pdu_type::pd1_acyclic, pdu_type::param_2pd_acyclic,
    pdu_type::pd2_acyclic, pdu_type::param_3pd_acyclic,
    pdu_type::pd3_acyclic, pdu_type::param_acyclic,
};
constexpr std::uint8_t interesting_addresses[] = {0,   1,   2,   15,  99,  100, 101,
                                                  150, 199, 254, 255, 253, 200, 252};

struct harness {
    FuzzedDataProvider& in;
    master_config cfg;
    master m;
    bool realistic = true; // bytes never arrive while our own request is on the wire
    time_point now{};

    // Bus model.
    time_point bus_free{};             // end of our last request on the wire
    time_point earliest_send{};        // start_pause / broadcast_spacing after last activity
    std::array<std::uint8_t, 64> rx{}; // the newest bytes received, in order
    std::size_t rx_size = 0;
    std::array<std::uint8_t, max_telegram_size> tail{}; // rx tail when a reply finished it
    std::size_t tail_size = 0;
    bool finished_in_receive = false;

    // Handshake bit per address, as the master must keep it.
    std::array<bool, 256> hs{};

    // Counters for the stats cross-check.
    std::uint32_t started = 0, succeeded = 0, failed = 0;

    // The running transaction.
    bool active = false;
    bool done_seen = false;
    bool param_job = false;
    bool transport_failed = false;
    bool cleared = false; // clear() after the transaction finished
    telegram request{};
    unsigned sends = 0;
    bool quiet_since_send = false; // nothing received since the last send
    time_point reply_due{};        // end of the last request + response_timeout
    bool have_wait = false;        // last next() said wait and nothing happened since
    time_point wait_deadline{};

    harness(FuzzedDataProvider& p, const master_config& c, bool real)
        : in(p), cfg(c), m(c), realistic(real) {}

    void invalidate() { have_wait = false; }

    void check_always() {
        FERRULE_CHECK(m.attempts() <= 1 + cfg.retries);
        if (m.fault_latched()) {
            FERRULE_CHECK(cfg.fault_threshold != 0);
            FERRULE_CHECK(m.consecutive_failures() >= cfg.fault_threshold);
        }
        FERRULE_CHECK(m.stats().transactions == started);
        FERRULE_CHECK(m.stats().succeeded + m.stats().failed <= m.stats().transactions);
        // The session counts an outcome when it happens; the harness when it sees `done`.
        FERRULE_CHECK(m.stats().succeeded >= succeeded && m.stats().succeeded <= succeeded + 1);
        FERRULE_CHECK(m.stats().failed >= failed && m.stats().failed <= failed + 1);
    }

    // ---- starting a transaction ------------------------------------------------------

    void start_transaction() {
        if (in.ConsumeBool()) m.reset_fault();
        const std::uint8_t a = in.ConsumeIntegral<std::uint8_t>();
        const std::uint8_t address = a < 224
                                         ? interesting_addresses[a % sizeof interesting_addresses]
                                         : in.ConsumeIntegral<std::uint8_t>();
        const std::uint8_t t = in.ConsumeIntegral<std::uint8_t>();
        const pdu_type type =
            t < 240 ? all_types[t % 14] : static_cast<pdu_type>(in.ConsumeIntegral<std::uint8_t>());
        const bool want_param = in.ConsumeBool();
        std::size_t npo = pd_words(type);
        if (in.ConsumeIntegral<std::uint8_t>() >= 240)
            npo = in.ConsumeIntegralInRange<std::size_t>(0, 3);
        std::array<std::uint16_t, 3> po{};
        for (std::size_t i = 0; i < npo; ++i) po[i] = in.ConsumeIntegral<std::uint16_t>();
        param_channel pc = param_channel::make(
            static_cast<service>(in.ConsumeIntegralInRange<unsigned>(0, 8)),
            in.ConsumeIntegral<std::uint16_t>(), in.ConsumeIntegral<std::uint32_t>(),
            in.ConsumeBool() ? in.ConsumeIntegral<std::uint8_t>() : 0);
        if (in.ConsumeIntegral<std::uint8_t>() >= 240)
            pc.management = in.ConsumeIntegral<std::uint8_t>();

        const bool busy_before = m.busy();
        const bool latched_before = m.fault_latched();
        const std::span<const std::uint16_t> pos(po.data(), npo);
        const std::error_code ec = want_param ? m.start_parameter(address, type, pc, pos)
                                              : m.start_exchange(address, type, pos);

        const auto kind = kind_of(address);
        const bool valid_args = is_valid_pdu_type(static_cast<std::uint8_t>(type)) &&
                                npo == pd_words(type) && (!want_param || has_param(type)) &&
                                kind != address_kind::undefined && kind != address_kind::local;
        const bool expect_ok = valid_args && !busy_before && !latched_before;
        FERRULE_CHECK(!ec == expect_ok);
        if (ec == errc::busy) FERRULE_CHECK(busy_before);
        if (ec == errc::fault_latched) FERRULE_CHECK(latched_before);
        if (ec && ec != errc::busy && ec != errc::fault_latched)
            FERRULE_CHECK(ec == errc::invalid_argument && !valid_args);
        invalidate();
        if (!ec) ++started;
        check_always();
        if (ec) {
            call_next(); // idle, or the previous transaction's `done`
            return;
        }
        cleared = false;

        active = true;
        done_seen = false;
        transport_failed = false;
        finished_in_receive = false;
        sends = 0;
        quiet_since_send = false;
        param_job = want_param;
        request = telegram{direction::request, address, type, {}, {}};
        for (std::size_t i = 0; i < npo; ++i) request.pd[i] = po[i];
        if (want_param) {
            request.param = pc;
            if (!is_acyclic(type)) {
                hs[address] = !hs[address]; // a new cyclic service toggles the bit
                request.param.set_handshake(hs[address]);
            } else {
                request.param.set_handshake(false);
            }
        } else {
            request.param = param_channel{}; // "no service", current handshake bit
            request.param.set_handshake(hs[address]);
        }
        FERRULE_CHECK(m.busy());
        FERRULE_CHECK(m.attempts() == 0);
    }

    // ---- next() ---------------------------------------------------------------------

    session_action call_next() {
        const auto act = m.next(now);
        check_always();
        if (have_wait && now < wait_deadline) {
            // Nothing happened since the last `wait`: same answer.
            FERRULE_CHECK(act.what == session_action::kind::wait && act.deadline == wait_deadline);
        }
        if (active && quiet_since_send && expects_response(request.address) && now < reply_due &&
            !transport_failed)
            FERRULE_CHECK(act.what == session_action::kind::wait);
        switch (act.what) {
        case session_action::kind::idle:
            FERRULE_CHECK(started == 0 || cleared);
            FERRULE_CHECK(!m.busy());
            break;
        case session_action::kind::wait:
            FERRULE_CHECK(active && !done_seen);
            FERRULE_CHECK(m.busy());
            FERRULE_CHECK(act.deadline > now);
            FERRULE_CHECK(act.deadline != never);
            have_wait = true;
            wait_deadline = act.deadline;
            break;
        case session_action::kind::send: on_send(act); break;
        case session_action::kind::done:
            FERRULE_CHECK(started > 0 && !cleared);
            FERRULE_CHECK(!m.busy());
            if (active && !done_seen) on_done();
            break;
        }
        return act;
    }

    void on_send(const session_action& act) {
        FERRULE_CHECK(active && !done_seen);
        invalidate();
        ++sends;
        FERRULE_CHECK(sends <= 1 + cfg.retries + cfg.handshake_polls);
        FERRULE_CHECK(act.discard_input == cfg.discard_stale_input);
        const auto req = m.request_bytes();
        FERRULE_CHECK(act.bytes.data() == req.data() && act.bytes.size() == req.size());
        FERRULE_CHECK(act.bytes.size() == telegram_size(request.type));
        const auto t = parse(act.bytes);
        FERRULE_CHECK(t.has_value());
        FERRULE_CHECK(*t == request);
        FERRULE_CHECK(t->param == request.param || !has_param(request.type));
        if (realistic) FERRULE_CHECK(now >= earliest_send);

        const duration wire = cfg.format.chars_time(act.bytes.size());
        bus_free = now + wire;
        reply_due = bus_free + cfg.response_timeout;
        quiet_since_send = true;
        earliest_send = bus_free + (expects_response(request.address) ? cfg.start_pause
                                                                      : cfg.broadcast_spacing);
        if (!expects_response(request.address)) {
            FERRULE_CHECK(!m.busy());
            FERRULE_CHECK(m.error() == errc::no_response_expected);
        } else {
            FERRULE_CHECK(m.busy());
        }
    }

    void on_done() {
        done_seen = true;
        FERRULE_CHECK(!m.busy());
        const std::error_code ec = m.error();
        if (!transport_failed) FERRULE_CHECK(m.attempts() >= 1 && sends >= 1);
        if (!ec) {
            ++succeeded;
            FERRULE_CHECK(expects_response(request.address));
            const telegram& r = m.reply();
            FERRULE_CHECK(r.dir == direction::response);
            FERRULE_CHECK(r.type == request.type);
            if (request.address != address_point_to_point)
                FERRULE_CHECK(r.address == request.address);
            if (has_param(r.type)) {
                FERRULE_CHECK(!r.param.is_error());
                if (param_job && !is_acyclic(request.type))
                    FERRULE_CHECK(r.param.handshake() == request.param.handshake());
            }
            FERRULE_CHECK(m.consecutive_failures() == 0);
            FERRULE_CHECK(!m.fault_latched());
            // The reply is the last telegram on the wire, nothing invented.
            const std::size_t n = telegram_size(r.type);
            FERRULE_CHECK(finished_in_receive && tail_size >= n);
            const auto last = parse(std::span<const std::uint8_t>(tail.data() + tail_size - n, n));
            FERRULE_CHECK(last.has_value() && *last == r);
        } else if (ec == errc::no_response_expected) {
            FERRULE_CHECK(!expects_response(request.address));
            FERRULE_CHECK(sends == 1 && m.attempts() == 1);
        } else if (transport_failed && ec == errc::transport) {
            ++failed; // finished by on_transport_error(), a failed transaction too
        } else {
            ++failed;
            FERRULE_CHECK(expects_response(request.address));
            FERRULE_CHECK(m.consecutive_failures() >= 1);
            const bool device = ec.category() == device_category();
            if (device) {
                FERRULE_CHECK(has_param(request.type));
                FERRULE_CHECK(m.reply().param.is_error());
                FERRULE_CHECK(ec == make_device_error(m.reply().param));
            }
            FERRULE_CHECK(m.fault_latched() || (device && !cfg.retry_device_errors) ||
                          m.attempts() == 1 + cfg.retries);
        }
        FERRULE_CHECK(m.stats().succeeded == succeeded);
        FERRULE_CHECK(m.stats().failed == failed);
        active = false;
    }

    // ---- input ----------------------------------------------------------------------

    void advance(duration d) {
        if (d.count() < 0) return;
        now += d;
    }

    void receive(std::span<const std::uint8_t> bytes) {
        if (bytes.empty()) return;
        if (realistic && now < bus_free) now = bus_free;
        now += cfg.format.chars_time(bytes.size()); // the bytes take their wire time
        const bool busy_before = m.busy();
        const auto stale_before = m.stats().stale_bytes;
        m.on_receive(bytes, now);
        invalidate();
        quiet_since_send = false;
        for (auto b : bytes) {
            if (rx_size == rx.size()) { // keep the newest half
                std::memmove(rx.data(), rx.data() + rx.size() / 2, rx.size() / 2);
                rx_size = rx.size() / 2;
            }
            rx[rx_size++] = b;
        }
        if (busy_before && !m.busy()) {
            // The bytes that finished the transaction: the reply must be their tail.
            finished_in_receive = true;
            tail_size = rx_size < tail.size() ? rx_size : tail.size();
            std::memcpy(tail.data(), rx.data() + rx_size - tail_size, tail_size);
        }
        const auto stale = m.stats().stale_bytes - stale_before;
        FERRULE_CHECK(stale == 0 || stale == bytes.size());
        if (!busy_before) FERRULE_CHECK(stale == bytes.size());
        if (now + cfg.start_pause > earliest_send) earliest_send = now + cfg.start_pause;
        check_always();
    }

    void receive_random() {
        std::array<std::uint8_t, 24> buf{};
        const std::size_t n = in.ConsumeIntegralInRange<std::size_t>(1, buf.size());
        for (std::size_t i = 0; i < n; ++i) buf[i] = in.ConsumeIntegral<std::uint8_t>();
        receive(std::span<const std::uint8_t>(buf.data(), n));
    }

    // A reply derived from the request, so that the interesting paths are reachable.
    void receive_reply() {
        const std::uint8_t f = in.ConsumeIntegral<std::uint8_t>();
        telegram r = request;
        r.dir = direction::response;
        if (f & 0x01)
            r.address = in.ConsumeIntegral<std::uint8_t>();
        else if (request.address == address_point_to_point)
            r.address = in.ConsumeIntegralInRange<std::uint8_t>(0, 99);
        if (f & 0x02) r.type = all_types[in.ConsumeIntegralInRange<std::size_t>(0, 13)];
        for (auto& w : r.pd) w = in.ConsumeIntegral<std::uint16_t>();
        if (has_param(r.type)) {
            r.param.data = in.ConsumeIntegral<std::uint32_t>();
            if (f & 0x04) r.param.set_handshake(!r.param.handshake());
            if (f & 0x08) r.param.management |= mgmt_status_error;
        }
        std::array<std::uint8_t, max_telegram_size + 1> buf{};
        const auto n0 = encode(r, buf);
        FERRULE_CHECK(n0.has_value());
        std::size_t n = *n0;
        if (f & 0x10) {
            const auto at = in.ConsumeIntegralInRange<std::size_t>(0, n - 1);
            buf[at] ^= static_cast<std::uint8_t>(in.ConsumeIntegralInRange<unsigned>(1, 255));
        }
        if (f & 0x20) buf[n++] = in.ConsumeIntegral<std::uint8_t>();
        if (f & 0x40) { // an echo of a request instead of a response
            buf[0] = sd1_request;
            buf[*n0 - 1] = xor_bcc(std::span<const std::uint8_t>(buf.data(), *n0 - 1));
        }
        // Response delay, then the telegram in up to three chunks with gaps between them.
        advance(std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 60000)));
        std::size_t pos = 0;
        const unsigned pieces = in.ConsumeIntegralInRange<unsigned>(1, 3);
        for (unsigned p = 0; p < pieces && pos < n; ++p) {
            const std::size_t len =
                p + 1 == pieces ? n - pos : in.ConsumeIntegralInRange<std::size_t>(1, n - pos);
            receive(std::span<const std::uint8_t>(buf.data() + pos, len));
            pos += len;
            if (pos < n)
                advance(
                    std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 5000)));
        }
    }

    void step() {
        switch (in.ConsumeIntegralInRange<unsigned>(0, 16)) {
        case 0:
        case 1:
        case 2:
        case 3: call_next(); break;
        case 4:
        case 5:
            advance(std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 8000)));
            break;
        case 6:
            advance(std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 300000)));
            break;
        case 7:
        case 8:
            if (have_wait) {
                const auto back = std::chrono::nanoseconds(in.ConsumeIntegralInRange<int>(0, 1));
                if (wait_deadline - back > now) now = wait_deadline - back;
            }
            break;
        case 9:
        case 10: receive_random(); break;
        case 11:
        case 12:
        case 13: receive_reply(); break;
        case 14:
            if (in.ConsumeIntegral<std::uint8_t>() < 16) {
                const bool was_busy = m.busy();
                m.on_transport_error(ferrule::error(errc::transport));
                invalidate();
                if (was_busy) {
                    transport_failed = true;
                    FERRULE_CHECK(!m.busy());
                    FERRULE_CHECK(m.error() == errc::transport);
                }
                check_always();
            }
            break;
        case 16:
            // clear(): done -> idle; no effect while busy.
            if (m.busy()) {
                m.clear();
                FERRULE_CHECK(m.busy());
            } else {
                if (active && !done_seen) on_done(); // finished, `done` not yet seen
                m.clear();
                invalidate();
                cleared = true;
                FERRULE_CHECK(m.next(now).what == session_action::kind::idle);
            }
            check_always();
            break;
        default: {
            // A second start while busy must be refused without side effects.
            if (!m.busy()) break;
            const std::uint16_t po[3] = {6, 0, 0};
            const auto ec = m.start_exchange(1, pdu_type::pd3, po);
            FERRULE_CHECK(ec == errc::busy);
            FERRULE_CHECK(m.busy());
            check_always();
            break;
        }
        }
    }

    // No more input: the session must finish on timeouts alone, in bounded virtual time.
    void drain() {
        if (!active) return;
        const duration per_send = std::max(cfg.broadcast_spacing, 2 * cfg.start_pause) +
                                  3 * cfg.format.chars_time(max_telegram_size) +
                                  cfg.response_timeout + cfg.max_char_delay +
                                  cfg.format.char_time() + 1ms;
        const unsigned budget = 2 + cfg.retries + cfg.handshake_polls;
        const time_point limit = now + budget * per_send;
        for (unsigned i = 0; i < 4 * budget + 8; ++i) {
            const auto act = call_next();
            if (act.what == session_action::kind::done) break;
            FERRULE_CHECK(act.what != session_action::kind::idle);
            if (act.what == session_action::kind::wait) now = act.deadline;
            FERRULE_CHECK(now <= limit);
        }
        FERRULE_CHECK(done_seen && !active);
    }
};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    FuzzedDataProvider in(data, size);

    master_config cfg;
    constexpr std::uint32_t bauds[] = {9600, 19200, 57600, 115200};
    cfg.format.baud = bauds[in.ConsumeIntegralInRange<std::size_t>(0, 3)];
    cfg.retries = in.ConsumeIntegralInRange<unsigned>(0, 6);
    cfg.fault_threshold = in.ConsumeIntegralInRange<unsigned>(0, 8);
    if (in.ConsumeBool()) cfg.max_char_delay = duration::zero();
    switch (in.ConsumeIntegralInRange<unsigned>(0, 3)) {
    case 0: break; // 50 ms
    case 1: cfg.response_timeout = 100ms; break;
    default:
        cfg.response_timeout =
            std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(1, 60000));
        break;
    }
    cfg.retry_device_errors = in.ConsumeBool();
    cfg.handshake_polls = in.ConsumeIntegralInRange<unsigned>(0, 4);
    cfg.discard_stale_input = in.ConsumeBool();
    const bool realistic = in.ConsumeBool();

    harness h(in, cfg, realistic);
    h.now = time_point{} + (in.ConsumeBool() ? 1s : 0s);
    for (int tx = 0; tx < 4 && in.remaining_bytes() > 0; ++tx) {
        h.start_transaction();
        for (int s = 0; s < 48 && h.active && !h.done_seen && in.remaining_bytes() > 0; ++s)
            h.step();
        h.drain();
        // Bytes between transactions are stale; the next request keeps its distance.
        if (in.remaining_bytes() > 0 && in.ConsumeIntegral<std::uint8_t>() < 32) h.receive_random();
    }
    return 0;
}
