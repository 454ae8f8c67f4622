// MOVILINK master session against a scripted drive on mock_serial, in virtual time.
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/movilink/access.hpp"
#include "ferrule/movilink/cyclic.hpp"
#include "ferrule/movilink/master.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule::movilink;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::script_step;
using ferrule::time_point;
using bytes = std::vector<std::uint8_t>;

namespace {

const ferrule::serial_format fmt = default_format; // 9600 8E1
const auto char_time = fmt.char_time();

bytes wire(const telegram& t) {
    bytes out(max_telegram_size);
    out.resize(*encode(t, out));
    return out;
}

// M2 from SC01 Fig. 23: acyclic 3PD request and the drive's response.
const bytes m2_req{0x02, 0x01, 0x85, 0x00, 0x06, 0x20, 0x00, 0x0B, 0xB8, 0x13};
const bytes m2_rsp{0x1D, 0x01, 0x85, 0x02, 0x06, 0x00, 0x00, 0x06, 0x06, 0x9D};
const std::array<std::uint16_t, 3> m2_po{0x0006, 0x2000, 0x0BB8};

script_step answer(const bytes& req, const bytes& rsp, ferrule::duration delay = 5ms) {
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

} // namespace

TEST_CASE("M2 exchange: one request, one reply, exact wire timing", "[movilink][master]") {
    const std::array<script_step, 1> steps{answer(m2_req, m2_rsp, 5ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(m.busy());
    REQUIRE_FALSE(ferrule::run(line, m));
    CHECK(peer.mismatches() == 0);
    CHECK(m.attempts() == 1);
    CHECK(m.reply().pd == std::array<std::uint16_t, 3>{0x0206, 0x0000, 0x0606});
    // Start pause from t = 0, request, drive delay, reply.
    CHECK(line.now() == time_point{} + start_pause + fmt.chars_time(10) + 5ms + fmt.chars_time(10));
}

TEST_CASE("stale input before a request delays it until the bus is idle", "[movilink][master]") {
    const std::array<script_step, 1> steps{answer(m2_req, m2_rsp)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    const bytes noise{0x55, 0xAA, 0x1D};
    line.inject(noise, time_point{} + 1ms);
    master m;
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    REQUIRE_FALSE(ferrule::run(line, m));
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 1);
    // The request starts one start pause after the last stale byte.
    CHECK(starts[0] == time_point{} + 1ms + fmt.chars_time(3) + start_pause);
    CHECK(m.stats().stale_bytes == 3);
}

TEST_CASE("no reply: 1 + 4 resends at the response timeout, then the fault latches",
          "[movilink][master]") {
    const std::array<script_step, 5> steps{silent(m2_req), silent(m2_req), silent(m2_req),
                                           silent(m2_req), silent(m2_req)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::timeout);
    CHECK(m.attempts() == 5);
    CHECK(m.stats().timeouts == 5);
    CHECK(m.stats().resends == 4);
    CHECK(m.fault_latched());
    CHECK(peer.finished());
    // Each attempt: start pause (first only; later the 50 ms wait exceeds it), request, timeout.
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 5);
    for (std::size_t i = 1; i < starts.size(); ++i)
        CHECK(starts[i] - starts[i - 1] == fmt.chars_time(10) + response_timeout);
    CHECK(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po) == errc::fault_latched);
    m.reset_fault();
    CHECK_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
}

TEST_CASE("the fault threshold counts failures across transactions", "[movilink][master]") {
    master_config cfg;
    cfg.retries = 1;
    cfg.fault_threshold = 3;
    const std::array<script_step, 4> steps{silent(m2_req), silent(m2_req), answer(m2_req, m2_rsp),
                                           silent(m2_req)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::timeout);
    CHECK(m.attempts() == 2);
    CHECK_FALSE(m.fault_latched());
    CHECK(m.consecutive_failures() == 2);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK_FALSE(ferrule::run(line, m)); // a good reply clears the count
    CHECK(m.consecutive_failures() == 0);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::timeout);
    CHECK_FALSE(m.fault_latched());
}

