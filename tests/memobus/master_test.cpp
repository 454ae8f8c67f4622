// Extended MEMOBUS master against scripted controllers on mock_serial, in virtual time: the
// golden requests of protocols/memobus.md §8.1 byte for byte with the serial counting up and
// wrapping, stale serials, the response type, the controller's error codes, timeouts and
// resends at exact times, garbage, and the blocking access helpers against a small
// in-test controller.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <deque>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/memobus/access.hpp"
#include "ferrule/memobus/master.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule::memobus;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::script_step;
using ferrule::time_point;
using octets = std::vector<std::uint8_t>;

namespace {

// A fast line: the test is about the session, not the wire (2.5 µs a byte).
const ferrule::serial_format fast{4'000'000, 8, ferrule::parity::none, 1};

request make(sfc f, std::uint16_t address, std::uint16_t count) {
    request r;
    r.function = f;
    r.address = address;
    r.count = count;
    return r;
}

octets command(const request& r, std::uint8_t serial) {
    octets out(max_message);
    const auto n = encode_command(r, serial, out);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

// A command's 05 / 06 / 08 echo: type 0x19 and the CPU nibbles swapped (§3.2).
octets echo(octets m) {
    m[0] = 0x19;
    m[16] = swap_nibbles(m[16]);
    return m;
}

octets operator+(octets a, const octets& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

// Script steps hold spans: their bytes live in this pool for the whole run.
std::span<const std::uint8_t> keep(octets bytes) {
    static std::deque<octets> pool;
    return pool.emplace_back(std::move(bytes));
}

script_step answer(octets req, octets rsp, ferrule::duration delay = 1ms) {
    script_step s;
    s.expect = keep(std::move(req));
    s.reply = keep(std::move(rsp));
    s.delay = delay;
    return s;
}
script_step silent(octets req) {
    script_step s;
    s.expect = keep(std::move(req));
    return s;
}

std::error_code transact(mock_serial& line, master& m, const request& r) {
    if (auto ec = m.start(r)) return ec;
    return ferrule::run(line, m);
}

// Start of each request on the wire.
std::vector<time_point> request_starts(const mock_serial& line) {
    std::vector<time_point> starts;
    time_point last_end = time_point::min();
    for (const auto& b : line.wire()) {
        if (b.origin != ferrule::wire_byte::from::session) continue;
        if (b.start != last_end) starts.push_back(b.start);
        last_end = b.end;
    }
    return starts;
}

master_config hsl_cpu() {
    master_config cfg;
    cfg.cpu = 0x21; // HSL's default, as in the §8.1 vectors 5…15
    return cfg;
}

// SFC 09, MW00000 × 10 (§8.1 #2) and a reply of 10 words.
const request read10 = make(sfc::read_holding_registers_ext, 0, 10);
octets read10_reply(std::uint8_t serial) {
    const octets cmd = command(read10, serial);
    const auto req = parse_request(std::span<const std::uint8_t>(cmd).subspan(header_size));
    REQUIRE(req);
    std::array<std::uint16_t, 10> words{};
    for (std::size_t i = 0; i < words.size(); ++i) words[i] = static_cast<std::uint16_t>(i + 1);
    response rsp;
    rsp.words = words;
    octets out(max_message);
    const auto n = encode_response(load_header(cmd.data()), *req, rsp, out);
    REQUIRE(n);
    out.resize(*n);
    return out;
}

// A controller with MW, IW, coils and input relays that answers every SFC of MFC 0x20
// (§3.4), and remembers the serial and SFC of each command.
class controller final : public ferrule::mock_peer {
public:
    std::vector<std::uint16_t> mw = std::vector<std::uint16_t>(65535);
    std::vector<std::uint16_t> iw = std::vector<std::uint16_t>(65536);
    std::vector<bool> coils = std::vector<bool>(65536);
    std::vector<bool> relays = std::vector<bool>(65536);
    std::vector<std::uint8_t> serials;
    std::vector<sfc> functions;

    void on_receive(mock_serial& line, std::span<const std::uint8_t> bytes,
                    time_point end) override {
        const auto h = parse_message(bytes);
        REQUIRE(h);
        serials.push_back(h->serial);
        const auto req = parse_request(bytes.subspan(header_size));
        REQUIRE(req);
        functions.push_back(req->function);
        std::array<std::uint16_t, max_read_registers_ext> words{};
        std::array<std::uint8_t, packed_size(max_read_bits)> bits{};
        response rsp;
        const auto f = req->function;
        switch (f) {
        case sfc::read_coils:
        case sfc::read_input_relays:
            for (std::size_t i = 0; i < req->count; ++i)
                if ((f == sfc::read_coils ? coils : relays)[req->address + i])
                    bits[i / 8] = static_cast<std::uint8_t>(bits[i / 8] | 1u << (i % 8));
            rsp.bits = std::span<const std::uint8_t>(bits).first(packed_size(req->count));
            break;
        case sfc::read_holding_registers_ext:
        case sfc::read_input_registers_ext:
            for (std::size_t i = 0; i < req->count; ++i)
                words[i] = (f == sfc::read_holding_registers_ext ? mw : iw)[req->address + i];
            rsp.words = std::span<const std::uint16_t>(words).first(req->count);
            break;
        case sfc::read_holding_registers_random:
            for (std::size_t i = 0; i < req->count; ++i) words[i] = mw[word_at(f, req->raw, i)];
            rsp.words = std::span<const std::uint16_t>(words).first(req->count);
            break;
        case sfc::write_coil: coils[req->address] = req->value == coil_on; break;
        case sfc::write_coils:
            for (std::size_t i = 0; i < req->count; ++i)
                coils[req->address + i] = (req->raw[i / 8] >> (i % 8)) & 1u;
            break;
        case sfc::write_holding_registers_ext:
            for (std::size_t i = 0; i < req->count; ++i)
                mw[req->address + i] = word_at(f, req->raw, i);
            break;
        case sfc::write_holding_registers_random:
            for (std::size_t i = 0; i < req->count; ++i)
                mw[word_at(f, req->raw, 2 * i)] = word_at(f, req->raw, 2 * i + 1);
            break;
        default: break;
        }
        std::array<std::uint8_t, max_message> out{};
        const auto n = encode_response(*h, *req, rsp, out);
        REQUIRE(n);
        line.inject(std::span<const std::uint8_t>(out).first(*n), end + 1ms);
    }
};

} // namespace

TEST_CASE("memobus master sends the golden requests, serial counting up", "[memobus][master]") {
    // §8.1 #5…#15 in the order of their serial numbers 00…0A.
    const std::array<std::uint8_t, 2> packed{0x05, 0x02};
    const std::array<std::uint16_t, 2> values{0x1234, 0xABCD};
    const std::array<std::uint16_t, 2> addresses{10, 20};
    const std::array<std::uint16_t, 4> pairs{10, 0x1111, 20, 0x2222};

    const octets q5{0x11, 0, 0, 0,    0,    0,    0x15, 0,    0,    0,   0,
                    0,    7, 0, 0x20, 0x01, 0x21, 0x00, 0x64, 0x00, 0x0A};
    const octets r5{0x19, 0, 0,    0,    0,    0,    0x13, 0,    0,   0,
                    0,    0, 0x05, 0x00, 0x20, 0x01, 0x12, 0x05, 0x02};
    const octets q6{0x11, 0x01, 0, 0,    0,    0,    0x15, 0,    0,    0,   0,
                    0,    7,    0, 0x20, 0x03, 0x21, 0x00, 0x64, 0x00, 0x02};
    const octets r6{0x19, 0x01, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                    0,    0x07, 0x00, 0x20, 0x03, 0x12, 0x12, 0x34, 0xAB, 0xCD};
    const octets q7{0x11, 0x02, 0, 0,    0,    0,    0x15, 0,    0,    0,   0,
                    0,    7,    0, 0x20, 0x05, 0x21, 0x00, 0x64, 0xFF, 0x00};
    const octets q8{0x11, 0x03, 0, 0,    0,    0,    0x15, 0,    0,    0,   0,
                    0,    7,    0, 0x20, 0x06, 0x21, 0x00, 0x64, 0x12, 0x34};
    const octets q9{0x11, 0x04, 0, 0,    0,    0,    0x15, 0,    0,    0,   0,
                    0,    7,    0, 0x20, 0x08, 0x21, 0x00, 0x00, 0xAA, 0xAA};
    const octets q10{0x11, 0x05, 0,    0,    0,    0,    0x17, 0,    0,    0,    0,   0,
                     0x09, 0x00, 0x20, 0x0F, 0x21, 0x00, 0x64, 0x00, 0x0A, 0x05, 0x02};
    const octets r10{0x19, 0x05, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                     0,    0x07, 0x00, 0x20, 0x0F, 0x12, 0x00, 0x64, 0x00, 0x0A};
    const octets q11{0x11, 0x06, 0,    0,    0,    0,    0x19, 0,    0,    0,    0,    0,   0x0B,
                     0x00, 0x20, 0x10, 0x21, 0x00, 0x64, 0x00, 0x02, 0x12, 0x34, 0xAB, 0xCD};
    const octets r11{0x19, 0x06, 0,    0,    0,    0,    0x15, 0,    0,    0,   0,
                     0,    0x07, 0x00, 0x20, 0x10, 0x12, 0x00, 0x64, 0x00, 0x02};
    const octets q12{0x11, 0x07, 0,    0,    0,    0,    0x1A, 0,    0,    0,    0,    0,    0x0C,
                     0x00, 0x20, 0x0B, 0x21, 0x00, 0x64, 0x00, 0x02, 0x00, 0x34, 0x12, 0xCD, 0xAB};
    const octets r12{0x19, 0x07, 0,    0,    0,    0,    0x16, 0,    0,    0,    0,
                     0,    0x08, 0x00, 0x20, 0x0B, 0x12, 0x00, 0x64, 0x00, 0x02, 0x00};
    const octets q13{0x11, 0x08, 0,    0,    0,    0,    0x18, 0,    0,    0,    0,    0,
                     0x0A, 0x00, 0x20, 0x0D, 0x21, 0x00, 0x02, 0x00, 0x0A, 0x00, 0x14, 0x00};
    const octets r13{0x19, 0x08, 0,    0,    0,    0,    0x18, 0,    0,    0,    0,    0,
                     0x0A, 0x00, 0x20, 0x0D, 0x12, 0x00, 0x02, 0x00, 0x11, 0x11, 0x22, 0x22};
    const octets q14{0x11, 0x09, 0,    0,    0,    0,    0x1C, 0,    0,    0,
                     0,    0,    0x0E, 0x00, 0x20, 0x0E, 0x21, 0x00, 0x02, 0x00,
                     0x0A, 0x00, 0x11, 0x11, 0x14, 0x00, 0x22, 0x22};
    const octets r14{0x19, 0x09, 0,    0,    0,    0,    0x14, 0,    0,    0,
                     0,    0,    0x06, 0x00, 0x20, 0x0E, 0x12, 0x00, 0x02, 0x00};
    const octets q15{0x11, 0x0A, 0,    0,    0,    0,    0x16, 0,    0,    0,    0,
                     0,    0x08, 0x00, 0x20, 0x0A, 0x21, 0x00, 0x00, 0x00, 0x01, 0x00};
    const octets r15{0x19, 0x0A, 0,    0,    0,    0,    0x16, 0,    0,    0,    0,
                     0,    0x08, 0x00, 0x20, 0x0A, 0x12, 0x00, 0x01, 0x00, 0x2A, 0x00};
    const std::array<script_step, 11> steps{
        answer(q5, r5),       answer(q6, r6),   answer(q7, echo(q7)), answer(q8, echo(q8)),
        answer(q9, echo(q9)), answer(q10, r10), answer(q11, r11),     answer(q12, r12),
        answer(q13, r13),     answer(q14, r14), answer(q15, r15)};
    ferrule::script_peer peer(steps);
    mock_serial line(fast, &peer);
    master m(hsl_cpu());

    REQUIRE_FALSE(transact(line, m, make(sfc::read_coils, 100, 10)));
    CHECK(m.bit(0));
    CHECK_FALSE(m.bit(1));
    CHECK(m.bit(2));
    CHECK(m.bit(9));
    CHECK(m.reply().cpu == 0x12);
    REQUIRE_FALSE(transact(line, m, make(sfc::read_holding_registers, 100, 2)));
    CHECK(m.word(0) == 0x1234); // big-endian, the default (§3.3)
    CHECK(m.word(1) == 0xABCD);
    request coil = make(sfc::write_coil, 100, 1);
    coil.value = coil_on;
    REQUIRE_FALSE(transact(line, m, coil));
    request one = make(sfc::write_holding_register, 100, 1);
    one.value = 0x1234;
    REQUIRE_FALSE(transact(line, m, one));
    request loop = make(sfc::loopback, 0, 1);
    loop.value = 0xAAAA;
    REQUIRE_FALSE(transact(line, m, loop));
    request wc = make(sfc::write_coils, 100, 10);
    wc.bits = packed;
    REQUIRE_FALSE(transact(line, m, wc));
    request wr = make(sfc::write_holding_registers, 100, 2);
    wr.words = values;
    REQUIRE_FALSE(transact(line, m, wr));
    request wx = make(sfc::write_holding_registers_ext, 100, 2);
    wx.words = values;
    REQUIRE_FALSE(transact(line, m, wx));
    request rr = make(sfc::read_holding_registers_random, 0, 2);
    rr.words = addresses;
    REQUIRE_FALSE(transact(line, m, rr));
    CHECK(m.word(0) == 0x1111);
    CHECK(m.word(1) == 0x2222);
    request wp = make(sfc::write_holding_registers_random, 0, 2);
    wp.words = pairs;
    REQUIRE_FALSE(transact(line, m, wp));
    REQUIRE_FALSE(transact(line, m, make(sfc::read_input_registers_ext, 0, 1)));
    CHECK(m.word(0) == 42);
    CHECK(m.serial() == 0x0A);
    CHECK(octets(m.request_bytes().begin(), m.request_bytes().end()) == q15);

    CHECK(peer.finished());
    CHECK(peer.mismatches() == 0);
    CHECK(m.stats().transactions == 11);
    CHECK(m.stats().succeeded == 11);
    CHECK(m.stats().stale == 0);
    CHECK(m.stats().malformed == 0);
}

TEST_CASE("memobus master: Yaskawa's sample request (§8.1 #2, #3)", "[memobus][master]") {
    const octets q2{0x11, 0, 0, 0,    0,    0,    0x16, 0,    0,    0,    0,
                    0,    8, 0, 0x20, 0x09, 0x10, 0x00, 0x00, 0x00, 0x0A, 0x00};
    const octets q3{0x11, 0, 0, 0,    0,    0,    0x16, 0,    0,    0,    0,
                    0,    8, 0, 0x20, 0x09, 0x00, 0x00, 0x01, 0x00, 0x0F, 0x00};
    const auto r2 = read10_reply(0);
    const std::array<script_step, 1> steps{answer(q2, r2)};
    ferrule::script_peer peer(steps);
    mock_serial line(fast, &peer);
    master m; // CPU byte 0x10: destination CPU 1, source 0 (§3.2)
    std::array<std::uint16_t, 10> regs{};
    REQUIRE_FALSE(read_words(line, m, mw(0), regs));
    CHECK(regs == std::array<std::uint16_t, 10>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10});
    CHECK(peer.mismatches() == 0);
    // 22 bytes out, 1 ms, 40 bytes back
    CHECK(line.now() == time_point{} + fast.chars_time(22) + 1ms + fast.chars_time(40));

    const std::array<script_step, 1> steps3{silent(q3)};
    ferrule::script_peer peer3(steps3);
    mock_serial line3(fast, &peer3);
    master_config cfg;
    cfg.cpu = 0x00;
    cfg.response_timeout = 10ms;
    master m3(cfg);
    std::array<std::uint16_t, 15> regs3{};
    CHECK(read(line3, m3, "MW00001", regs3) == errc::timeout);
    CHECK(peer3.mismatches() == 0);
}

TEST_CASE("memobus master: the serial wraps after FF, one per request", "[memobus][master]") {
    controller plc;
    mock_serial line(fast, &plc);
    master m;
    for (int i = 0; i < 260; ++i) {
        REQUIRE_FALSE(loopback(line, m, static_cast<std::uint16_t>(i)));
        line.clear_wire_log();
    }
    REQUIRE(plc.serials.size() == 260);
    for (std::size_t i = 0; i < plc.serials.size(); ++i)
        CHECK(plc.serials[i] == static_cast<std::uint8_t>(i));
    CHECK(m.serial() == 3);
    CHECK(m.stats().succeeded == 260);
}

TEST_CASE("memobus master: a response with another serial is stale, the right one taken",
          "[memobus][master][stale]") {
    const octets q = command(read10, 0);
    // an old answer (serial FF) and then ours, in one burst
    const std::array<script_step, 1> steps{answer(q, read10_reply(0xFF) + read10_reply(0))};
    ferrule::script_peer peer(steps);
    mock_serial line(fast, &peer);
    line.set_read_size(7); // the messages arrive in pieces
    master m;
    std::array<std::uint16_t, 10> regs{};
    REQUIRE_FALSE(read_words(line, m, mw(0), regs));
    CHECK(regs[9] == 10);
    CHECK(m.stats().stale == 1);
    CHECK(m.stats().malformed == 0);
    CHECK(m.stats().succeeded == 1);
}

TEST_CASE("memobus master: a late answer to the timed-out attempt is stale",
          "[memobus][master][stale]") {
    master_config cfg;
    cfg.response_timeout = 50ms;
    cfg.retries = 1;
    // attempt 1 (serial 0): answered after the deadline, while attempt 2 (serial 1) waits
    const std::array<script_step, 2> steps{answer(command(read10, 0), read10_reply(0), 60ms),
                                           answer(command(read10, 1), read10_reply(1), 20ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(fast, &peer);
    master m(cfg);
    std::array<std::uint16_t, 10> regs{};
    REQUIRE_FALSE(read_words(line, m, mw(0), regs));
    CHECK(peer.mismatches() == 0);
    CHECK(m.attempts() == 2);
    CHECK(m.serial() == 1);
    CHECK(m.stats().timeouts == 1);
    CHECK(m.stats().resends == 1);
    CHECK(m.stats().stale == 1);
    CHECK(line.now() == time_point{} + 50ms + fast.chars_time(22) + 20ms + fast.chars_time(40));
}

TEST_CASE("memobus master: response type 0x11 refused unless lenient", "[memobus][master]") {
    octets hsl = read10_reply(0);
    hsl[0] = 0x11; // the HSL server's type byte (§2)
    const std::array<script_step, 1> steps{answer(command(read10, 0), hsl)};
    {
        ferrule::script_peer peer(steps);
        mock_serial line(fast, &peer);
        master m;
        std::array<std::uint16_t, 10> regs{};
        CHECK(read_words(line, m, mw(0), regs) == errc::unexpected_type);
        CHECK(m.stats().malformed == 1);
        CHECK(m.stats().failed == 1);
    }
    {
        ferrule::script_peer peer(steps);
        mock_serial line(fast, &peer);
        master_config cfg;
        cfg.lenient_response_type = true;
        master m(cfg);
        std::array<std::uint16_t, 10> regs{};
        REQUIRE_FALSE(read_words(line, m, mw(0), regs));
        CHECK(regs[0] == 1);
    }
    // A general-purpose message (0x12) is no response either.
    octets general = read10_reply(0);
    general[0] = 0x12;
    const std::array<script_step, 1> steps12{answer(command(read10, 0), general)};
    ferrule::script_peer peer(steps12);
    mock_serial line(fast, &peer);
    master_config cfg;
    cfg.lenient_response_type = true;
    master m(cfg);
    std::array<std::uint16_t, 10> regs{};
    CHECK(read_words(line, m, mw(0), regs) == errc::unexpected_type);
}

TEST_CASE("memobus master: the controller's error code, not resent", "[memobus][master]") {
    // §8.1 #16: SFC 09, reference address error
    const octets e16{0x19, 0, 0, 0, 0, 0, 0x12, 0, 0, 0, 0, 0, 0x04, 0x00, 0x20, 0x89, 0x01, 0x02};
    const std::array<script_step, 2> steps{answer(command(read10, 0), e16),
                                           answer(command(read10, 1), read10_reply(1))};
    ferrule::script_peer peer(steps);
    mock_serial line(fast, &peer);
    master_config cfg;
    cfg.retries = 2;
    master m(cfg);
    std::array<std::uint16_t, 10> regs{};
    const std::error_code ec = read_words(line, m, mw(0), regs);
    CHECK(ec == device_errc::address_error);
    CHECK(ec.category() == device_category());
    CHECK(ec.message() == "controller: reference address error");
    CHECK(m.error() == ec);
    CHECK(m.attempts() == 1);
    CHECK(peer.steps_done() == 1);
    CHECK(m.stats().device_errors == 1);
    CHECK(m.stats().failed == 1);
    CHECK(m.stats().resends == 0);
    // It is a failure in a row all the same (the fault latch counts it); a success clears it.
    CHECK(m.consecutive_failures() == 1);
    REQUIRE_FALSE(read_words(line, m, mw(0), regs));
    CHECK(m.consecutive_failures() == 0);
}

TEST_CASE("memobus master: timeouts resent at exact times", "[memobus][master][timing]") {
    master_config cfg;
    cfg.response_timeout = 100ms;
    cfg.retries = 2;
    SECTION("never answered") {
        const std::array<script_step, 3> steps{
            silent(command(read10, 0)), silent(command(read10, 1)), silent(command(read10, 2))};
        ferrule::script_peer peer(steps);
        mock_serial line(fast, &peer);
        master m(cfg);
        std::array<std::uint16_t, 10> regs{};
        CHECK(read_words(line, m, mw(0), regs) == errc::timeout);
        CHECK(request_starts(line) ==
              std::vector<time_point>{time_point{}, time_point{} + 100ms, time_point{} + 200ms});
        CHECK(line.now() == time_point{} + 300ms);
        CHECK(peer.mismatches() == 0);
        CHECK(m.attempts() == 3);
        CHECK(m.stats().timeouts == 3);
        CHECK(m.stats().resends == 2);
        CHECK(m.stats().failed == 1);
        CHECK(m.stats().succeeded == 0);
    }
    SECTION("answered on the third attempt") {
        const std::array<script_step, 3> steps{silent(command(read10, 0)),
                                               silent(command(read10, 1)),
                                               answer(command(read10, 2), read10_reply(2), 30ms)};
        ferrule::script_peer peer(steps);
        mock_serial line(fast, &peer);
        master m(cfg);
        std::array<std::uint16_t, 10> regs{};
        REQUIRE_FALSE(read_words(line, m, mw(0), regs));
        CHECK(line.now() ==
              time_point{} + 200ms + fast.chars_time(22) + 30ms + fast.chars_time(40));
        CHECK(m.stats().timeouts == 2);
        CHECK(m.stats().succeeded == 1);
        CHECK(m.error() == std::error_code{});
    }
}

TEST_CASE("memobus master: fault_threshold failed attempts in a row latch a fault",
          "[memobus][master][fault]") {
    master_config cfg;
    cfg.response_timeout = 100ms;
    cfg.retries = 1;
    cfg.fault_threshold = 3;
    // Two attempts time out; the third transaction's first attempt is the third failure in
    // a row: it latches and is not resent although a retry is left.
    const std::array<script_step, 4> steps{silent(command(read10, 0)), silent(command(read10, 1)),
                                           silent(command(read10, 2)),
                                           answer(command(read10, 3), read10_reply(3))};
    ferrule::script_peer peer(steps);
    mock_serial line(fast, &peer);
    master m(cfg);
    std::array<std::uint16_t, 10> regs{};
    CHECK(read_words(line, m, mw(0), regs) == errc::timeout);
    CHECK(m.consecutive_failures() == 2);
    CHECK_FALSE(m.fault_latched());
    CHECK(read_words(line, m, mw(0), regs) == errc::timeout);
    CHECK(m.attempts() == 1);
    CHECK(m.consecutive_failures() == 3);
    CHECK(m.fault_latched());
    CHECK(m.start(read10) == errc::fault_latched);
    CHECK(m.stats().transactions == 2);
    CHECK(peer.steps_done() == 3);
    // reset_fault() lets it start again; a success clears the count.
    m.reset_fault();
    CHECK_FALSE(m.fault_latched());
    CHECK(m.consecutive_failures() == 0);
    REQUIRE_FALSE(read_words(line, m, mw(0), regs));
    CHECK(regs[0] == 1);
    CHECK(m.consecutive_failures() == 0);
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("memobus master: garbage before the response is skipped", "[memobus][master][stale]") {
    const octets noise{0xDE, 0xAD, 0xBE, 0xEF, 0x00, 0x42};
    script_step s = answer(command(read10, 0), read10_reply(0), 2ms);
    s.noise = keep(noise);
    const std::array<script_step, 1> steps{s};
    ferrule::script_peer peer(steps);
    mock_serial line(fast, &peer);
    master m;
    std::array<std::uint16_t, 10> regs{};
    REQUIRE_FALSE(read_words(line, m, mw(0), regs));
    CHECK(regs[0] == 1);
    CHECK(m.stats().malformed == 1);
    CHECK(m.stats().succeeded == 1);

    // Only garbage: malformed at the deadline, resent once.
    master_config cfg;
    cfg.response_timeout = 20ms;
    cfg.retries = 1;
    script_step g;
    g.noise = keep(noise);
    const std::array<script_step, 2> junk{g, g};
    ferrule::script_peer peer2(junk);
    mock_serial line2(fast, &peer2);
    master m2(cfg);
    CHECK(read_words(line2, m2, mw(0), regs) == errc::malformed);
    CHECK(line2.now() == time_point{} + 40ms);
    CHECK(m2.stats().malformed == 2);
    CHECK(m2.stats().timeouts == 0);
    CHECK(m2.stats().resends == 1);
}

TEST_CASE("memobus master: wrong SFC or a short answer is resent", "[memobus][master]") {
    octets wrong = read10_reply(0);
    wrong[15] = 0x0A; // an answer to SFC 0A
    const std::array<script_step, 2> steps{answer(command(read10, 0), wrong),
                                           answer(command(read10, 1), read10_reply(1))};
    ferrule::script_peer peer(steps);
    mock_serial line(fast, &peer);
    master_config cfg;
    cfg.retries = 1;
    master m(cfg);
    std::array<std::uint16_t, 10> regs{};
    REQUIRE_FALSE(read_words(line, m, mw(0), regs));
    CHECK(m.attempts() == 2);
    CHECK(m.stats().malformed == 1);

    // Nine words for ten: parse_response's count check.
    std::array<std::uint16_t, 9> nine{};
    master m2;
    const request read9 = make(sfc::read_holding_registers_ext, 0, 9);
    const std::array<script_step, 1> short_steps{answer(command(read10, 0), [&] {
        const octets cmd = command(read9, 0);
        const auto req = parse_request(std::span<const std::uint8_t>(cmd).subspan(header_size));
        response rsp;
        rsp.words = nine;
        octets out(max_message);
        out.resize(*encode_response(load_header(cmd.data()), *req, rsp, out));
        return out;
    }())};
    ferrule::script_peer peer2(short_steps);
    mock_serial line2(fast, &peer2);
    CHECK(read_words(line2, m2, mw(0), regs) == errc::malformed);
}

TEST_CASE("memobus master: busy, bad requests and transport errors", "[memobus][master]") {
    master m;
    CHECK(m.start(make(sfc::read_holding_registers_ext, 0, 0)) == errc::invalid_argument);
    CHECK(m.start(make(sfc::read_holding_registers_ext, 0, 2045)) == errc::invalid_argument);
    CHECK(m.stats().transactions == 0);
    CHECK_FALSE(m.start(read10));
    CHECK(m.start(read10) == errc::busy);

    controller plc;
    mock_serial line(fast, &plc);
    line.fail_at(1); // the request's write
    CHECK(ferrule::run(line, m) == errc::transport);
    CHECK(line.writes() == 0);
    CHECK(m.error() == errc::transport);
    CHECK(m.stats().failed == 1);
    CHECK_FALSE(m.busy());
    // the next transaction goes on with the next serial
    std::array<std::uint16_t, 10> regs{};
    REQUIRE_FALSE(read_words(line, m, mw(0), regs));
    CHECK(plc.serials == std::vector<std::uint8_t>{1});
}

TEST_CASE("memobus access helpers against a controller", "[memobus][master][access]") {
    controller plc;
    mock_serial line(fast, &plc);
    master m;

    const std::array<std::uint16_t, 3> values{0x1234, 0xABCD, 7};
    REQUIRE_FALSE(write_words(line, m, mw(100), values));
    CHECK(plc.mw[100] == 0x1234);
    CHECK(plc.mw[102] == 7);
    std::array<std::uint16_t, 3> back{};
    REQUIRE_FALSE(read(line, m, "MW00100", back));
    CHECK(back == values);
    plc.iw[10] = 0x55AA;
    std::array<std::uint16_t, 1> in{};
    REQUIRE_FALSE(read(line, m, "iw0010", in));
    CHECK(in[0] == 0x55AA);

    // MB00100A is bit 10 of MW00100: coil 1610 (§3.4, word × 16 + bit)
    REQUIRE_FALSE(write_bit(line, m, mb(100, 0xA), true));
    CHECK(plc.coils[1610]);
    const std::array<bool, 5> bits{true, false, true, true, false};
    REQUIRE_FALSE(write(line, m, "MB00200F", bits));
    CHECK(plc.coils[3215]);
    CHECK_FALSE(plc.coils[3216]);
    CHECK(plc.coils[3217]);
    std::array<bool, 5> bits_back{};
    REQUIRE_FALSE(read(line, m, "MB00200F", bits_back));
    CHECK(bits_back == bits);
    plc.relays[16 * 10 + 3] = true;
    std::array<bool, 2> relays{};
    REQUIRE_FALSE(read_bits(line, m, ib(10, 2), relays));
    CHECK(relays == std::array<bool, 2>{false, true});

    const std::array<std::uint16_t, 2> where{10, 20};
    const std::array<std::uint16_t, 2> what{0x1111, 0x2222};
    REQUIRE_FALSE(write_random(line, m, where, what));
    CHECK(plc.mw[10] == 0x1111);
    CHECK(plc.mw[20] == 0x2222);
    std::array<std::uint16_t, 2> got{};
    REQUIRE_FALSE(read_random(line, m, where, got));
    CHECK(got == what);
    REQUIRE_FALSE(loopback(line, m));

    CHECK(plc.functions ==
          std::vector<sfc>{sfc::write_holding_registers_ext, sfc::read_holding_registers_ext,
                           sfc::read_input_registers_ext, sfc::write_coil, sfc::write_coils,
                           sfc::read_coils, sfc::read_input_relays,
                           sfc::write_holding_registers_random, sfc::read_holding_registers_random,
                           sfc::loopback});

    // Refused before anything is sent
    const auto sent = plc.serials.size();
    std::array<std::uint16_t, 1> one{};
    std::array<bool, 1> flag{};
    CHECK(read(line, m, "XW00100", one) == errc::invalid_argument);
    CHECK(read(line, m, "MW65535", one) == errc::out_of_range); // a name beyond MW
    CHECK(write(line, m, "MB65535F", std::span<const bool>(flag)) == errc::out_of_range);
    CHECK(read(line, m, "MB001000", one) == errc::invalid_argument);      // a bit name for words
    CHECK(read(line, m, "MW00100", flag) == errc::invalid_argument);      // a word name for bits
    CHECK(write_words(line, m, iw(0), values) == errc::invalid_argument); // IW is read-only
    CHECK(write_bit(line, m, ib(0, 0), true) == errc::invalid_argument);
    CHECK(write_bits(line, m, ib(0, 0), bits) == errc::invalid_argument);
    CHECK(read_bits(line, m, mb(4096, 0), flag) == errc::invalid_argument); // bit 65536
    CHECK(read_bits(line, m, mb(4095, 15), relays) == errc::invalid_argument);
    std::vector<std::uint16_t> many(2045);
    CHECK(read_words(line, m, mw(0), many) == errc::invalid_argument);
    CHECK(read_words(line, m, mw(0), std::span<std::uint16_t>{}) == errc::invalid_argument);
    CHECK(read_random(line, m, where, one) == errc::invalid_argument);
    CHECK(write_random(line, m, where, std::span<const std::uint16_t>(what).first(1)) ==
          errc::invalid_argument);
    CHECK(plc.serials.size() == sent);
    // The last bits MEMOBUS reaches: MB04095F is coil 65535
    REQUIRE_FALSE(read_bits(line, m, mb(4095, 15), flag));
}
