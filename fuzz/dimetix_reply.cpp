// libFuzzer target: the Dimetix line decoder, parse_reply() / check_answers(), and the sensor
// session (dimetix::sensor) fed random answers.
//
// The input (read through FuzzedDataProvider) picks a sensor_config, then up to four
// commands from the D-Series set (IDs 0..99, DO hysteresis `1` / `2` to hit the s11/g11
// clash, ID-less dg on a point-to-point line). Each runs for a bounded number of steps, each
// one of: next(now), advance virtual time (small, large, or to the announced deadline),
// random bytes, an answer built from the command (right, other ID, error, startup string,
// tracking line, sometimes a 1-digit ID with a leading zero, with a flipped byte or a dropped
// CR; split into chunks), a transport error. Then it is drained with no input. Every complete
// line the session saw is also given to a separate line_decoder, parse_reply() and the
// session's reading of a line. Seeds: fuzz/corpus/dimetix_reply/.
//
// Invariants (violation -> __builtin_trap):
//   * line_decoder: every consumed chunk makes progress; lines hold printable ASCII only,
//     at most max_line_length - 2 bytes; bytes fed == line bytes + CR LF + skipped() +
//     the unfinished line
//   * parse_reply(): a parsed reply is consistent (kind vs. mnemonic / values / error code,
//     buffer status 0..2, at most max_values values); printing it back and parsing again
//     gives the same reply; a line that is not 'g' + digits is refused
//   * the session's reading of a line (detail::read_answer) against the command being run
//     agrees with the full parse (detail::parse_into) and check_answers()'s rule
//     (detail::classify): the same lines are answers and device errors, an answer reads as
//     answered() gives it, a device error as the parsed gN@Ezzz line, a line it calls
//     malformed is refused by the full parse too
//   * session: every send is the encoded command; sends <= 1 + retries (connect: attempts);
//     `wait` deadlines lie in the future; no `done` before the deadline unless an answer or
//     a malformed line came; with no input it is done within (1 + retries) timeouts
//   * outcome: success -> reply() answers the command (check_answers() empty) and
//     carries its ID; a device error -> a gN@Ezzz line of the command's ID (or any ID for
//     dg) was received and error() holds zzz; stats add up
#include <fuzzer/FuzzedDataProvider.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/dimetix/reply.hpp"
#include "ferrule/dimetix/sensor.hpp"
#include "fuzz_check.hpp"