TEST_CASE("a late reply: timeout, resend, and the late bytes are taken as the answer",
          "[movilink][master]") {
    // MOVILINK telegrams carry no sequence number: a reply that comes after the response
    // timeout, while the resend of the same request is awaited, answers that resend. The
    // resend's own reply then arrives outside any transaction and delays the next request.
    const std::array<script_step, 3> steps{answer(m2_req, m2_rsp, 60ms), answer(m2_req, m2_rsp),
                                           answer(m2_req, m2_rsp)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    REQUIRE_FALSE(ferrule::run(line, m));
    CHECK(m.attempts() == 2);
    CHECK(m.stats().timeouts == 1);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    REQUIRE_FALSE(ferrule::run(line, m));
    CHECK(m.stats().stale_bytes == 10);
    CHECK(peer.finished());
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 3);
    CHECK(starts[1] == starts[0] + fmt.chars_time(10) + response_timeout);
    // The third request waits for a start pause after the stale reply's last byte, which
    // queued behind the late reply on the line.
    const auto late_reply_end = starts[0] + fmt.chars_time(10) + 60ms + fmt.chars_time(10);
    CHECK(starts[2] == late_reply_end + fmt.chars_time(10) + start_pause);
}

TEST_CASE("a reply with a dropped byte ends in a character-delay error, then a resend",
          "[movilink][master]") {
    auto broken = answer(m2_req, m2_rsp);
    broken.drop_index = 4;
    const std::array<script_step, 2> steps{broken, answer(m2_req, m2_rsp)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    REQUIRE_FALSE(ferrule::run(line, m));
    CHECK(m.attempts() == 2);
    CHECK(m.stats().invalid_replies == 1);
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 2);
    // 9 of 10 bytes arrive; the frame is given up one character + max delay after the last.
    const auto last_byte = starts[0] + fmt.chars_time(10) + 5ms + fmt.chars_time(9);
    CHECK(starts[1] >= last_byte + char_time + max_char_delay);
    CHECK(starts[1] <= last_byte + char_time + max_char_delay + start_pause);
}

TEST_CASE("retries exhausted by a dropped byte report frame_gap", "[movilink][master]") {
    master_config cfg;
    cfg.retries = 0;
    auto broken = answer(m2_req, m2_rsp);
    broken.drop_index = 9;
    const std::array<script_step, 1> steps{broken};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::frame_gap);
}

TEST_CASE("a corrupted byte is a BCC error, then a resend", "[movilink][master]") {
    master_config cfg;
    cfg.retries = 0;
    auto broken = answer(m2_req, m2_rsp);
    broken.corrupt_index = 6;
    broken.corrupt_mask = 0x01;
    const std::array<script_step, 1> steps{broken};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::bad_checksum);
    CHECK(m.attempts() == 1);
    CHECK(m.consecutive_failures() == 1);
}

TEST_CASE("a reply split into chunks: short gaps pass, long gaps break the telegram",
          "[movilink][master]") {
    master_config cfg;
    cfg.retries = 0;
    auto split = answer(m2_req, m2_rsp);
    split.chunk = 3;
    split.chunk_gap = 3ms; // below the 3.43 ms character delay limit
    auto torn = split;
    torn.chunk_gap = 4ms; // above it
    const std::array<script_step, 2> steps{split, torn};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK_FALSE(ferrule::run(line, m));
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::frame_gap);

    // With the check disabled (USB adapters deliver in bursts) the torn reply is accepted.
    cfg.max_char_delay = {};
    const std::array<script_step, 1> again{torn};
    ferrule::script_peer peer2(again);
    mock_serial line2(fmt, &peer2);
    master lenient(cfg);
    REQUIRE_FALSE(lenient.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK_FALSE(ferrule::run(line2, lenient));
}

TEST_CASE("noise before the reply breaks the attempt, the resend succeeds", "[movilink][master]") {
    const bytes noise{0x7F};
    auto noisy = answer(m2_req, m2_rsp, 10ms);
    noisy.noise = noise;
    const std::array<script_step, 2> steps{noisy, answer(m2_req, m2_rsp)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    REQUIRE_FALSE(ferrule::run(line, m));
    CHECK(m.attempts() == 2);
    CHECK(m.stats().invalid_replies == 1);
    CHECK(m.reply().pd[0] == 0x0206);
}

TEST_CASE("replies from another address or with another TYP are rejected", "[movilink][master]") {
    master_config cfg;
    cfg.retries = 0;
    cfg.fault_threshold = 0;
    const bytes other_adr = wire({direction::response, 2, pdu_type::pd3_acyclic, {}, {1, 2, 3}});
    const bytes other_typ = wire({direction::response, 1, pdu_type::pd3, {}, {1, 2, 3}});
    const bytes echo = m2_req; // a request echoed back (adapter hears itself)
    const std::array<script_step, 3> steps{answer(m2_req, other_adr), answer(m2_req, other_typ),
                                           answer(m2_req, echo)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::unexpected_address);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::unexpected_type);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::malformed);
    CHECK_FALSE(m.fault_latched());
}

