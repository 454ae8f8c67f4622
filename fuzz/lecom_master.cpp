// libFuzzer target: the LECOM master session (lecom::master) against arbitrary replies, in
// virtual time.
//
// The input (read through FuzzedDataProvider) picks a master_config, then up to four
// transactions: RECEIVE or SEND, an address (drive, group, broadcast, beyond 99), a code
// (standard, beyond 6229, with a subcode, extended) and a value (each format, or a
// hand-built one that cannot be encoded). Each transaction runs for a bounded number of
// steps, each one of: next(now), advance virtual time (small, large, or to the deadline
// last announced), deliver random bytes, deliver a reply built from the request (data,
// `?`, no-code, bare EOT / NAK / ACK, another code echoed, a flipped byte, trailing
// garbage; split into chunks with gaps), a transport error, a second start while busy,
// or clear(). Then it is drained with no input at all. Seeds: fuzz/corpus/lecom_master/.
//
// Invariants (violation -> __builtin_trap):
//   * start_*() succeeds exactly when the session is not busy and the request can be
//     sent (RECEIVE: a drive address; both: an encodable code and value); busy only then
//   * next(): `wait` deadlines lie in the future; asking again before the deadline with
//     nothing received gives the same answer; no send and no `done` while a reply is
//     awaited, nothing has been received and end of request + response_timeout is ahead
//   * every send is the request: request_bytes(), parsing back to request(); discard_input
//     as configured; at least `turnaround` after the last byte received, at least
//     broadcast_spacing after a broadcast's end; a resend with nothing received since the
//     last send at least response_timeout + turnaround after that send's end
//   * attempts() <= 1 + retries
//   * stats add up: at most one attempt is open (sent, outcome not counted yet); every
//     other send of a reply-expecting request has exactly one outcome (succeeded,
//     timeouts, bad_checksums, malformed, device_errors) unless a transport error cut it;
//     transactions == started; when idle, transactions == succeeded + failed + broadcasts;
//     resends == sends - transactions that sent
//   * outcome: success -> a RECEIVE got a data reply echoing the requested code, a SEND an
//     ACK; a broadcast -> errc::no_response_expected after one send; a retryable failure
//     -> all 1 + retries attempts used; code_does_not_exist ends at once
//   * with no input the session reaches `done` within a bounded amount of virtual time
//   * each attempt ends as a reference model says: a shadow frame_decoder (accept::replies),
//     fed what the master is fed, finds the reply telegram, and parse_reply() plus the table
//     of master.hpp give the outcome (the counter that moves and error()), or the deadline
//     passes (timeout, or malformed once bytes came); the reply deadline is end of request +
//     response_timeout, + chars_time(max_reply_length) while the shadow is inside a telegram;
//     a successful parse is what reply() holds
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "ferrule/lecom/master.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::lecom;
using namespace std::chrono_literals;

constexpr std::uint8_t interesting_addresses[] = {1, 2, 34, 99, 0, 10, 90, 100, 255, 11};

std::uint32_t outcomes(const master_stats& s) {
    return s.succeeded + s.timeouts + s.bad_checksums + s.malformed + s.device_errors;
}

struct harness {
    FuzzedDataProvider& in;
    master_config cfg;
    master m;
    time_point now{};

    // Bus model: no request before these.
    time_point quiet_after{}; // last byte received + turnaround, deadline + turnaround …
    bool any_quiet = false;

    // Counters for the stats cross-check.
    std::uint32_t started = 0, broadcasts = 0, sends = 0, reply_sends = 0, aborted = 0;
    std::uint32_t transactions_sent = 0;

    // The running transaction.
    bool active = false;
    bool done_seen = false;
    bool transport_failed = false;
    bool cleared = true;
    frame request{};
    bool broadcast = false;
    unsigned tx_sends = 0;
    time_point tx_end{};
    bool quiet_since_send = false;
    bool have_wait = false;
    time_point wait_deadline{};

    // Reference model of the attempt under way.
    frame_decoder shadow{frame_decoder::accept::replies};
    bool awaiting = false; // a reply is awaited: sent, no outcome yet
    bool heard = false;    // bytes came while it was

    harness(FuzzedDataProvider& p, const master_config& c) : in(p), cfg(c), m(c) {}

    void hold(time_point t) {
        if (!any_quiet || t > quiet_after) quiet_after = t;
        any_quiet = true;
    }