namespace {

using namespace ferrule;
using namespace ferrule::dimetix;
using namespace std::chrono_literals;

using text = std::array<std::uint8_t, 2 * max_line_length>;

struct writer {
    text buf{};
    std::size_t n = 0;
    void put(char c) {
        if (n < buf.size()) buf[n++] = static_cast<std::uint8_t>(c);
    }
    void put_id(unsigned id) {
        if (id >= 10) put(static_cast<char>('0' + id / 10));
        put(static_cast<char>('0' + id % 10));
    }
    void put_value(std::int32_t v, bool pad) {
        put(v < 0 ? '-' : '+');
        put_digits(v < 0 ? 0u - static_cast<std::uint32_t>(v) : static_cast<std::uint32_t>(v), pad);
    }
    void put_digits(std::uint32_t m, bool pad) {
        char d[10];
        int k = 0;
        do {
            d[k++] = static_cast<char>('0' + m % 10);
            m /= 10;
        } while (m != 0);
        for (int i = k; pad && i < 8; ++i) put('0');
        while (k > 0) put(d[--k]);
    }
    std::span<const std::uint8_t> view() const { return {buf.data(), n}; }
};

// The text of a parsed reply, as a sensor would write it.
writer print(const reply& r) {
    writer w;
    w.put('g');
    if (r.id_digits == 2 && r.id < 10) w.put('0');
    w.put_id(r.id);
    for (char c : r.mnemonic.view()) w.put(c);
    if (r.kind == reply_kind::error) {
        w.put('@');
        w.put('E');
        w.put_digits(r.error_code, false);
    }
    for (std::size_t i = 0; i < r.count; ++i) w.put_value(r.values[i], i % 2 == 0);
    if (r.kind == reply_kind::error && r.buffer_status >= 0) w.put_value(r.buffer_status, false);
    if (r.kind == reply_kind::set_ack || r.kind == reply_kind::startup_or_ack) w.put('?');
    return w;
}

void check_same(const reply& a, const reply& b) {
    FERRULE_CHECK(a.id == b.id && a.id_digits == b.id_digits && a.kind == b.kind);
    FERRULE_CHECK(a.mnemonic == b.mnemonic && a.count == b.count && a.truncated == b.truncated);
    FERRULE_CHECK(a.error_code == b.error_code && a.buffer_status == b.buffer_status);
    for (std::size_t i = 0; i < a.count; ++i) FERRULE_CHECK(a.values[i] == b.values[i]);
}

void check_read_answer(const command& c, std::span<const std::uint8_t> line) {
    const answer a = dimetix::detail::expected_answer(c);
    reply r;
    r.count = 3; // read_answer() starts from a blank reply
    const dimetix::detail::line_is what = dimetix::detail::read_answer(c, a, line, r);
    reply p;
    const bool parsed = dimetix::detail::parse_into(line, p);
    const auto m =
        parsed ? dimetix::detail::classify(c, a, p) : dimetix::detail::match::other_answer;
    if (what == dimetix::detail::line_is::malformed) FERRULE_CHECK(!parsed);
    FERRULE_CHECK((what == dimetix::detail::line_is::answer) ==
                  (parsed && m == dimetix::detail::match::answer));
    FERRULE_CHECK((what == dimetix::detail::line_is::device_error) ==
                  (parsed && m == dimetix::detail::match::device_error));
    if (what == dimetix::detail::line_is::answer) {
        check_same(r, answered(c, p));
        FERRULE_CHECK(!check_answers(c, r));
    }
    if (what == dimetix::detail::line_is::device_error) {
        check_same(r, p);
        FERRULE_CHECK(check_answers(c, r) == make_device_error(r.error_code));
    }
}

void check_reply(std::span<const std::uint8_t> line) {
    const auto r = parse_reply(line);
    if (line.empty() || line[0] != 'g' || line.size() < 2 || line[1] < '0' || line[1] > '9') {
        FERRULE_CHECK(!r);
        return;
    }
    if (!r) return;
    FERRULE_CHECK(r->count <= reply::max_values);
    FERRULE_CHECK(r->id <= max_id);
    FERRULE_CHECK(r->buffer_status >= -1 && r->buffer_status <= 2);
    FERRULE_CHECK(r->mnemonic.size == 0 || r->mnemonic.valid_text());
    switch (r->kind) {
    case reply_kind::startup_or_ack: FERRULE_CHECK(r->mnemonic.size == 0 && r->count == 0); break;
    case reply_kind::set_ack: FERRULE_CHECK(r->mnemonic.size > 0); break;
    case reply_kind::value:
        FERRULE_CHECK(r->mnemonic.size > 0 && r->count > 0);
        if (r->mnemonic.is('q')) FERRULE_CHECK(r->buffer_status == r->values[r->count - 1]);
        break;
    case reply_kind::error:
        FERRULE_CHECK(r->mnemonic.size == 0 && r->count == 0);
        FERRULE_CHECK(r->error_code >= 1 && r->error_code <= 999);
        break;
    }
    if (r->truncated) return; // printing back cannot restore the values left out
    const writer w = print(*r);
    const auto again = parse_reply(w.view());
    FERRULE_CHECK(again.has_value());
    FERRULE_CHECK(again->id == r->id && again->kind == r->kind && again->mnemonic == r->mnemonic);
    FERRULE_CHECK(again->count == r->count && again->error_code == r->error_code);
    FERRULE_CHECK(again->buffer_status == r->buffer_status);
    for (std::size_t i = 0; i < r->count; ++i) FERRULE_CHECK(again->values[i] == r->values[i]);
}

struct line_checker {
    line_decoder d;
    std::size_t fed = 0, in_lines = 0, current = 0;

