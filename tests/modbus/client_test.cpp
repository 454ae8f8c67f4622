// Modbus client session against scripted servers on mock_serial, in virtual time.
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/client.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/tcp.hpp"
#include "ferrule/sim/mock_serial.hpp"

using namespace std::chrono_literals;
using namespace ferrule::modbus;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::script_step;
using ferrule::time_point;
using bytes = std::vector<std::uint8_t>;

namespace {

const ferrule::serial_format f9600{9600, 8, ferrule::parity::even, 1};
const ferrule::serial_format f115200{115200, 8, ferrule::parity::even, 1};

bytes adu(std::uint8_t unit, const bytes& pdu) {
    bytes out(max_rtu_adu);
    out.resize(*encode_rtu(unit, pdu, out));
    return out;
}
bytes mbap(std::uint16_t transaction, std::uint8_t unit, const bytes& pdu) {
    bytes out(max_tcp_adu);
    out.resize(*encode_tcp(transaction, unit, pdu, out));
    return out;
}

script_step answer(const bytes& req, const bytes& rsp, ferrule::duration delay) {
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

client_config rtu_config(const ferrule::serial_format& f) {
    client_config cfg;
    cfg.format = f;
    cfg.inter_frame_gap = t35(f);
    return cfg;
}

// Start of each request on the wire (a session byte that does not follow the previous one).
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

// End of the last byte the servers sent before `t`.
time_point peer_end_before(const mock_serial& line, time_point t) {
    time_point end{};
    for (const auto& b : line.wire())
        if (b.origin == ferrule::wire_byte::from::peer && b.end <= t) end = b.end;
    return end;
}

// Read 1 holding register at 0 of unit 1, and its answer 0x002A.
const bytes read1 = adu(1, {0x03, 0x00, 0x00, 0x00, 0x01});
const bytes value42 = adu(1, {0x03, 0x02, 0x00, 0x2A});

} // namespace

TEST_CASE("modbus client read at 9600 8E1: wire time, server delay, then t3.5 before the next",
          "[modbus][client][timing]") {
    const std::array<script_step, 2> steps{answer(read1, value42, 5ms),
                                           answer(read1, value42, 7ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client c(rtu_config(f9600));
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    CHECK(reg[0] == 42);
    // 8 + 7 characters of 11 bits: 9.1667 ms + 5 ms + 8.0208 ms.
    CHECK(line.now() == time_point{} + f9600.chars_time(8) + 5ms + f9600.chars_time(7));
    const time_point first_end = line.now();
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 2);
    CHECK(starts[0] == time_point{});
    CHECK(starts[1] - first_end == t35(f9600));
    CHECK(t35(f9600) == 4'010'417ns);
    CHECK(line.now() == starts[1] + f9600.chars_time(8) + 7ms + f9600.chars_time(7));
    CHECK(peer.mismatches() == 0);
    CHECK(c.stats().transactions == 2);
    CHECK(c.stats().succeeded == 2);
    CHECK(c.succeeded());
    CHECK(c.attempts() == 1);
    CHECK(bytes(c.request_bytes().begin(), c.request_bytes().end()) == read1);
}

TEST_CASE("modbus client read at 115200: the gap is the 1.75 ms floor",
          "[modbus][client][timing]") {
    const std::array<script_step, 2> steps{answer(read1, value42, 2ms),
                                           answer(read1, value42, 2ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f115200, &peer);
    client c(rtu_config(f115200));
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    const time_point first_end = line.now();
    CHECK(first_end == time_point{} + f115200.chars_time(8) + 2ms + f115200.chars_time(7));
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 2);
    CHECK(starts[1] - first_end == 1750us);
}

TEST_CASE("modbus client: a zero gap sends at once on virtual links", "[modbus][client][timing]") {
    const std::array<script_step, 2> steps{answer(read1, value42, 1ms),
                                           answer(read1, value42, 1ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client_config cfg = rtu_config(f9600);
    cfg.inter_frame_gap = ferrule::duration::zero();
    client c(cfg);
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    const time_point first_end = line.now();
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    CHECK(request_starts(line).at(1) == first_end);
}

TEST_CASE("modbus client: on a link faster than its format the next request waits for no wire time",
          "[modbus][client][timing]") {
    // A pty: the response is back long before the request's computed end at 19200 Bd.
    client_config cfg = rtu_config(ferrule::serial_format{19200, 8, ferrule::parity::none, 1});
    cfg.inter_frame_gap = ferrule::duration::zero();
    client c(cfg);
    request r;
    r.function = function::read_holding_registers;
    r.quantity = 1;
    const time_point t0{};
    for (int i = 0; i < 2; ++i) {
        const time_point start = t0 + i * 100us;
        REQUIRE_FALSE(c.start(1, r));
        REQUIRE(c.next(start).what == ferrule::session_action::kind::send);
        const bytes rsp = adu(1, {0x03, 0x02, 0x00, 0x2A});
        c.on_receive(rsp, start + 60us);
        REQUIRE(c.next(start + 60us).what == ferrule::session_action::kind::done);
        REQUIRE_FALSE(c.error());
        c.clear();
    }
    // With the format's wire time respected instead, the second send would have waited
    // until 8 characters at 19200 Bd (4.17 ms) after the first.
}

TEST_CASE("modbus client poll of 8 servers: cycle = sum of t3.5 + request + delay + response",
          "[modbus][client][timing]") {
    for (const auto& fmt : {f9600, f115200}) {
        std::vector<bytes> reqs, rsps;
        std::vector<ferrule::duration> delays;
        for (std::uint8_t unit = 1; unit <= 8; ++unit) {
            const std::uint16_t qty = unit; // requests and responses of different lengths
            reqs.push_back(adu(unit, {0x03, 0x00, 0x10, 0x00, static_cast<std::uint8_t>(qty)}));
            bytes pdu{0x03, static_cast<std::uint8_t>(2 * qty)};
            for (std::uint16_t i = 0; i < qty; ++i) {
                pdu.push_back(0x00);
                pdu.push_back(static_cast<std::uint8_t>(unit * 10 + i));
            }
            rsps.push_back(adu(unit, pdu));
            delays.push_back(std::chrono::microseconds(1500 + 700 * unit));
        }
        std::vector<script_step> steps;
        for (int cycle = 0; cycle < 2; ++cycle)
            for (std::size_t i = 0; i < 8; ++i)
                steps.push_back(answer(reqs[i], rsps[i], delays[i]));
        ferrule::script_peer peer(steps);
        mock_serial line(fmt, &peer);
        client c(rtu_config(fmt));
        std::array<std::uint16_t, 8> regs{};
        for (int cycle = 0; cycle < 2; ++cycle)
            for (std::uint8_t unit = 1; unit <= 8; ++unit) {
                REQUIRE_FALSE(
                    read_holding_registers(line, c, unit, 0x10, std::span(regs).first(unit)));
                CHECK(regs[unit - 1] == unit * 10 + unit - 1);
            }
        CHECK(peer.mismatches() == 0);
        ferrule::duration expected{};
        for (std::size_t i = 0; i < 8; ++i)
            expected += t35(fmt) + fmt.chars_time(reqs[i].size()) + delays[i] +
                        fmt.chars_time(rsps[i].size());
        const auto starts = request_starts(line);
        REQUIRE(starts.size() == 16);
        CHECK(starts[8] - starts[0] == expected);
        CHECK(line.now() - starts[8] == expected - t35(fmt));
    }
}

TEST_CASE("modbus client broadcast: no response awaited, turnaround before the next request",
          "[modbus][client][broadcast]") {
    const bytes write0 = adu(0, {0x06, 0x00, 0x01, 0x00, 0x03});
    const std::array<script_step, 2> steps{silent(write0), answer(read1, value42, 3ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client_config cfg = rtu_config(f9600);
    cfg.turnaround = 50ms;
    cfg.retries = 3;
    client c(cfg);
    REQUIRE_FALSE(write_register(line, c, broadcast_address, 1, 3));
    CHECK(c.error() == errc::no_response_expected);
    CHECK(c.attempts() == 1);
    CHECK(line.now() == time_point{} + f9600.chars_time(8) + 50ms);
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 2);
    CHECK(starts[1] == time_point{} + f9600.chars_time(8) + 50ms);
    CHECK(c.stats().broadcasts == 1);
    CHECK(c.stats().timeouts == 0);
    // Reads cannot be broadcast.
    CHECK(read_holding_registers(line, c, broadcast_address, 0, reg) == errc::invalid_argument);
    CHECK(c.start(248, request{}) == errc::invalid_argument);
}

TEST_CASE("modbus client: FC8 force listen only gets no response", "[modbus][client][broadcast]") {
    const bytes listen = adu(1, {0x08, 0x00, 0x04, 0x00, 0x00});
    const std::array<script_step, 1> steps{silent(listen)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client_config cfg = rtu_config(f9600);
    cfg.turnaround = 20ms;
    client c(cfg);
    const auto r = diagnostics(line, c, 1, diag_sub::force_listen_only);
    REQUIRE(r);
    CHECK(*r == 0);
    CHECK(line.now() == time_point{} + f9600.chars_time(8) + 20ms);
}

TEST_CASE("modbus client: no response, resent at the deadline, then answered",
          "[modbus][client][retry]") {
    const std::array<script_step, 2> steps{silent(read1), answer(read1, value42, 5ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client_config cfg = rtu_config(f9600);
    cfg.response_timeout = 200ms;
    cfg.retries = 1;
    client c(cfg);
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    CHECK(c.attempts() == 2);
    CHECK(c.stats().timeouts == 1);
    CHECK(c.stats().resends == 1);
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 2);
    CHECK(starts[1] == starts[0] + f9600.chars_time(8) + 200ms);

    const std::array<script_step, 1> none{silent(read1)};
    ferrule::script_peer quiet(none);
    mock_serial line2(f9600, &quiet);
    client c2(rtu_config(f9600)); // retries 0, timeout 1 s
    CHECK(read_holding_registers(line2, c2, 1, 0, reg) == errc::timeout);
    CHECK(line2.now() == time_point{} + f9600.chars_time(8) + 1s);
    CHECK(c2.stats().failed == 1);
}

TEST_CASE("modbus client: a CRC error ends the attempt after t3.5 of silence and is resent",
          "[modbus][client][retry]") {
    auto broken = answer(read1, value42, 5ms);
    broken.corrupt_index = 6; // CRC low byte
    broken.corrupt_mask = 0x01;
    const std::array<script_step, 2> steps{broken, answer(read1, value42, 5ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client_config cfg = rtu_config(f9600);
    cfg.retries = 1;
    client c(cfg);
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    CHECK(c.stats().bad_checksums == 1);
    CHECK(c.attempts() == 2);
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 2);
    const time_point bad_end = time_point{} + f9600.chars_time(8) + 5ms + f9600.chars_time(7);
    // Silent for t3.5: a byte begun by then would have arrived one character later.
    CHECK(starts[1] == bad_end + t35(f9600) + f9600.char_time());

    const std::array<script_step, 1> once{broken};
    ferrule::script_peer peer2(once);
    mock_serial line2(f9600, &peer2);
    client c2(rtu_config(f9600));
    CHECK(read_holding_registers(line2, c2, 1, 0, reg) == errc::bad_checksum);
    CHECK(line2.now() == bad_end + t35(f9600) + f9600.char_time());
    CHECK(c2.stats().bad_checksums == 1);
}

TEST_CASE("modbus client: exception responses are device errors, not resent",
          "[modbus][client][exception]") {
    const bytes ex = adu(1, {0x83, 0x02});
    CHECK(ex == bytes{0x01, 0x83, 0x02, 0xC0, 0xF1});
    const std::array<script_step, 1> steps{answer(read1, ex, 4ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client_config cfg = rtu_config(f9600);
    cfg.retries = 2;
    client c(cfg);
    std::array<std::uint16_t, 1> reg{};
    const std::error_code ec = read_holding_registers(line, c, 1, 0, reg);
    CHECK(ec == device_errc::illegal_data_address);
    CHECK(ec.category() == device_category());
    CHECK_FALSE(c.succeeded());
    CHECK(c.attempts() == 1);
    CHECK(c.stats().exceptions == 1);
    CHECK(c.stats().failed == 1);
    // The 5-byte exception frame ends the transaction at its last byte.
    CHECK(line.now() == time_point{} + f9600.chars_time(8) + 4ms + f9600.chars_time(5));
}

TEST_CASE("modbus client: a response from another unit is unexpected", "[modbus][client]") {
    const bytes other = adu(2, {0x03, 0x02, 0x00, 0x2A});
    const std::array<script_step, 1> steps{answer(read1, other, 4ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client c(rtu_config(f9600));
    std::array<std::uint16_t, 1> reg{};
    CHECK(read_holding_registers(line, c, 1, 0, reg) == errc::unexpected_address);
    CHECK(c.stats().unexpected_units == 1);
}

TEST_CASE("modbus client echo suppression skips exactly the request coming back",
          "[modbus][client][echo]") {
    auto s = answer(read1, value42, 12ms);
    s.noise = read1; // the adapter hands our request back first
    const std::array<script_step, 1> steps{s};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client_config cfg = rtu_config(f9600);
    cfg.echo_suppression = true;
    client c(cfg);
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    CHECK(reg[0] == 42);
    CHECK(c.stats().echo_bytes == read1.size());
    CHECK(c.stats().stale_bytes == 0);

    // Without an echo on the line the option costs nothing.
    const std::array<script_step, 1> plain{answer(read1, value42, 5ms)};
    ferrule::script_peer peer2(plain);
    mock_serial line2(f9600, &peer2);
    client c2(cfg);
    REQUIRE_FALSE(read_holding_registers(line2, c2, 1, 0, reg));
    CHECK(c2.stats().echo_bytes == 0);
}

TEST_CASE("modbus client: stale input is dropped and holds the gap", "[modbus][client][stale]") {
    // Two junk bytes behind the first response; three on the line before the first request.
    bytes tail = value42;
    tail.push_back(0xAA);
    tail.push_back(0xBB);
    const std::array<script_step, 2> steps{answer(read1, tail, 5ms), answer(read1, value42, 5ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    const bytes junk{0x55, 0x66, 0x77};
    line.inject(junk, time_point{});
    line.advance(20ms);
    client c(rtu_config(f9600));
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    CHECK(line.discarded() == 3);
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    CHECK(c.stats().stale_bytes == 2);
    const auto starts = request_starts(line);
    REQUIRE(starts.size() == 2);
    // The gap counts from the end of the junk, the last byte on the line.
    CHECK(starts[1] == peer_end_before(line, starts[1]) + t35(f9600));
    CHECK(starts[1] == starts[0] + f9600.chars_time(8) + 5ms + f9600.chars_time(9) + t35(f9600));
}

TEST_CASE("modbus client: garbage before the response is skipped", "[modbus][client][stale]") {
    auto s = answer(read1, value42, 6ms);
    const bytes noise{0x00, 0x00};
    s.noise = noise;
    const std::array<script_step, 1> steps{s};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client c(rtu_config(f9600));
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    CHECK(reg[0] == 42);
}

TEST_CASE("modbus client inter-byte timeout: a gap inside the response is frame_gap",
          "[modbus][client][timing]") {
    auto s = answer(read1, value42, 5ms);
    s.chunk = 3;
    s.chunk_gap = 3ms; // more than t1.5 (1.72 ms)
    const std::array<script_step, 2> steps{s, s};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client_config cfg = rtu_config(f9600);
    cfg.inter_byte_timeout = t15(f9600);
    client c(cfg);
    std::array<std::uint16_t, 1> reg{};
    CHECK(read_holding_registers(line, c, 1, 0, reg) == errc::frame_gap);
    // Ends when the 4th byte, begun t1.5 after the 3rd, would have arrived.
    CHECK(line.now() == time_point{} + f9600.chars_time(8) + 5ms + f9600.chars_time(3) +
                            f9600.char_time() + t15(f9600));
    CHECK(c.stats().malformed == 1);
    // Off (the default): the split response is fine.
    client lenient(rtu_config(f9600));
    line.advance(100ms);
    REQUIRE_FALSE(read_holding_registers(line, lenient, 1, 0, reg));
    CHECK(reg[0] == 42);
}

TEST_CASE("modbus client access helpers: coils, registers, FC23, diagnostics, device id",
          "[modbus][client][access]") {
    const bytes coils_req = adu(0x11, {0x01, 0x00, 0x13, 0x00, 0x0A});
    const bytes coils_rsp = adu(0x11, {0x01, 0x02, 0xCD, 0x01});
    const bytes wcoils_req = adu(0x11, {0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01});
    const bytes wcoils_rsp = adu(0x11, {0x0F, 0x00, 0x13, 0x00, 0x0A});
    const bytes wregs_req = adu(0x11, {0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02});
    const bytes wregs_rsp = adu(0x11, {0x10, 0x00, 0x01, 0x00, 0x02});
    const bytes rw_req =
        adu(0x11, {0x17, 0x00, 0x03, 0x00, 0x02, 0x00, 0x0E, 0x00, 0x01, 0x02, 0x00, 0xFF});
    const bytes rw_rsp = adu(0x11, {0x17, 0x04, 0x00, 0xFE, 0x0A, 0xCD});
    const bytes di_req = adu(0x11, {0x02, 0x00, 0xC4, 0x00, 0x03});
    const bytes di_rsp = adu(0x11, {0x02, 0x01, 0x05});
    const bytes ir_req = adu(0x11, {0x04, 0x00, 0x08, 0x00, 0x01});
    const bytes ir_rsp = adu(0x11, {0x04, 0x02, 0x00, 0x0A});
    const bytes coil_req = adu(0x11, {0x05, 0x00, 0xAC, 0xFF, 0x00});
    const bytes diag_req = adu(0x11, {0x08, 0x00, 0x00, 0xA5, 0x37});
    const bytes id_req = adu(0x11, {0x2B, 0x0E, 0x01, 0x00});
    const bytes id_rsp = adu(0x11, {0x2B, 0x0E, 0x01, 0x01, 0x00, 0x00, 0x02, 0x00, 0x03, 'A', 'C',
                                    'M', 0x01, 0x02, 'X', '1'});
    const std::array<script_step, 9> steps{
        answer(coils_req, coils_rsp, 2ms), answer(wcoils_req, wcoils_rsp, 2ms),
        answer(wregs_req, wregs_rsp, 2ms), answer(rw_req, rw_rsp, 2ms),
        answer(di_req, di_rsp, 2ms),       answer(ir_req, ir_rsp, 2ms),
        answer(coil_req, coil_req, 2ms),   answer(diag_req, diag_req, 2ms),
        answer(id_req, id_rsp, 2ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client c(rtu_config(f9600));

    std::array<bool, 10> bits{};
    REQUIRE_FALSE(read_coils(line, c, 0x11, 0x13, bits));
    CHECK(bits ==
          std::array<bool, 10>{true, false, true, true, false, false, true, true, true, false});
    REQUIRE_FALSE(write_coils(line, c, 0x11, 0x13, std::span<const bool>(bits)));
    const std::array<std::uint16_t, 2> two{0x000A, 0x0102};
    REQUIRE_FALSE(write_registers(line, c, 0x11, 1, two));
    std::array<std::uint16_t, 2> got{};
    const std::array<std::uint16_t, 1> one{0x00FF};
    REQUIRE_FALSE(read_write_registers(line, c, 0x11, 3, got, 14, one));
    CHECK(got == std::array<std::uint16_t, 2>{0x00FE, 0x0ACD});
    std::array<bool, 3> di{};
    REQUIRE_FALSE(read_discrete_inputs(line, c, 0x11, 0xC4, di));
    CHECK(di == std::array<bool, 3>{true, false, true});
    std::array<std::uint16_t, 1> ir{};
    REQUIRE_FALSE(read_input_registers(line, c, 0x11, 8, ir));
    CHECK(ir[0] == 10);
    REQUIRE_FALSE(write_coil(line, c, 0x11, 0xAC, true));
    const auto echo = diagnostics(line, c, 0x11, diag_sub::return_query_data, 0xA537);
    REQUIRE(echo);
    CHECK(*echo == 0xA537);
    const auto id = read_device_identification(line, c, 0x11);
    REQUIRE(id);
    CHECK(id->quantity == 2);
    std::span<const std::uint8_t> objects = id->data;
    device_id_object o;
    REQUIRE(next_device_id_object(objects, o));
    CHECK(o.id == 0);
    CHECK(bytes(o.value.begin(), o.value.end()) == bytes{'A', 'C', 'M'});
    CHECK(peer.finished());
    CHECK(peer.mismatches() == 0);
    CHECK(c.stats().succeeded == 9);
    // Spans beyond the spec's limits are refused before anything is sent.
    std::array<std::uint16_t, 126> many{};
    CHECK(read_holding_registers(line, c, 0x11, 0, many) == errc::invalid_argument);
}

TEST_CASE("modbus client TCP: MBAP transaction ids, a late response of an old id is stale",
          "[modbus][client][tcp]") {
    const bytes pdu_req{0x03, 0x00, 0x04, 0x00, 0x01};
    const bytes pdu_rsp{0x03, 0x02, 0x01, 0x02};
    client_config cfg;
    cfg.rtu = false;
    cfg.response_timeout = 100ms;
    cfg.retries = 1;
    const bytes req1 = mbap(1, 0x11, pdu_req), rsp1 = mbap(1, 0x11, pdu_rsp);
    const bytes req2 = mbap(2, 0x11, pdu_req), rsp2 = mbap(2, 0x11, pdu_rsp);
    const std::array<script_step, 2> steps{answer(req1, rsp1, 110ms), answer(req2, rsp2, 30ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f115200, &peer); // bytes in virtual time; TCP keeps no gaps
    client c(cfg);
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 0x11, 4, reg));
    CHECK(reg[0] == 0x0102);
    CHECK(c.transaction() == 2);
    CHECK(c.stats().timeouts == 1);
    CHECK(c.stats().stale_bytes == rsp1.size());
    CHECK(peer.mismatches() == 0);
    // Unit 0 is an ordinary unit id on TCP: a response is awaited.
    const bytes req0 = mbap(3, 0, pdu_req), rsp0 = mbap(3, 0, pdu_rsp);
    const std::array<script_step, 1> unit0{answer(req0, rsp0, 1ms)};
    ferrule::script_peer peer0(unit0);
    line.set_peer(&peer0);
    REQUIRE_FALSE(read_holding_registers(line, c, 0, 4, reg));
    CHECK(c.stats().broadcasts == 0);
}

TEST_CASE("modbus client TCP: a header of another protocol is malformed at the deadline",
          "[modbus][client][tcp]") {
    const bytes pdu_req{0x03, 0x00, 0x04, 0x00, 0x01};
    const bytes req = mbap(1, 0x11, pdu_req);
    const bytes bad{0x00, 0x01, 0x00, 0x07, 0x00, 0x05, 0x11, 0x03, 0x02, 0x01, 0x02};
    const std::array<script_step, 1> steps{answer(req, bad, 2ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f115200, &peer);
    client_config cfg;
    cfg.rtu = false;
    cfg.response_timeout = 50ms;
    client c(cfg);
    std::array<std::uint16_t, 1> reg{};
    CHECK(read_holding_registers(line, c, 0x11, 4, reg) == errc::malformed);
    CHECK(line.now() == time_point{} + 50ms); // TCP: the timeout counts from the write
    CHECK(c.stats().malformed == 1);
}

TEST_CASE("modbus client: random responses end every transaction by its deadline",
          "[modbus][client]") {
    std::uint32_t seed = 12345;
    auto rnd = [&seed] {
        seed = seed * 1664525u + 1013904223u;
        return static_cast<std::uint8_t>(seed >> 24);
    };
    client_config cfg = rtu_config(f9600);
    cfg.response_timeout = 20ms;
    const ferrule::duration limit = f9600.chars_time(8) + cfg.response_timeout +
                                    f9600.chars_time(max_rtu_adu) + t35(f9600) + f9600.char_time();
    std::size_t succeeded = 0;
    for (int i = 0; i < 300; ++i) {
        bytes reply(rnd() % 24);
        for (auto& b : reply) b = rnd();
        if (i % 3 == 0) { // a valid response somewhere in the noise
            const auto at = reply.begin() + static_cast<std::ptrdiff_t>(reply.size() / 2);
            reply.insert(at, value42.begin(), value42.end());
        }
        const std::array<script_step, 1> steps{answer(read1, reply, 2ms)};
        ferrule::script_peer peer(steps);
        mock_serial line(f9600, &peer);
        client c(cfg);
        std::array<std::uint16_t, 1> reg{};
        const std::error_code ec = read_holding_registers(line, c, 1, 0, reg);
        CHECK((!ec || ec.category() == ferrule::errc_category() ||
               ec.category() == device_category()));
        CHECK(line.now() <= time_point{} + limit);
        CHECK_FALSE(c.busy());
        if (!ec) {
            CHECK(reg[0] == 42);
            ++succeeded;
        }
    }
    CHECK(succeeded == 100); // every embedded response is found
}

TEST_CASE("modbus client refuses a second start while busy and reports transport errors",
          "[modbus][client]") {
    client c;
    request r;
    r.function = function::read_holding_registers;
    r.quantity = 1;
    REQUIRE_FALSE(c.start(1, r));
    CHECK(c.start(1, r) == errc::busy);
    CHECK(c.busy());
    c.on_transport_error(errc::transport);
    CHECK_FALSE(c.busy());
    CHECK(c.error() == errc::transport);
    CHECK(c.stats().failed == 1);
    c.clear();
    CHECK(c.next(time_point{}).what == ferrule::session_action::kind::idle);
    r.quantity = 0;
    CHECK(c.start(1, r) == errc::invalid_argument);
}

// A client built for FC 3 only: it refuses FC 6 before anything goes on the line, and reads
// as the full client does; a response of a function it does not know is garbage to it.
TEST_CASE("modbus client with a function set: others refused, its own served", "[modbus][client]") {
    using fc3_client = basic_client<link_mode::rtu, functions<function::read_holding_registers>>;
    const bytes fc6_echo = adu(1, {0x06, 0, 0, 0, 1});
    const std::array<script_step, 2> steps{answer(read1, value42, 5ms),
                                           answer(read1, fc6_echo, 5ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client_config cfg = rtu_config(f9600);
    cfg.response_timeout = 100ms;
    fc3_client c(cfg);
    CHECK(write_register(line, c, 1, 0, 7) == errc::invalid_argument);
    CHECK(line.writes() == 0);
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    CHECK(reg[0] == 42);
    CHECK(read_holding_registers(line, c, 1, 0, reg) == errc::malformed);
    CHECK(c.stats().malformed == 1);
}

TEST_CASE("modbus client keeps the response PDU as received, exception responses too",
          "[modbus][client]") {
    const bytes exception = adu(1, {0x83, 0x02});
    const std::array<script_step, 2> steps{answer(read1, value42, 5ms),
                                           answer(read1, exception, 5ms)};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    client c(rtu_config(f9600));
    std::array<std::uint16_t, 1> reg{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, reg));
    CHECK(bytes(c.response_pdu().begin(), c.response_pdu().end()) == bytes{0x03, 0x02, 0x00, 0x2A});
    CHECK(read_holding_registers(line, c, 1, 0, reg) == device_errc::illegal_data_address);
    CHECK(bytes(c.response_pdu().begin(), c.response_pdu().end()) == bytes{0x83, 0x02});
}