    void check_always() {
        const auto& s = m.stats();
        FERRULE_CHECK(m.attempts() <= 1 + cfg.retries);
        FERRULE_CHECK(s.transactions == started);
        FERRULE_CHECK(outcomes(s) + aborted <= reply_sends);
        FERRULE_CHECK(reply_sends - aborted - outcomes(s) <= 1);
        FERRULE_CHECK(s.resends == sends - transactions_sent);
        FERRULE_CHECK(s.succeeded + s.failed + broadcasts <= s.transactions);
        if (!m.busy()) {
            FERRULE_CHECK(reply_sends - aborted == outcomes(s));
            FERRULE_CHECK(s.succeeded + s.failed + broadcasts == s.transactions);
        }
    }

    // ---- starting a transaction ------------------------------------------------------

    code_address pick_code() {
        switch (in.ConsumeIntegralInRange<unsigned>(0, 5)) {
        case 0: return code(46);
        case 1: return code(in.ConsumeIntegralInRange<std::uint16_t>(0, 6229));
        case 2: return code_address{in.ConsumeIntegral<std::uint16_t>(), 0, false};
        case 3:
            return code_address{in.ConsumeIntegral<std::uint16_t>(),
                                in.ConsumeIntegral<std::uint8_t>(), false};
        default:
            return extended_code(in.ConsumeIntegral<std::uint16_t>(),
                                 in.ConsumeIntegral<std::uint8_t>());
        }
    }

    value pick_value() {
        value v;
        switch (in.ConsumeIntegralInRange<unsigned>(0, 5)) {
        case 0:
            v = decimal_fixed(in.ConsumeIntegral<std::int32_t>(),
                              in.ConsumeIntegral<std::uint8_t>());
            break;
        case 1: {
            const std::uint8_t digits[] = {2, 4, 8};
            const auto d = digits[in.ConsumeIntegralInRange<unsigned>(0, 2)];
            v = hex(in.ConsumeIntegral<std::uint32_t>() &
                        (d == 8 ? 0xFFFFFFFFu : (1u << 4 * d) - 1),
                    d)
                    .value_or(value{});
            break;
        }
        case 2: v = string("82EV123").value_or(value{}); break;
        case 3: {
            const std::array<std::uint8_t, 3> o{0x0A, 0x1B, 0xFF};
            v = octets(o).value_or(value{});
            break;
        }
        default: // hand-built, maybe not encodable
            v.format = static_cast<value_format>(in.ConsumeIntegralInRange<unsigned>(0, 4));
            v.hex = in.ConsumeIntegral<std::uint32_t>();
            v.digits = in.ConsumeIntegral<std::uint8_t>();
            v.size = in.ConsumeIntegralInRange<std::uint8_t>(0, 40);
            for (auto& b : v.bytes) b = in.ConsumeIntegral<std::uint8_t>();
            break;
        }
        return v;
    }

    void start_transaction() {
        const std::uint8_t a = in.ConsumeIntegral<std::uint8_t>();
        const std::uint8_t address = a < 200
                                         ? interesting_addresses[a % sizeof interesting_addresses]
                                         : in.ConsumeIntegral<std::uint8_t>();
        const bool is_write = in.ConsumeBool();
        const code_address c = pick_code();
        const value v = pick_value();

        const bool busy_before = m.busy();
        const frame req = is_write ? write_request(address, c, v) : read_request(address, c);
        std::array<std::uint8_t, max_request_length> probe{};
        const bool encodable = encode(req, probe).has_value();
        const bool valid = encodable && (is_write || is_unit_address(address));
        const std::error_code ec =
            is_write ? m.start_write(address, c, v) : m.start_read(address, c);
        FERRULE_CHECK(!ec == (valid && !busy_before));
        if (ec) FERRULE_CHECK(ec == (busy_before ? errc::busy : errc::invalid_argument));
        have_wait = false;
        if (ec) {
            check_always();
            call_next(); // idle, or the previous transaction's `done`
            return;
        }
        ++started;
        active = true;
        done_seen = false;
        transport_failed = false;
        cleared = false;
        request = req;
        broadcast = is_write && is_group_address(address);
        tx_sends = 0;
        quiet_since_send = false;
        awaiting = false;
        FERRULE_CHECK(m.busy() && m.attempts() == 0);
        check_always();
    }