    void feed(std::span<const std::uint8_t> in, const command& cmd) {
        while (!in.empty()) {
            const auto s = d.feed(in);
            FERRULE_CHECK(s.consumed >= 1 && s.consumed <= in.size());
            FERRULE_CHECK(s.what == line_decoder::status::need_more ? s.consumed == in.size()
                                                                    : true);
            FERRULE_CHECK((s.what == line_decoder::status::error) == static_cast<bool>(s.ec));
            fed += s.consumed;
            in = in.subspan(s.consumed);
            if (s.what == line_decoder::status::line) {
                const auto l = d.line();
                FERRULE_CHECK(l.size() <= max_line_length - 2);
                for (auto b : l) FERRULE_CHECK(b >= 0x20 && b <= 0x7E);
                in_lines += l.size() + 2;
                check_reply(l);
                check_read_answer(cmd, l);
            }
        }
        // Conservation: what is neither a line nor skipped is the unfinished line.
        FERRULE_CHECK(fed >= in_lines + d.skipped());
        FERRULE_CHECK(d.in_line() || fed == in_lines + d.skipped());
        FERRULE_CHECK(fed - in_lines - d.skipped() <= max_line_length);
    }
};

command pick_command(FuzzedDataProvider& in, bool multi_drop) {
    const std::uint8_t id = in.ConsumeBool() ? in.ConsumeIntegralInRange<std::uint8_t>(0, 99)
                                             : in.ConsumeIntegralInRange<std::uint8_t>(0, 12);
    switch (in.ConsumeIntegralInRange<int>(0, 9)) {
    case 0: return distance(id);
    case 1: return stop_clear(id);
    case 2: return read_buffer(id);
    case 3: return *set(id, in.ConsumeBool() ? "1" : "2", std::array{500, -495});
    case 4: return *get(id, in.ConsumeBool() ? "1" : "uo");
    case 5: return *set(id, "afi", std::array{in.ConsumeIntegralInRange<int>(1, 3), 100});
    case 6: return multi_drop ? temperature(id) : generation();
    case 7: return save_configuration(id);
    case 8: return tracking_buffered(id, in.ConsumeIntegralInRange<int>(0, 1000));
    default: return *get(id, "ot");
    }
}

struct harness {
    FuzzedDataProvider& in;
    sensor_config cfg;
    sensor s;
    line_checker lines;
    time_point now{};
    command cmd{};
    unsigned sends = 0;
    unsigned max_sends = 0;
    bool active = false;
    bool done_seen = false;
    bool transport_failed = false;
    bool have_wait = false;
    time_point wait_deadline{};
    time_point reply_due{};
    bool quiet_since_send = false;
    std::uint32_t started = 0, succeeded = 0, failed = 0;

    harness(FuzzedDataProvider& i, const sensor_config& c) : in(i), cfg(c), s(c) {}

    void start() {
        const bool connect = in.ConsumeIntegralInRange<int>(0, 7) == 0;
        cmd = connect ? stop_clear(in.ConsumeIntegralInRange<std::uint8_t>(0, 99))
                      : pick_command(in, cfg.multi_drop);
        const bool latched = s.fault_latched();
        const std::error_code ec = connect ? s.start_connect(cmd.id) : s.start(cmd);
        if (latched && !cmd.mnemonic.is('c')) {
            FERRULE_CHECK(ec == errc::fault_latched);
            return;
        }
        FERRULE_CHECK(!ec);
        ++started;
        active = true;
        done_seen = false;
        transport_failed = false;
        have_wait = false;
        quiet_since_send = false;
        sends = 0;
        max_sends = connect ? cfg.connect_attempts : 1 + cfg.retries;
        FERRULE_CHECK(s.busy());
        FERRULE_CHECK(s.start(cmd) == errc::busy);
    }

    session_action call_next() {
        const auto a = s.next(now);
        if (have_wait && now < wait_deadline)
            FERRULE_CHECK(a.what == session_action::kind::wait && a.deadline == wait_deadline);
        if (active && quiet_since_send && now < reply_due && !transport_failed)
            FERRULE_CHECK(a.what == session_action::kind::wait);
        switch (a.what) {
        case session_action::kind::idle: FERRULE_CHECK(!active && !s.busy()); break;
        case session_action::kind::wait:
            FERRULE_CHECK(active && !done_seen && s.busy());
            FERRULE_CHECK(a.deadline > now && a.deadline != never);
            have_wait = true;
            wait_deadline = a.deadline;
            break;
        case session_action::kind::send: {
            FERRULE_CHECK(active && !done_seen);
            have_wait = false;
            ++sends;
            FERRULE_CHECK(sends <= max_sends);
            FERRULE_CHECK(a.discard_input == cfg.discard_stale_input);
            std::array<std::uint8_t, max_request_length> want{};
            const auto n = encode(cmd, want);
            FERRULE_CHECK(n.has_value() && *n == a.bytes.size());
            for (std::size_t i = 0; i < *n; ++i) FERRULE_CHECK(a.bytes[i] == want[i]);
            const duration t = cfg.format.chars_time(a.bytes.size());
            const bool measures = find_spec(cmd.mnemonic, cmd.id != command::no_id)->measures;
            reply_due = now + t + (measures ? cfg.measurement_timeout : cfg.command_timeout);
            quiet_since_send = true;
            if (cfg.discard_stale_input) lines = line_checker{};
            break;
        }
        case session_action::kind::done:
            FERRULE_CHECK(!s.busy());
            if (active && !done_seen) on_done();
            break;
        }
        return a;
    }

