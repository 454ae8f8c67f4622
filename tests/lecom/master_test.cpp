// LECOM master session against a scripted drive on mock_serial, in virtual time.
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/lecom/access.hpp"
#include "ferrule/lecom/master.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule::lecom;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::script_step;
using ferrule::session_action;
using ferrule::time_point;
using bytes = std::vector<std::uint8_t>;

namespace {

const ferrule::serial_format fmt = lenze_4900.format; // 9600 8E1

bytes wire(const frame& f) {
    bytes out(max_frame_length);
    out.resize(*encode(f, out));
    return out;
}

// lecom.md §4.1: read C46 @01 and the drive's answers.
const bytes read46{0x04, 0x30, 0x31, 0x34, 0x36, 0x05};
const bytes reply46{0x02, 0x34, 0x36, 0x33, 0x35, 0x2E, 0x34, 0x03, 0x1D}; // 35.4
const bytes fault46{0x02, 0x34, 0x36, 0x3F, 0x03, 0x3E};
const bytes no_code46{0x02, 0x34, 0x36, 0x04};
const bytes reply68{0x02, 0x36, 0x38, 0x48, 0x30, 0x39, 0x30, 0x30, 0x03, 0x4C}; // C68 = H0900
// write C11 = 95.2 @34, and the broadcast C40 = 0.
const bytes write11{0x04, 0x33, 0x34, 0x02, 0x31, 0x31, 0x39, 0x35, 0x2E, 0x32, 0x03, 0x13};
const bytes broadcast40{0x04, 0x30, 0x30, 0x02, 0x34, 0x30, 0x30, 0x03, 0x37};
const bytes ack_{ack};
const bytes nak_{nak};
const bytes eot_{eot};

const value v95_2 = decimal_fixed(952'000);

script_step answer(const bytes& req, const bytes& rsp, ferrule::duration delay = 20ms) {
    script_step s;
    s.expect = req;
    s.reply = rsp;
    s.delay = delay;
    return s;
}
script_step silent(const bytes& req) {
    script_step s;
    s.expect = req;
    return s;
}

// Start times of the session's telegrams (a byte after >= 1 ms of silence on its side).
std::vector<time_point> request_starts(const mock_serial& line) {
    std::vector<time_point> starts;
    time_point last_end{};
    bool first = true;
    for (const auto& b : line.wire()) {
        if (b.origin != ferrule::wire_byte::from::session) continue;
        if (first || b.start - last_end >= 1ms) starts.push_back(b.start);
        first = false;
        last_end = b.end;
    }
    return starts;
}

// End of the last byte the drive sent.
time_point last_reply_end(const mock_serial& line) {
    time_point t{};
    for (const auto& b : line.wire())
        if (b.origin == ferrule::wire_byte::from::peer) t = b.end;
    return t;
}

} // namespace

TEST_CASE("a read takes request wire time + drive delay + reply wire time, exactly",
          "[lecom][master][timing]") {
    const std::array<script_step, 1> steps{answer(read46, reply46, 20ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    const auto v = read(line, m, 1, code(46));
    REQUIRE(v);
    CHECK(v->fixed == 354'000);
    CHECK(peer.mismatches() == 0);
    CHECK(m.attempts() == 1);
    CHECK(m.reply().kind == frame_kind::data);
    CHECK(m.reply().code == code(46));
    CHECK(m.request().kind == frame_kind::receive);
    CHECK(bytes(m.request_bytes().begin(), m.request_bytes().end()) == read46);
    // 6 + 9 characters of 11 bits at 9600 Bd: 6.875 ms + 20 ms + 10.3125 ms.
    CHECK(line.now() == time_point{} + fmt.chars_time(6) + 20ms + fmt.chars_time(9));
    CHECK(line.now() == time_point{} + 37'187'500ns);
    CHECK(m.stats().transactions == 1);
    CHECK(m.stats().succeeded == 1);
}

TEST_CASE("back-to-back reads keep the turnaround after each reply", "[lecom][master][timing]") {
    master_config cfg;
    cfg.turnaround = 3ms;
    const std::array<script_step, 3> steps{answer(read46, reply46, 20ms),
                                           answer(read46, reply46, 15ms),
                                           answer(read46, reply46, 20ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    for (int i = 0; i < 3; ++i) REQUIRE(read(line, m, 1, code(46)));
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 3);
    CHECK(starts[0] == time_point{}); // nothing before: no wait
    CHECK(starts[1] - starts[0] == fmt.chars_time(6) + 20ms + fmt.chars_time(9) + 3ms);
    CHECK(starts[2] - starts[1] == fmt.chars_time(6) + 15ms + fmt.chars_time(9) + 3ms);
}

TEST_CASE("no reply: resent at the deadline, then a timeout", "[lecom][master]") {
    const std::array<script_step, 3> steps{silent(read46), silent(read46), silent(read46)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    CHECK(read(line, m, 1, code(46)).error() == errc::timeout);
    CHECK(m.error() == errc::timeout);
    CHECK(m.attempts() == 3); // 1 + retries (2)
    CHECK(m.stats().timeouts == 3);
    CHECK(m.stats().resends == 2);
    CHECK(m.stats().failed == 1);
    CHECK(peer.finished());
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 3);
    for (std::size_t i = 1; i < starts.size(); ++i)
        CHECK(starts[i] - starts[i - 1] == fmt.chars_time(6) + response_timeout);
    CHECK(line.now() == starts[2] + fmt.chars_time(6) + response_timeout);
}

TEST_CASE("a timeout, then the resend is answered", "[lecom][master]") {
    master_config cfg;
    cfg.turnaround = 2ms;
    const std::array<script_step, 2> steps{silent(read46), answer(read46, reply46)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    const auto v = read(line, m, 1, code(46));
    REQUIRE(v);
    CHECK(m.attempts() == 2);
    CHECK(m.stats().timeouts == 1);
    CHECK(m.stats().resends == 1);
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 2);
    // The turnaround counts from the timeout as it does from a reply.
    CHECK(starts[1] - starts[0] == fmt.chars_time(6) + response_timeout + 2ms);
}

TEST_CASE("a bad BCC from the drive is resent", "[lecom][master]") {
    auto broken = answer(read46, reply46);
    broken.corrupt_index = 8; // the BCC
    broken.corrupt_mask = 0x01;
    const std::array<script_step, 2> steps{broken, answer(read46, reply46)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE(read(line, m, 1, code(46)));
    CHECK(m.attempts() == 2);
    CHECK(m.stats().bad_checksums == 1);
    // The resend goes out right after the bad reply's last byte (turnaround 0).
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 2);
    CHECK(starts[1] == starts[0] + fmt.chars_time(6) + 20ms + fmt.chars_time(9));

    master_config once;
    once.retries = 0;
    const std::array<script_step, 1> again{broken};
    ferrule::script_peer peer2(again);
    mock_serial line2(fmt, &peer2);
    master m2(once);
    CHECK(read(line2, m2, 1, code(46)).error() == errc::bad_checksum);
}

TEST_CASE("the drive's checksum-fault reply ? is resent, and stays a device error",
          "[lecom][master]") {
    const std::array<script_step, 3> steps{answer(read46, fault46), answer(read46, fault46),
                                           answer(read46, fault46)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    const auto r = read(line, m, 1, code(46));
    CHECK(r.error() == device_errc::checksum_fault);
    CHECK(std::error_code(r.error()).category() == device_category());
    CHECK(m.attempts() == 3);
    CHECK(m.stats().device_errors == 3);
    CHECK(m.reply().kind == frame_kind::fault);
    CHECK(peer.finished());
}

TEST_CASE("STX code EOT: the code does not exist, never resent", "[lecom][master]") {
    const std::array<script_step, 1> steps{answer(read46, no_code46)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    const auto r = read(line, m, 1, code(46));
    CHECK(r.error() == device_errc::code_does_not_exist);
    CHECK(std::error_code(r.error()).message() == "the drive has no such code");
    CHECK(m.attempts() == 1);
    CHECK(m.stats().device_errors == 1);
    CHECK(m.stats().failed == 1);
}

TEST_CASE("the 4900's bare EOT and bare NAK to a RECEIVE", "[lecom][master]") {
    const std::array<script_step, 2> steps{answer(read46, eot_), answer(read46, nak_)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master_config cfg;
    cfg.retries = 0;
    master m(cfg);
    CHECK(read(line, m, 1, code(46)).error() == device_errc::code_does_not_exist);
    CHECK(read(line, m, 1, code(46)).error() == device_errc::checksum_fault);

    // A bare NAK is a fault of the line: resent like `?`.
    const std::array<script_step, 2> retry{answer(read46, nak_), answer(read46, reply46)};
    ferrule::script_peer peer2(retry);
    mock_serial line2(fmt, &peer2);
    master m2;
    CHECK(read(line2, m2, 1, code(46)));
    CHECK(m2.attempts() == 2);
}

TEST_CASE("NAK to a SEND is resent (it also means a parity fault), then refused",
          "[lecom][master]") {
    const std::array<script_step, 4> steps{answer(write11, nak_), answer(write11, ack_),
                                           answer(write11, nak_), answer(write11, nak_)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master_config cfg;
    cfg.retries = 1;
    master m(cfg);
    CHECK_FALSE(write(line, m, 34, code(11), v95_2));
    CHECK(m.attempts() == 2);
    CHECK(m.reply().kind == frame_kind::ack);
    const auto ec = write(line, m, 34, code(11), v95_2);
    CHECK(ec == device_errc::write_refused);
    CHECK(m.attempts() == 2);
    CHECK(m.stats().device_errors == 3);
    CHECK(peer.finished());
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("replies of the wrong form are malformed", "[lecom][master]") {
    master_config cfg;
    cfg.retries = 0;
    const bytes write_reply = wire({frame_kind::data, 0, code(11), v95_2});
    const std::array<script_step, 3> steps{answer(read46, ack_), answer(write11, write_reply),
                                           answer(write11, eot_)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    CHECK(read(line, m, 1, code(46)).error() == errc::malformed); // ACK to RECEIVE
    CHECK(write(line, m, 34, code(11), v95_2) == errc::malformed);
    CHECK(write(line, m, 34, code(11), v95_2) == errc::malformed);
    CHECK(m.stats().malformed == 3);
}

TEST_CASE("a reply echoing another code is unexpected_type", "[lecom][master]") {
    const bytes fault68 = wire({frame_kind::fault, 0, code(68), {}});
    const bytes no_code68 = wire({frame_kind::no_code, 0, code(68), {}});
    const bytes reply46_ext = wire({frame_kind::data, 0, extended_code(46, 0), decimal_fixed(1)});
    const std::array<script_step, 4> steps{answer(read46, reply68), answer(read46, fault68),
                                           answer(read46, no_code68), answer(read46, reply46_ext)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master_config cfg;
    cfg.retries = 0;
    master m(cfg);
    for (int i = 0; i < 4; ++i) CHECK(read(line, m, 1, code(46)).error() == errc::unexpected_type);
    CHECK(m.stats().malformed == 4);
    // With a resend left, the next good reply wins.
    const std::array<script_step, 2> retry{answer(read46, reply68), answer(read46, reply46)};
    ferrule::script_peer peer2(retry);
    mock_serial line2(fmt, &peer2);
    master m2;
    CHECK(read(line2, m2, 1, code(46)));
}

TEST_CASE("a broadcast gets no reply: the session waits the spacing, then finishes",
          "[lecom][master]") {
    const bytes group40 = wire(write_request(20, code(40), decimal_fixed(0)));
    const std::array<script_step, 3> steps{silent(broadcast40), silent(group40),
                                           answer(read46, reply46)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE_FALSE(m.start_write(0, code(40), decimal_fixed(0)));
    CHECK(ferrule::run(line, m) == errc::no_response_expected);
    CHECK(m.attempts() == 1);
    CHECK(line.now() == time_point{} + fmt.chars_time(9) + processing_time);
    CHECK_FALSE(write(line, m, 20, code(40), decimal_fixed(0))); // write() returns {}
    REQUIRE(read(line, m, 1, code(46)));
    CHECK(peer.mismatches() == 0);
    CHECK(m.stats().transactions == 3);
    CHECK(m.stats().succeeded == 1);
    CHECK(m.stats().failed == 0);
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 3);
    CHECK(starts[1] == starts[0] + fmt.chars_time(9) + processing_time);
    CHECK(starts[2] == starts[1] + fmt.chars_time(9) + processing_time);
}

TEST_CASE("start refuses what no drive would answer or cannot be sent", "[lecom][master]") {
    master m;
    CHECK(m.start_read(0, code(46)) == errc::invalid_argument);  // broadcast
    CHECK(m.start_read(30, code(46)) == errc::invalid_argument); // group
    CHECK(m.start_read(100, code(46)) == errc::invalid_argument);
    CHECK(m.start_read(1, code_address{7000, 0, false}) == errc::invalid_argument);
    CHECK(m.start_read(1, code_address{39, 1, false}) == errc::invalid_argument);
    CHECK(m.start_write(100, code(46), v95_2) == errc::invalid_argument);
    value bad = v95_2;
    bad.format = value_format::hex; // 1 digit
    bad.digits = 1;
    CHECK(m.start_write(1, code(46), bad) == errc::invalid_argument);
    CHECK(m.stats().transactions == 0);
    CHECK(m.next(time_point{}).what == session_action::kind::idle);
    REQUIRE_FALSE(m.start_read(1, extended_code(1002, 0)));
    CHECK(m.start_read(1, code(46)) == errc::busy);
    CHECK(m.busy());
}

TEST_CASE("a refused start leaves the last request as it was", "[lecom][master]") {
    const std::array<script_step, 1> steps{answer(read46, reply46)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE(read(line, m, 1, code(46)));
    value bad = *string("OK");
    bad.bytes[1] = etx; // would cut the telegram
    CHECK(m.start_write(34, code(11), bad) == errc::invalid_argument);
    CHECK(m.start_write(34, code(11), bad) == errc::invalid_argument);
    CHECK(bytes(m.request_bytes().begin(), m.request_bytes().end()) == read46);
    CHECK(m.request().kind == frame_kind::receive);
    CHECK(m.reply().value.fixed == 354'000);
}

TEST_CASE("stale input is dropped before the request", "[lecom][master]") {
    const bytes noise{0x55, 0x06, 0x15};
    const std::array<script_step, 1> steps{answer(read46, reply46)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    line.inject(noise, time_point{});
    line.advance(5ms);
    master m;
    REQUIRE(read(line, m, 1, code(46)));
    CHECK(line.discarded() == 3);
    CHECK(m.stats().stale_bytes == 0);
    CHECK(m.attempts() == 1);
}

TEST_CASE("without discarding, a stale ACK would be taken as the reply", "[lecom][master]") {
    // Why discard_stale_input is the default: the replies decoder cannot tell an old NAK or
    // EOT from the answer to the request.
    master_config cfg;
    cfg.discard_stale_input = false;
    cfg.retries = 0;
    const std::array<script_step, 1> steps{answer(read46, reply46)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    line.inject(eot_, time_point{});
    line.advance(5ms);
    master m(cfg);
    CHECK(read(line, m, 1, code(46)).error() == device_errc::code_does_not_exist);
}

TEST_CASE("bytes behind the reply, and bytes between transactions, are stale", "[lecom][master]") {
    master_config cfg;
    cfg.turnaround = 1ms;
    master m(cfg);
    const time_point t0 = time_point{} + 1s;
    REQUIRE_FALSE(m.start_read(1, code(46)));
    REQUIRE(m.next(t0).what == session_action::kind::send);
    bytes chunk = reply46;
    chunk.insert(chunk.end(), {0x06, 0x41});
    const time_point end = t0 + 40ms;
    m.on_receive(chunk, end);
    REQUIRE(m.next(end).what == session_action::kind::done);
    CHECK_FALSE(m.error());
    CHECK(m.reply().value.fixed == 354'000);
    CHECK(m.stats().stale_bytes == 2);
    // Noise while idle moves the next request: 1 ms after it.
    m.on_receive(bytes{0x7F}, end + 5ms);
    CHECK(m.stats().stale_bytes == 3);
    m.clear();
    REQUIRE_FALSE(m.start_read(1, code(46)));
    const auto a = m.next(end + 5ms);
    REQUIRE(a.what == session_action::kind::wait);
    CHECK(a.deadline == end + 6ms);
    CHECK(m.next(end + 6ms).what == session_action::kind::send);
}

TEST_CASE("noise before the reply is skipped, noise alone is malformed at the deadline",
          "[lecom][master]") {
    const bytes noise{'x', 0x7F};
    auto noisy = answer(read46, reply46, 20ms);
    noisy.noise = noise;
    script_step only_noise = silent(read46);
    only_noise.noise = noise;
    const std::array<script_step, 2> steps{noisy, only_noise};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master_config cfg;
    cfg.retries = 0;
    master m(cfg);
    REQUIRE(read(line, m, 1, code(46)));
    CHECK(m.attempts() == 1);
    const time_point second = line.now();
    CHECK(read(line, m, 1, code(46)).error() == errc::malformed);
    CHECK(line.now() == second + fmt.chars_time(6) + response_timeout);
}

TEST_CASE("a reply under way at the deadline may finish, a broken one ends later",
          "[lecom][master][timing]") {
    // The first byte has arrived 0.85 ms before the deadline, the last one 8.2 ms after it.
    const auto late = response_timeout - 2ms;
    auto cut = answer(read46, reply46, late);
    cut.drop_index = 8; // BCC lost: the decoder waits for it
    const std::array<script_step, 2> steps{answer(read46, reply46, late), cut};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master_config cfg;
    cfg.retries = 0;
    master m(cfg);
    REQUIRE(read(line, m, 1, code(46)));
    CHECK(line.now() == time_point{} + fmt.chars_time(6) + late + fmt.chars_time(9));
    const time_point second = line.now();
    CHECK(read(line, m, 1, code(46)).error() == errc::malformed);
    CHECK(line.now() ==
          second + fmt.chars_time(6) + response_timeout + fmt.chars_time(max_reply_length));
}

TEST_CASE("a control character that cuts a reply short starts the next telegram",
          "[lecom][master]") {
    // As frame_decoder frames replies: STX '1' is cut by ACK, which is the reply to the SEND;
    // STX '4' is cut by EOT, which is the 4900's bare EOT to the RECEIVE.
    const bytes cut_by_ack{stx, '1', ack};
    const bytes cut_by_eot{stx, '4', eot};
    master_config cfg;
    cfg.retries = 0;
    const std::array<script_step, 2> steps{answer(write11, cut_by_ack), answer(read46, cut_by_eot)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    CHECK_FALSE(write(line, m, 34, code(11), v95_2));
    CHECK(m.reply().kind == frame_kind::ack);
    CHECK(read(line, m, 1, code(46)).error() == device_errc::code_does_not_exist);
    CHECK(m.reply().kind == frame_kind::eot);
    CHECK(m.stats().stale_bytes == 0);
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("a reply split into chunks with gaps is put together", "[lecom][master]") {
    auto split = answer(read46, reply46);
    split.chunk = 2;
    split.chunk_gap = 15ms; // LECOM has no character gap limit
    const std::array<script_step, 1> steps{split};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE(read(line, m, 1, code(46)));
    CHECK(line.now() == last_reply_end(line));
}

TEST_CASE("extended addressing reads with !CCCCSS and checks its echo", "[lecom][master]") {
    const bytes req = wire(read_request(1, extended_code(1002, 3)));
    const bytes rsp = wire({frame_kind::data, 0, extended_code(1002, 3), *hex(0x1234)});
    const std::array<script_step, 1> steps{answer(req, rsp)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    const auto v = read(line, m, 1, extended_code(1002, 3));
    REQUIRE(v);
    CHECK(v->hex == 0x1234);
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("a transport error ends the LECOM transaction", "[lecom][master]") {
    mock_serial line(fmt);
    line.fail_at(1); // the request's write
    master m;
    CHECK(read(line, m, 1, code(46)).error() == errc::transport);
    CHECK(line.writes() == 0);
    CHECK(m.error() == errc::transport);
    CHECK_FALSE(m.busy());
    CHECK(m.stats().failed == 1);
    m.clear();
    CHECK(m.next(line.now()).what == session_action::kind::idle);
}

TEST_CASE("a transport error after a broadcast still keeps its spacing", "[lecom][master]") {
    // Found by fuzz_lecom_master: the spacing was set when the broadcast finished, so a
    // transport error during it let the next request go out while the drives were busy.
    master m;
    const time_point t0 = time_point{} + 1s;
    REQUIRE_FALSE(m.start_write(0, code(40), decimal_fixed(0)));
    REQUIRE(m.next(t0).what == session_action::kind::send);
    m.on_transport_error(ferrule::error(errc::transport));
    CHECK(m.error() == errc::transport);
    REQUIRE_FALSE(m.start_read(1, code(46)));
    const auto a = m.next(t0 + 1ms);
    REQUIRE(a.what == session_action::kind::wait);
    CHECK(a.deadline == t0 + fmt.chars_time(broadcast40.size()) + processing_time);
}