    // ---- next() ---------------------------------------------------------------------

    // The attempt under way ended with `ec`, counted in `counter`.
    void check_outcome(const master_stats& before, std::uint32_t master_stats::*counter,
                       std::error_code ec) {
        FERRULE_CHECK(outcomes(m.stats()) == outcomes(before) + 1);
        FERRULE_CHECK(m.stats().*counter == before.*counter + 1);
        FERRULE_CHECK(m.error() == ec);
        awaiting = false;
    }

    session_action call_next() {
        const master_stats before = m.stats();
        const auto act = m.next(now);
        if (awaiting && outcomes(m.stats()) != outcomes(before)) // the deadline has passed
            check_outcome(before, heard ? &master_stats::malformed : &master_stats::timeouts,
                          heard ? errc::malformed : errc::timeout);
        if (awaiting && act.what == session_action::kind::wait)
            FERRULE_CHECK(act.deadline == tx_end + cfg.response_timeout +
                                              (shadow.in_frame()
                                                   ? cfg.format.chars_time(max_reply_length)
                                                   : duration::zero()));
        if (have_wait && now < wait_deadline)
            FERRULE_CHECK(act.what == session_action::kind::wait && act.deadline == wait_deadline);
        if (active && !done_seen && quiet_since_send && !broadcast && !transport_failed &&
            now < tx_end + cfg.response_timeout)
            FERRULE_CHECK(act.what == session_action::kind::wait);
        switch (act.what) {
        case session_action::kind::idle: FERRULE_CHECK(cleared && !m.busy()); break;
        case session_action::kind::wait:
            FERRULE_CHECK(active && !done_seen && m.busy());
            FERRULE_CHECK(act.deadline > now && act.deadline != never);
            have_wait = true;
            wait_deadline = act.deadline;
            break;
        case session_action::kind::send: on_send(act); break;
        case session_action::kind::done:
            FERRULE_CHECK(!cleared && !m.busy());
            if (active && !done_seen) on_done();
            break;
        }
        check_always();
        return act;
    }

    void on_send(const session_action& act) {
        FERRULE_CHECK(active && !done_seen);
        have_wait = false;
        if (tx_sends == 0) ++transactions_sent;
        ++tx_sends;
        ++sends;
        if (!broadcast) ++reply_sends;
        FERRULE_CHECK(tx_sends <= 1 + cfg.retries);
        FERRULE_CHECK(m.attempts() == tx_sends);
        FERRULE_CHECK(act.discard_input == cfg.discard_stale_input);
        const auto req = m.request_bytes();
        FERRULE_CHECK(act.bytes.data() == req.data() && act.bytes.size() == req.size());
        const auto parsed = parse_request(act.bytes);
        FERRULE_CHECK(parsed.has_value());
        FERRULE_CHECK(parsed->kind == request.kind && parsed->address == request.address &&
                      parsed->code == request.code);
        FERRULE_CHECK(m.request().kind == request.kind);
        if (any_quiet) FERRULE_CHECK(now >= quiet_after);
        // A resend with nothing heard since the last send: that attempt timed out.
        if (tx_sends > 1 && quiet_since_send && !broadcast)
            FERRULE_CHECK(now >= tx_end + cfg.response_timeout + cfg.turnaround);
        tx_end = now + cfg.format.chars_time(act.bytes.size());
        quiet_since_send = true;
        awaiting = !broadcast;
        heard = false;
        shadow.reset();
        if (broadcast) hold(tx_end + cfg.broadcast_spacing);
        check_always();
    }

    void on_done() {
        done_seen = true;
        active = false;
        const std::error_code ec = m.error();
        if (!transport_failed) FERRULE_CHECK(m.attempts() >= 1);
        if (broadcast && !transport_failed) {
            ++broadcasts;
            FERRULE_CHECK(ec == errc::no_response_expected);
            FERRULE_CHECK(m.attempts() == 1);
            return;
        }
        FERRULE_CHECK(ec != errc::no_response_expected);
        if (!ec) {
            const frame& r = m.reply();
            if (request.kind == frame_kind::receive) {
                FERRULE_CHECK(r.kind == frame_kind::data);
                FERRULE_CHECK(r.code == request.code);
            } else {
                FERRULE_CHECK(r.kind == frame_kind::ack);
            }
            return;
        }
        if (transport_failed) {
            FERRULE_CHECK(ec == errc::transport);
            return;
        }
        if (ec == device_errc::code_does_not_exist) {
            FERRULE_CHECK(request.kind == frame_kind::receive);
        } else {
            FERRULE_CHECK(m.attempts() == 1 + cfg.retries);
            FERRULE_CHECK(ec == errc::timeout || ec == errc::bad_checksum ||
                          ec == errc::malformed || ec == errc::unexpected_type ||
                          ec == device_errc::checksum_fault || ec == device_errc::write_refused);
            if (ec == device_errc::write_refused) FERRULE_CHECK(request.kind == frame_kind::send);
            if (ec == device_errc::checksum_fault)
                FERRULE_CHECK(request.kind == frame_kind::receive);
        }
    }