TEST_CASE("point-to-point address 254 accepts the answering unit's address", "[movilink][master]") {
    const bytes req = wire({direction::request, 254, pdu_type::pd3_acyclic, {}, m2_po});
    const std::array<script_step, 1> steps{answer(req, m2_rsp)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE_FALSE(m.start_exchange(254, pdu_type::pd3_acyclic, m2_po));
    CHECK_FALSE(ferrule::run(line, m));
    CHECK(m.reply().address == 1);
}

TEST_CASE("a drive error reply is resent 4 times, then latches with the drive's code",
          "[movilink][master]") {
    const bytes d2{0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x7E, 0x00, 0x00, 0x00, 0x00, 0xEA};
    const bytes d4{0x1D, 0x01, 0x86, 0xB1, 0x00, 0x20, 0x7E, 0x08, 0x00, 0x00, 0x10, 0x6D};
    std::array<script_step, 5> steps{};
    steps.fill(answer(d2, d4));
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    const auto r = read_parameter(line, m, 1, 0x207E);
    REQUIRE_FALSE(r);
    CHECK(std::error_code(r.error()).category() == device_category());
    const auto f = fields_of(r.error());
    CHECK(f.error_class == 8);
    CHECK(f.code == 0);
    CHECK(f.additional == 0x0010);
    CHECK(std::error_code(r.error()).message().find("invalid parameter index") !=
          std::string::npos);
    CHECK(m.attempts() == 5);
    CHECK(m.stats().device_errors == 5);
    CHECK(m.fault_latched());
    CHECK(peer.finished());
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("with retry_device_errors off a drive error ends the transaction at once",
          "[movilink][master]") {
    master_config cfg;
    cfg.retry_device_errors = false;
    const bytes d2{0x02, 0x01, 0x86, 0x31, 0x00, 0x20, 0x7E, 0x00, 0x00, 0x00, 0x00, 0xEA};
    const bytes d4{0x1D, 0x01, 0x86, 0xB1, 0x00, 0x20, 0x7E, 0x08, 0x00, 0x00, 0x10, 0x6D};
    const std::array<script_step, 1> steps{answer(d2, d4)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    const auto r = read_parameter(line, m, 1, 0x207E);
    CHECK(fields_of(r.error()).additional == 0x10);
    CHECK(m.attempts() == 1);
    CHECK_FALSE(m.fault_latched());
}

TEST_CASE("D3: a read returns the drive's data word", "[movilink][master]") {
    const bytes req = wire({direction::request,
                            1,
                            pdu_type::param_acyclic,
                            param_channel::make(service::read, 0x2087),
                            {}});
    const bytes d3{0x1D, 0x01, 0x86, 0x31, 0x00, 0x20, 0x87, 0x00, 0x00, 0x00, 0x14, 0x18};
    const std::array<script_step, 1> steps{answer(req, d3)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    const auto r = read_parameter(line, m, 1, 0x2087);
    REQUIRE(r);
    CHECK(*r == 0x14);
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("broadcast and group requests expect no reply and keep 25 ms spacing",
          "[movilink][master]") {
    const bytes d7{0x02, 0xFF, 0x03, 0x00, 0x06, 0x10, 0x00, 0xE8};
    const bytes d8{0x02, 0x65, 0x85, 0x00, 0x06, 0x20, 0x00, 0x0B, 0xB8, 0x77};
    const std::array<script_step, 3> steps{silent(d7), silent(d8), answer(m2_req, m2_rsp)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    const std::array<std::uint16_t, 2> po2{0x0006, 0x1000};
    REQUIRE_FALSE(m.start_exchange(255, pdu_type::pd2, po2));
    CHECK(ferrule::run(line, m) == errc::no_response_expected);
    REQUIRE_FALSE(m.start_exchange(101, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::no_response_expected);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK_FALSE(ferrule::run(line, m));
    CHECK(peer.mismatches() == 0);
    CHECK(m.consecutive_failures() == 0);
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 3);
    CHECK(starts[1] == starts[0] + fmt.chars_time(8) + broadcast_spacing);
    CHECK(starts[2] == starts[1] + fmt.chars_time(10) + broadcast_spacing);
    // Nothing to read from a broadcast.
    CHECK(read_parameter(line, m, 255, 0x207E).error() == errc::no_response_expected);
}

TEST_CASE("cyclic PARAM types toggle the handshake bit and poll until the drive echoes it",
          "[movilink][master]") {
    const std::array<std::uint16_t, 3> po{0x0006, 0x07D0, 0};
    // First service: handshake 1 (the bit toggles from its initial 0). D6 is exactly this.
    const bytes d6{0x02, 0x01, 0x04, 0x71, 0x00, 0x20, 0x7E, 0x00, 0x00,
                   0x00, 0x00, 0x00, 0x06, 0x07, 0xD0, 0x00, 0x00, 0xF9};
    const bytes busy = wire(
        {direction::response, 1, pdu_type::param_3pd, {0x31, 0, 0x207E, 0}, {0x0407, 0x0100, 0}});
    const bytes done = wire({direction::response,
                             1,
                             pdu_type::param_3pd,
                             {0x71, 0, 0x207E, 0x0001D4C0},
                             {0x0407, 0x0200, 0}});
    // Second service: handshake back to 0.
    const bytes second =
        wire({direction::request, 1, pdu_type::param_3pd, {0x31, 0, 0x2087, 0}, po});
    const bytes second_done = wire({direction::response,
                                    1,
                                    pdu_type::param_3pd,
                                    {0x31, 0, 0x2087, 0x14},
                                    {0x0407, 0x0300, 0}});
    const std::array<script_step, 4> steps{answer(d6, busy), answer(d6, done),
                                           answer(second, second_done)};
    ferrule::script_peer peer(std::span<const script_step>(steps).first(3));
    mock_serial line(fmt, &peer);
    master m;
    REQUIRE_FALSE(
        m.start_parameter(1, pdu_type::param_3pd, param_channel::make(service::read, 0x207E), po));
    REQUIRE_FALSE(ferrule::run(line, m));
    CHECK(m.reply().param.data == 0x0001D4C0);
    CHECK(m.attempts() == 1);
    CHECK(m.stats().handshake_polls == 1);
    REQUIRE_FALSE(
        m.start_parameter(1, pdu_type::param_3pd, param_channel::make(service::read, 0x2087), po));
    REQUIRE_FALSE(ferrule::run(line, m));
    CHECK(m.reply().param.data == 0x14);
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
}

TEST_CASE("a transport error during a handshake poll does not leak into the next request",
          "[movilink][master]") {
    // Found by fuzz_movilink_master: the next transaction's first send was counted as a
    // handshake poll, so it ended with attempts() == 0.
    const std::array<std::uint16_t, 1> po{0x0006};
    const bytes busy =
        wire({direction::response, 1, pdu_type::param_1pd, {0x31, 0, 0x207E, 0}, {0x0407}});
    master m;
    REQUIRE_FALSE(
        m.start_parameter(1, pdu_type::param_1pd, param_channel::make(service::read, 0x207E), po));
    const time_point t0 = time_point{} + start_pause;
    REQUIRE(m.next(t0).what == ferrule::session_action::kind::send);
    // The drive still shows the old handshake bit: the session queues a poll.
    m.on_receive(busy, t0 + 30ms);
    REQUIRE(m.busy());
    REQUIRE(m.next(t0 + 30ms).what == ferrule::session_action::kind::wait);
    m.on_transport_error(ferrule::error(errc::transport));
    REQUIRE(m.error() == errc::transport);
    const std::array<std::uint16_t, 3> pd3{0x0006, 0, 0};
    REQUIRE_FALSE(m.start_exchange(255, pdu_type::pd3, pd3));
    const time_point t1 = t0 + 100ms;
    REQUIRE(m.next(t1).what == ferrule::session_action::kind::send);
    CHECK(m.error() == errc::no_response_expected);
    CHECK(m.attempts() == 1);
    CHECK(m.stats().handshake_polls == 0);
}

TEST_CASE("a drive that never echoes the handshake bit times out", "[movilink][master]") {
    master_config cfg;
    cfg.handshake_polls = 3;
    cfg.retries = 0;
    const std::array<std::uint16_t, 1> po{0x0006};
    const bytes busy =
        wire({direction::response, 1, pdu_type::param_1pd, {0x31, 0, 0x207E, 0}, {0x0407}});
    std::array<script_step, 4> steps{};
    for (auto& s : steps) {
        s.reply = busy;
        s.delay = 5ms;
    }
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m(cfg);
    REQUIRE_FALSE(
        m.start_parameter(1, pdu_type::param_1pd, param_channel::make(service::read, 0x207E), po));
    CHECK(ferrule::run(line, m) == errc::timeout);
    CHECK(m.stats().handshake_polls == 3);
    CHECK(peer.finished());
}

TEST_CASE("a 3PD cycle at 9600 baud costs exactly wire time + start pause + drive delay",
          "[movilink][master][timing]") {
    constexpr int cycles = 20;
    const auto delay = 4ms;
    const bytes req = wire({direction::request, 1, pdu_type::pd3, {}, m2_po});
    const bytes rsp = wire({direction::response, 1, pdu_type::pd3, {}, {0x0206, 0, 0x0606}});
    std::vector<script_step> steps(cycles, answer(req, rsp, delay));
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    for (int i = 0; i < cycles; ++i) {
        const auto pi = exchange(line, m, 1, m2_po); // PD only, 3 words: TYP 0x05
        REQUIRE(pi);
        CHECK(pi->count == 3);
        CHECK(pi->words[0] == 0x0206);
    }
    CHECK(peer.mismatches() == 0);
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == cycles);
    const auto cycle = start_pause + fmt.chars_time(10) + delay + fmt.chars_time(10);
    for (std::size_t i = 1; i < starts.size(); ++i) CHECK(starts[i] - starts[i - 1] == cycle);
    CHECK(line.now() == time_point{} + cycles * cycle);
}

TEST_CASE("cyclic exchange under the poll driver carries PO and a parameter service",
          "[movilink][master][cyclic]") {
    const std::array<std::uint16_t, 3> po{0x0006, 0x1388, 0x01F4};
    const bytes pd_req = wire({direction::request, 1, pdu_type::pd3, {}, po});
    const bytes pd_rsp =
        wire({direction::response, 1, pdu_type::pd3, {}, {0x0407, 0x1388, 0x0100}});
    const bytes par_req =
        wire({direction::request, 1, pdu_type::param_3pd, {0x71, 0, 0x2087, 0}, po});
    const bytes par_rsp = wire({direction::response,
                                1,
                                pdu_type::param_3pd,
                                {0x71, 0, 0x2087, 0x14},
                                {0x0407, 0x1388, 0x0100}});
    const std::array<script_step, 4> steps{answer(pd_req, pd_rsp), answer(par_req, par_rsp),
                                           answer(pd_req, pd_rsp), answer(pd_req, pd_rsp)};
    ferrule::script_peer peer(steps);
    mock_serial line(fmt, &peer);
    master m;
    cyclic c(m, 1);
    for (std::size_t i = 0; i < 3; ++i) c.set_po(i, po[i]);
    ferrule::poll_driver drv(line, c);
    drv.step(); // the first cycle (PD only) is under way
    REQUIRE(c.request_parameter(param_channel::make(service::read, 0x2087)));
    CHECK_FALSE(c.request_parameter(param_channel::make(service::read, 0x2087)));
    while (c.cycles() < 4 && line.now() < time_point{} + 1s) {
        drv.step();
        line.advance(100us); // the rest of the main loop
    }
    CHECK(c.cycles() == 4);
    CHECK(c.failed_cycles() == 0);
    CHECK(c.pi(0) == 0x0407);
    CHECK(c.pi(2) == 0x0100);
    REQUIRE(c.parameter_done());
    CHECK_FALSE(c.parameter_error());
    CHECK(c.parameter_value() == 0x14);
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("start() refuses what cannot be sent", "[movilink][master]") {
    master m;
    const std::array<std::uint16_t, 3> po{};
    CHECK(m.start_exchange(253, pdu_type::pd3, po) == errc::invalid_argument);
    CHECK(m.start_exchange(200, pdu_type::pd3, po) == errc::invalid_argument);
    CHECK(m.start_exchange(1, pdu_type::pd2, po) == errc::invalid_argument);
    CHECK(m.start_exchange(1, static_cast<pdu_type>(0x07), po) == errc::invalid_argument);
    CHECK(m.start_parameter(1, pdu_type::pd3, param_channel::make(service::read, 1), po) ==
          errc::invalid_argument);
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3, po));
    CHECK(m.start_exchange(1, pdu_type::pd3, po) == errc::busy);
}

TEST_CASE("a transport error ends the transaction", "[movilink][master]") {
    mock_serial line(fmt);
    line.fail_at(2); // the request's write: operation 1 waits out the start pause
    master m;
    REQUIRE_FALSE(m.start_exchange(1, pdu_type::pd3_acyclic, m2_po));
    CHECK(ferrule::run(line, m) == errc::transport);
    CHECK(line.writes() == 0);
    CHECK(m.error() == errc::transport);
    CHECK_FALSE(m.busy());
}