    void on_done() {
        done_seen = true;
        active = false;
        const std::error_code ec = s.error();
        if (!ec) {
            ++succeeded;
            const reply& r = s.reply();
            FERRULE_CHECK(!check_answers(cmd, r));
            if (cmd.id != command::no_id) FERRULE_CHECK(r.id == cmd.id);
            FERRULE_CHECK(s.consecutive_failures() == 0);
        } else if (transport_failed && ec == errc::transport) {
            ++failed; // finished by on_transport_error(), a failed transaction too
        } else {
            ++failed;
            if (ec.category() == device_category()) {
                FERRULE_CHECK(s.reply().kind == reply_kind::error);
                FERRULE_CHECK(ec.value() == s.reply().error_code);
                if (cmd.id != command::no_id) FERRULE_CHECK(s.reply().id == cmd.id);
            } else {
                FERRULE_CHECK(ec == errc::timeout || ec == errc::malformed);
                FERRULE_CHECK(sends == max_sends);
            }
        }
        FERRULE_CHECK(s.stats().succeeded == succeeded);
        FERRULE_CHECK(s.stats().failed == failed);
        FERRULE_CHECK(s.stats().transactions == started);
    }

    void receive(std::span<const std::uint8_t> bytes) {
        if (bytes.empty()) return;
        now += cfg.format.chars_time(bytes.size());
        s.on_receive(bytes, now);
        lines.feed(bytes, cmd);
        have_wait = false;
        quiet_since_send = false;
    }

    void receive_random() {
        std::array<std::uint8_t, 40> buf{};
        const std::size_t n = in.ConsumeIntegralInRange<std::size_t>(1, buf.size());
        for (std::size_t i = 0; i < n; ++i) {
            // Mostly the characters answers are made of.
            static constexpr char alphabet[] = "g0123456789+-?@Ecq\r\n";
            buf[i] =
                in.ConsumeBool()
                    ? static_cast<std::uint8_t>(
                          alphabet[in.ConsumeIntegralInRange<std::size_t>(0, sizeof alphabet - 2)])
                    : in.ConsumeIntegral<std::uint8_t>();
        }
        receive(std::span<const std::uint8_t>(buf.data(), n));
    }