    // ---- input ----------------------------------------------------------------------

    void advance(duration d) {
        if (d.count() > 0) now += d;
    }

    // The table of master.hpp applied to the reply telegram `t`.
    void expect_reply(std::span<const std::uint8_t> t, const master_stats& before) {
        using s = master_stats;
        const auto r = parse_reply(t);
        if (!r) {
            const bool bcc = r.error() == errc::bad_checksum;
            FERRULE_CHECK(bcc || r.error() == errc::malformed);
            check_outcome(before, bcc ? &s::bad_checksums : &s::malformed, r.error());
            return;
        }
        const frame_kind k = r->kind;
        FERRULE_CHECK(m.reply().kind == k && m.reply().code == r->code &&
                      m.reply().value == r->value);
        if (request.kind == frame_kind::send) {
            if (k == frame_kind::ack)
                check_outcome(before, &s::succeeded, {});
            else if (k == frame_kind::nak)
                check_outcome(before, &s::device_errors, device_errc::write_refused);
            else
                check_outcome(before, &s::malformed, errc::malformed);
            return;
        }
        const bool echoes =
            k == frame_kind::data || k == frame_kind::fault || k == frame_kind::no_code;
        if (echoes && r->code != request.code) {
            check_outcome(before, &s::malformed, errc::unexpected_type);
            return;
        }
        switch (k) {
        case frame_kind::data: check_outcome(before, &s::succeeded, {}); break;
        case frame_kind::fault:
        case frame_kind::nak:
            check_outcome(before, &s::device_errors, device_errc::checksum_fault);
            break;
        case frame_kind::no_code:
        case frame_kind::eot:
            check_outcome(before, &s::device_errors, device_errc::code_does_not_exist);
            break;
        default: check_outcome(before, &s::malformed, errc::malformed); break;
        }
    }

    void receive(std::span<const std::uint8_t> bytes) {
        if (bytes.empty()) return;
        now += cfg.format.chars_time(bytes.size()); // the bytes take their wire time
        const std::uint32_t before = outcomes(m.stats());
        const master_stats stats_before = m.stats();
        // What the reference model makes of the bytes: the reply telegram, if one ends in them.
        bool telegram = false;
        std::array<std::uint8_t, max_frame_length> reply_bytes{};
        std::size_t reply_size = 0;
        if (awaiting) {
            heard = true;
            for (auto rest = bytes; !rest.empty() && !telegram;) {
                const auto step = shadow.feed(rest);
                rest = rest.subspan(step.consumed);
                if (step.what != frame_decoder::status::frame) continue;
                telegram = true;
                reply_size = shadow.frame().size();
                std::copy_n(shadow.frame().begin(), reply_size, reply_bytes.begin());
            }
        }
        m.on_receive(bytes, now);
        if (telegram)
            expect_reply({reply_bytes.data(), reply_size}, stats_before);
        else
            FERRULE_CHECK(outcomes(m.stats()) == before);
        have_wait = false;
        quiet_since_send = false;
        hold(now + cfg.turnaround);
        // An attempt ended in these bytes: the master holds from now on as well.
        if (outcomes(m.stats()) != before) FERRULE_CHECK(outcomes(m.stats()) == before + 1);
        if (!m.busy() && active && !done_seen) call_next();
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
        frame r;
        const unsigned form = in.ConsumeIntegralInRange<unsigned>(0, 7);
        switch (form) {
        case 0: r = {frame_kind::data, 0, request.code, pick_value()}; break;
        case 1: r = {frame_kind::data, 0, pick_code(), pick_value()}; break;
        case 2: r = {frame_kind::fault, 0, request.code, {}}; break;
        case 3: r = {frame_kind::no_code, 0, request.code, {}}; break;
        case 4: r = {frame_kind::eot}; break;
        case 5: r = {frame_kind::nak}; break;
        case 6: r = {frame_kind::ack}; break;
        default:
            r = {in.ConsumeBool() ? frame_kind::fault : frame_kind::no_code, 0, pick_code(), {}};
        }
        std::array<std::uint8_t, max_frame_length + 2> buf{};
        const auto n0 = encode(r, std::span(buf).first(max_frame_length));
        if (!n0) return; // a value or code that cannot be sent
        std::size_t n = *n0;
        const std::uint8_t f = in.ConsumeIntegral<std::uint8_t>();
        if (f & 0x01) {
            const auto at = in.ConsumeIntegralInRange<std::size_t>(0, n - 1);
            buf[at] ^= static_cast<std::uint8_t>(in.ConsumeIntegralInRange<unsigned>(1, 255));
        }
        if (f & 0x02) buf[n++] = in.ConsumeIntegral<std::uint8_t>();
        // Drive delay, then the telegram in up to three chunks with gaps between them.
        advance(std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 120000)));
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
        switch (in.ConsumeIntegralInRange<unsigned>(0, 15)) {
        case 0:
        case 1:
        case 2:
        case 3: call_next(); break;
        case 4:
            advance(std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 8000)));
            break;
        case 5:
            advance(std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 400000)));
            break;
        case 6:
        case 7:
            if (have_wait) {
                const auto back = std::chrono::nanoseconds(in.ConsumeIntegralInRange<int>(0, 1));
                if (wait_deadline - back > now) now = wait_deadline - back;
            }
            break;
        case 8:
        case 9: receive_random(); break;
        case 10:
        case 11:
        case 12: receive_reply(); break;
        case 13:
            if (in.ConsumeIntegral<std::uint8_t>() < 16) {
                const bool was_busy = m.busy();
                const std::uint32_t open = reply_sends - aborted - outcomes(m.stats());
                m.on_transport_error(ferrule::error(errc::transport));
                have_wait = false;
                awaiting = false;
                if (was_busy) {
                    transport_failed = true;
                    aborted += open;
                    FERRULE_CHECK(!m.busy());
                    FERRULE_CHECK(m.error() == errc::transport);
                }
                check_always();
            }
            break;
        case 14:
            // clear(): done -> idle; no effect while busy.
            if (m.busy()) {
                m.clear();
                FERRULE_CHECK(m.busy());
            } else {
                if (active && !done_seen) on_done(); // finished, `done` not yet seen
                m.clear();
                have_wait = false;
                cleared = true;
                FERRULE_CHECK(m.next(now).what == session_action::kind::idle);
            }
            check_always();
            break;
        default: {
            // A second start while busy must be refused without side effects.
            if (!m.busy()) break;
            const auto before = m.stats().transactions;
            FERRULE_CHECK(m.start_read(1, code(46)) == errc::busy);
            FERRULE_CHECK(m.busy() && m.stats().transactions == before);
            break;
        }
        }
    }

    // No more input: the session must finish on timeouts alone, in bounded virtual time.
    void drain() {
        if (!active) return;
        const duration per_send = cfg.turnaround + cfg.broadcast_spacing +
                                  cfg.format.chars_time(max_request_length) + cfg.response_timeout +
                                  cfg.format.chars_time(max_reply_length) + 400ms;
        const time_point limit = now + (2 + cfg.retries) * per_send;
        for (unsigned i = 0; i < 4 * (2 + cfg.retries) + 8; ++i) {
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
    constexpr std::uint32_t bauds[] = {9600, 1200, 19200, 57600};
    cfg.format.baud = bauds[in.ConsumeIntegralInRange<std::size_t>(0, 3)];
    if (in.ConsumeBool()) cfg.format = lenze_8200.format;
    cfg.retries = in.ConsumeIntegralInRange<unsigned>(0, 4);
    switch (in.ConsumeIntegralInRange<unsigned>(0, 2)) {
    case 0: break; // 100 ms
    default:
        cfg.response_timeout =
            std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(1, 200000));
        break;
    }
    cfg.turnaround = std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 20000));
    cfg.broadcast_spacing =
        std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 50000));
    cfg.discard_stale_input = in.ConsumeBool();

    harness h(in, cfg);
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