    // An answer shaped after the command: right, from another ID, an error, the startup
    // string, a tracking line; then maybe damaged.
    void receive_answer() {
        writer w;
        w.put('g');
        const int shape = in.ConsumeIntegralInRange<int>(0, 6);
        const unsigned id = cmd.id == command::no_id || shape == 1
                                ? in.ConsumeIntegralInRange<unsigned>(0, 99)
                                : cmd.id;
        if (id < 10 && in.ConsumeIntegralInRange<int>(0, 7) == 0) w.put('0'); // g03… (§11.2)
        w.put_id(id);
        switch (shape) {
        case 2: // error, with a buffer status for sNq
            w.put('@');
            w.put('E');
            w.put_id(in.ConsumeIntegralInRange<unsigned>(200, 299) / 10);
            w.put(static_cast<char>('0' + in.ConsumeIntegralInRange<int>(0, 9)));
            if (in.ConsumeBool()) w.put_value(in.ConsumeIntegralInRange<int>(0, 2), false);
            break;
        case 3: w.put('?'); break; // startup string / generic acknowledge
        case 4:                    // a tracking line
            w.put('h');
            w.put_value(in.ConsumeIntegral<std::int32_t>(), true);
            break;
        default: { // the answer the command expects (or a set ack with values)
            for (char c : cmd.mnemonic.view()) w.put(c);
            const int values = in.ConsumeIntegralInRange<int>(0, 4);
            for (int i = 0; i < values; ++i) {
                const std::int32_t v = i == 0 && cmd.param_count > 0 && in.ConsumeBool()
                                           ? cmd.params[0]
                                           : in.ConsumeIntegralInRange<std::int32_t>(-3, 100000);
                w.put_value(v, in.ConsumeBool());
            }
            if (values == 0 || in.ConsumeIntegralInRange<int>(0, 3) == 0) w.put('?');
            break;
        }
        }
        w.put('\r');
        w.put('\n');
        const std::uint8_t damage = in.ConsumeIntegral<std::uint8_t>();
        if (damage < 24 && w.n > 0)
            w.buf[in.ConsumeIntegralInRange<std::size_t>(0, w.n - 1)] ^=
                static_cast<std::uint8_t>(in.ConsumeIntegralInRange<unsigned>(1, 255));
        else if (damage < 32)
            w.buf[w.n - 2] = 'x'; // CR lost
        now += std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 600000));
        std::size_t pos = 0;
        while (pos < w.n) {
            const std::size_t len = in.ConsumeIntegralInRange<std::size_t>(1, w.n - pos);
            receive(std::span<const std::uint8_t>(w.buf.data() + pos, len));
            pos += len;
        }
    }

    void step() {
        switch (in.ConsumeIntegralInRange<int>(0, 12)) {
        case 0:
        case 1:
        case 2: call_next(); break;
        case 3:
            now += std::chrono::microseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 50000));
            break;
        case 4:
            now += std::chrono::milliseconds(in.ConsumeIntegralInRange<std::uint32_t>(0, 6000));
            break;
        case 5:
            if (have_wait && wait_deadline - 1ns > now)
                now = wait_deadline - (in.ConsumeBool() ? 1ns : 0ns);
            break;
        case 6:
        case 7: receive_random(); break;
        case 8:
        case 9:
        case 10: receive_answer(); break;
        case 11:
            if (in.ConsumeIntegral<std::uint8_t>() < 16 && s.busy()) {
                s.on_transport_error(ferrule::error(errc::transport));
                transport_failed = true;
                have_wait = false;
                FERRULE_CHECK(!s.busy() && s.error() == errc::transport);
            }
            break;
        default:
            if (!s.busy()) {
                if (active && !done_seen) on_done();
                s.clear();
                FERRULE_CHECK(s.next(now).what == session_action::kind::idle);
                have_wait = false;
            }
            break;
        }
    }

    void drain() {
        if (!active) return;
        const duration per_send =
            cfg.measurement_timeout + cfg.format.chars_time(max_request_length) + 1ms;
        const time_point limit = now + (max_sends + 1) * per_send;
        for (unsigned i = 0; i < 4 * max_sends + 8; ++i) {
            const auto a = call_next();
            if (a.what == session_action::kind::done) break;
            FERRULE_CHECK(a.what != session_action::kind::idle);
            if (a.what == session_action::kind::wait) now = a.deadline;
            FERRULE_CHECK(now <= limit);
        }
        FERRULE_CHECK(done_seen && !active);
    }
};

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    FuzzedDataProvider in(data, size);
    sensor_config cfg;
    constexpr std::uint32_t bauds[] = {9600, 19200, 115200};
    cfg.format.baud = bauds[in.ConsumeIntegralInRange<std::size_t>(0, 2)];
    cfg.retries = in.ConsumeIntegralInRange<unsigned>(0, 3);
    cfg.connect_attempts = in.ConsumeIntegralInRange<unsigned>(1, 4);
    cfg.fault_threshold = in.ConsumeIntegralInRange<unsigned>(0, 3);
    cfg.retry_device_errors = in.ConsumeBool();
    cfg.multi_drop = in.ConsumeBool();
    cfg.discard_stale_input = in.ConsumeBool();
    if (in.ConsumeBool()) cfg.command_timeout = 50ms;
    if (in.ConsumeBool()) cfg.measurement_timeout = 700ms;

    harness h(in, cfg);
    for (int tx = 0; tx < 4 && in.remaining_bytes() > 0; ++tx) {
        h.start();
        for (int k = 0; k < 40 && h.active && !h.done_seen && in.remaining_bytes() > 0; ++k)
            h.step();
        h.drain();
        if (h.done_seen || !h.active) h.s.clear();
    }
    return 0;
}
