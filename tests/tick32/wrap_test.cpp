// Built with FERRULE_TICK_32, as a firmware is: the 32-bit microsecond tick. Comparisons across
// the 2^32 us wrap, `never`, times from baud rates, a session's deadline after the wrap and a
// reply just before it, a hold left by a session idle for longer than half the range, and one
// transaction of every master on mock_serial that starts a few milliseconds before the wrap.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <type_traits>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/core/serial_format.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/dimetix/access.hpp"
#include "ferrule/dimetix/sim/bus.hpp"
#include "ferrule/lecom/access.hpp"
#include "ferrule/lecom/sim/bus.hpp"
#include "ferrule/memobus/access.hpp"
#include "ferrule/memobus/register_image.hpp"
#include "ferrule/memobus/server.hpp"
#include "ferrule/modbus/access.hpp"
#include "ferrule/modbus/rtu.hpp"
#include "ferrule/modbus/sim/bus.hpp"
#include "ferrule/movilink/access.hpp"
#include "ferrule/movilink/sim/bus.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/sim/bus.hpp"
#include "ferrule/sim/mock_serial.hpp"

// With the 32-bit tick, a point plus a std::chrono literal (int64) is an int64 point: a test
// compares it after converting it back to time_point, which wraps it as the session does.
using namespace std::chrono_literals;
using ferrule::before;
using ferrule::duration;
using ferrule::earliest;
using ferrule::errc;
using ferrule::latest;
using ferrule::line_hold;
using ferrule::mock_serial;
using ferrule::never;
using ferrule::time_point;
using ferrule::within;

static_assert(std::is_same_v<time_point::rep, std::uint32_t>);
static_assert(std::is_same_v<duration, std::chrono::duration<std::int32_t, std::micro>>);

namespace {

constexpr time_point us(std::uint32_t n) {
    return time_point{time_point::duration{n}};
}
constexpr std::uint32_t last_count = 0xFFFF'FFFF; // never's count
// 2^32 us after 0: the count is 0 again.
constexpr time_point wrap = us(0);
constexpr time_point before_wrap(duration lead) {
    return wrap - lead;
}

// Moves the line's clock (from 0) to `lead` before the wrap in two steps, each under half the
// range, which is as far as before() compares; `follow(now)` brings the simulated devices'
// models along after each step.
template <class Follow>
void run_to_wrap(mock_serial& line, duration lead, Follow follow) {
    REQUIRE(line.now() == us(0));
    line.advance(duration{0x7FFF'FFFF});
    follow(line.now());
    line.advance(duration{static_cast<std::int32_t>(0x8000'0001u - lead.count())});
    follow(line.now());
    REQUIRE(line.now() == before_wrap(lead));
}
void run_to_wrap(mock_serial& line, duration lead) {
    run_to_wrap(line, lead, [](time_point) {});
}

// The clock has passed the wrap: its count is small again.
void wrapped(const mock_serial& line, time_point start) {
    CHECK(before(start, line.now()));
    CHECK(line.now().time_since_epoch().count() < start.time_since_epoch().count());
}

// When the session's first byte on the line (since the log was cleared) began.
time_point first_request_byte(const mock_serial& line) {
    for (const auto& b : line.wire())
        if (b.origin == ferrule::wire_byte::from::session) return b.start;
    return never;
}

} // namespace

TEST_CASE("tick32: time points compare by their signed difference across the wrap",
          "[tick32][time]") {
    const time_point late = us(last_count - 999); // 1 ms before the wrap
    const time_point early = us(1000);            // 1 ms after it
    CHECK(before(late, early));
    CHECK_FALSE(before(early, late));
    CHECK_FALSE(before(late, late));
    CHECK(before(us(last_count), wrap));
    CHECK(time_point(late + 2ms) == early);
    CHECK(duration(early - late) == 2ms);
    CHECK(duration(late - early) == -2ms);
    CHECK(earliest(early, late) == late);
    CHECK(earliest(late, early) == late);
    CHECK(latest(early, late) == early);
    CHECK(latest(late, early) == early);
    // Half the range apart is where the difference turns: points must be closer than that.
    CHECK(before(us(0), us(0x7FFF'FFFF)));
    CHECK_FALSE(before(us(0), us(0x8000'0001))); // reads as behind
}

TEST_CASE("tick32: never is later than every point and a real point never reads as never",
          "[tick32][time]") {
    // never's count lies 1 us before the wrap, but earliest/latest never take it for a time.
    for (const time_point t : {us(0), us(1), us(0x8000'0000), us(last_count - 1), wrap}) {
        CHECK(earliest(t, never) == t);
        CHECK(earliest(never, t) == t);
        CHECK(latest(t, never) == never);
        CHECK(latest(never, t) == never);
        CHECK(ferrule::scheduled(t) == t);
        CHECK_FALSE(ferrule::reached(never, t));
        CHECK(ferrule::reached(t, t));
    }
    CHECK(earliest(never, never) == never);
    // A real point on never's count is answered 1 us later, past the wrap.
    CHECK(ferrule::scheduled(us(last_count)) == wrap);
}

TEST_CASE("tick32: within() and line_hold measure the time elapsed, across the wrap and after "
          "a long idle",
          "[tick32][time]") {
    const time_point t = before_wrap(1ms);
    CHECK(within(t + 999us, t, 2ms));
    CHECK(within(t + 1999us, t, 2ms));
    CHECK_FALSE(within(t + 2ms, t, 2ms));
    line_hold h;
    CHECK_FALSE(h.holds(t));
    h.set(t, t + 2ms);
    CHECK(h.holds(t + 1ms)); // past the wrap
    CHECK(h.end() == time_point(t + 2ms));
    CHECK_FALSE(h.holds(t + 2ms));
    h.extend(t + 1ms, t + 1500us); // shorter: kept
    CHECK(h.end() == time_point(t + 2ms));
    h.extend(t + 1ms, t + 3ms);
    CHECK(h.end() == time_point(t + 3ms));
    CHECK(h.holds(t + 2ms));
    // 40 minutes later (beyond half the range) the kept end compares as ahead again, but the
    // hold is over.
    const time_point idle = t + 20min + 20min;
    CHECK(before(idle, h.end()));
    CHECK_FALSE(h.holds(idle));
    h.set(t, t - 1ms); // already past: nothing held
    CHECK_FALSE(h.holds(t));
}

TEST_CASE("tick32: character times from baud rates are rounded up to the microsecond",
          "[tick32][time]") {
    const std::array formats{
        ferrule::serial_format{9600, 8, ferrule::parity::even, 1},
        ferrule::serial_format{19200, 7, ferrule::parity::even, 1},
        ferrule::serial_format{115200, 8, ferrule::parity::none, 1},
        ferrule::serial_format{187'500, 8, ferrule::parity::even, 1},
        ferrule::serial_format{12'000'000, 8, ferrule::parity::even, 1},
        ferrule::serial_format{300, 8, ferrule::parity::odd, 2},
        ferrule::serial_format{9601, 8, ferrule::parity::even, 1},
    };
    for (const auto& f : formats) {
        for (const std::uint64_t n : {1u, 2u, 7u, 8u, 256u, 1000u}) {
            INFO(f.baud << " baud, " << n << " characters");
            // ceil(n × bits × 10^6 / baud), exact
            const std::uint64_t bits = n * f.bits_per_char();
            const std::uint64_t exact = (bits * 1'000'000 + f.baud - 1) / f.baud;
            const auto t = static_cast<std::uint64_t>(f.chars_time(n).count());
            CHECK(t >= exact);               // never shorter
            CHECK(t <= exact + 1 + n / 256); // and within the stated bound
        }
    }
    // Bit times (PROFIBUS TSDR, TSYN, the slot time) the same way.
    for (const std::uint32_t baud : {9600u, 19200u, 187'500u, 1'500'000u, 12'000'000u}) {
        for (const std::uint32_t bits : {1u, 11u, 33u, 100u, 16383u}) {
            INFO(bits << " bits at " << baud << " baud");
            const std::uint64_t exact = (std::uint64_t{bits} * 1'000'000 + baud - 1) / baud;
            const auto t =
                static_cast<std::uint64_t>(ferrule::profibus::bit_times(baud, bits).count());
            CHECK(t >= exact);
            CHECK(t <= exact + 1 + bits / 256);
        }
    }
    const ferrule::serial_format f9600{9600, 8, ferrule::parity::even, 1};
    CHECK(f9600.char_time() == 1146us); // 11 bits: 1145.83 us
    // Modbus t3.5 below 19200 baud: 3.5 × 11 bits at 9600 = 4010.4 us.
    CHECK(ferrule::modbus::t35(f9600) == 4011us);
    CHECK(ferrule::modbus::t15(f9600) == 1719us); // 1718.75 us
    // PROFIBUS TSYN, 33 bits at 19200 baud = 1718.75 us.
    CHECK(ferrule::profibus::bit_times(19200, ferrule::profibus::syn_bits) == 1719us);
}

namespace {

const ferrule::serial_format f9600{9600, 8, ferrule::parity::even, 1};

std::vector<std::uint8_t> rtu_adu(std::uint8_t unit, std::vector<std::uint8_t> pdu) {
    std::vector<std::uint8_t> out(ferrule::modbus::max_rtu_adu);
    out.resize(*ferrule::modbus::encode_rtu(unit, pdu, out));
    return out;
}
const std::vector<std::uint8_t> read1 = rtu_adu(1, {0x03, 0x00, 0x00, 0x00, 0x01});
const std::vector<std::uint8_t> value42 = rtu_adu(1, {0x03, 0x02, 0x00, 0x2A});

ferrule::modbus::client_config client_100ms() {
    ferrule::modbus::client_config cfg;
    cfg.format = f9600;
    cfg.inter_frame_gap = ferrule::modbus::t35(f9600);
    cfg.response_timeout = 100ms;
    cfg.retries = 0;
    return cfg;
}

} // namespace

TEST_CASE("tick32: a deadline after the wrap times out exactly when it should", "[tick32][wrap]") {
    ferrule::script_step silent;
    silent.expect = read1;
    const std::array steps{silent};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    const time_point start = before_wrap(5ms);
    run_to_wrap(line, 5ms);

    ferrule::modbus::client c(client_100ms());
    std::array<std::uint16_t, 1> out{};
    CHECK(read_holding_registers(line, c, 1, 0, out) == errc::timeout);
    CHECK(peer.mismatches() == 0);
    // The request left at once (no hold from before), and the session gave up exactly
    // response_timeout after its end, 95 ms past the wrap.
    CHECK(first_request_byte(line) == start);
    const time_point tx_end = start + f9600.chars_time(read1.size());
    CHECK(line.now() == time_point(tx_end + 100ms));
    wrapped(line, start);
}

TEST_CASE("tick32: a reply ending just before the wrap, and one across it, are accepted",
          "[tick32][wrap]") {
    const time_point start = before_wrap(30ms);
    const duration req = f9600.chars_time(read1.size());
    const duration rsp = f9600.chars_time(value42.size());
    for (const duration after_wrap : {-1us, 0us, 500us}) {
        INFO("the reply's last byte ends " << after_wrap.count() << " us after the wrap");
        ferrule::script_step answer;
        answer.expect = read1;
        answer.reply = value42;
        answer.delay = 30ms - req - rsp + after_wrap;
        const std::array steps{answer};
        ferrule::script_peer peer(steps);
        mock_serial line(f9600, &peer);
        run_to_wrap(line, 30ms);

        ferrule::modbus::client c(client_100ms());
        std::array<std::uint16_t, 1> out{};
        CHECK_FALSE(read_holding_registers(line, c, 1, 0, out));
        CHECK(out[0] == 42);
        CHECK(line.wire().back().end == time_point(wrap + after_wrap));
        CHECK(first_request_byte(line) == start);
    }
}

TEST_CASE("tick32: a master idle for longer than half the range sends its next request at once",
          "[tick32][wrap]") {
    ferrule::script_step answer;
    answer.expect = read1;
    answer.reply = value42;
    const std::array steps{answer, answer};
    ferrule::script_peer peer(steps);
    mock_serial line(f9600, &peer);
    ferrule::modbus::client c(client_100ms());
    std::array<std::uint16_t, 1> out{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, out));
    // 40 minutes: the t3.5 the reply left would compare as 31.6 minutes ahead.
    line.advance(20min);
    line.advance(20min);
    line.clear_wire_log();
    const time_point idle_end = line.now();
    REQUIRE_FALSE(read_holding_registers(line, c, 1, 0, out));
    CHECK(first_request_byte(line) == idle_end);
}

// One transaction of every master, starting 5 ms before the wrap and ending after it.

TEST_CASE("tick32: a Modbus RTU read across the wrap", "[tick32][wrap][modbus]") {
    using namespace ferrule::modbus;
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    bus.add();
    client c;
    const time_point start = before_wrap(5ms);
    run_to_wrap(line, 5ms, [&](time_point t) { bus.advance(t); });
    std::array<std::uint16_t, 3> out{};
    REQUIRE_FALSE(read_holding_registers(line, c, 1, sim::vfd_register::max_frequency, out));
    CHECK(out == std::array<std::uint16_t, 3>{5000, 50, 50}); // the VFD's defaults
    CHECK(first_request_byte(line) == start);
    wrapped(line, start);
}

TEST_CASE("tick32: a MOVILINK parameter read across the wrap", "[tick32][wrap][movilink]") {
    using namespace ferrule::movilink;
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    bus.add();
    master m;
    const time_point start = before_wrap(5ms);
    run_to_wrap(line, 5ms, [&](time_point t) { bus.advance(t); });
    const auto v = read_parameter(line, m, 1, 0x2087); // P014 heat sink temperature
    REQUIRE(v);
    CHECK(*v == 20);
    CHECK(first_request_byte(line) == start);
    wrapped(line, start);
}

TEST_CASE("tick32: a LECOM read across the wrap", "[tick32][wrap][lecom]") {
    using namespace ferrule::lecom;
    namespace cn = ferrule::lecom::sim::code_number;
    constexpr std::int32_t setpoint = 1500 * value::scale;
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    bus.add()->drive.preset(cn::c0046_speed_setpoint, setpoint);
    master m;
    const time_point start = before_wrap(5ms);
    run_to_wrap(line, 5ms, [&](time_point t) { bus.advance(t); });
    const auto v = read(line, m, 1, code(cn::c0046_speed_setpoint));
    REQUIRE(v);
    CHECK(v->fixed == setpoint);
    CHECK(first_request_byte(line) == start);
    wrapped(line, start);
}

TEST_CASE("tick32: a Dimetix measurement across the wrap", "[tick32][wrap][dimetix]") {
    using namespace ferrule::dimetix;
    sim::bus<1> bus;
    mock_serial line{default_format, &bus};
    bus.add(); // ID 0, a constant 1234.5 mm
    sensor s;
    const time_point start = before_wrap(5ms);
    run_to_wrap(line, 5ms);
    const auto m = measure(line, s, 0);
    REQUIRE(m);
    CHECK(m->distance == 12345);
    CHECK(first_request_byte(line) == start);
    wrapped(line, start);
}

TEST_CASE("tick32: a PROFIBUS-DP bring-up and Data_Exchange across the wrap",
          "[tick32][wrap][profibus]") {
    using namespace ferrule::profibus;
    const std::array<std::uint8_t, 2> cfg_2in_2out{0x11, 0x21};
    slave_config sc;
    sc.address = 8;
    sc.ident = 0x0815;
    sc.cfg = cfg_2in_2out;
    prm_data p;
    p.station_status = prm::lock_req;
    p.min_tsdr = 11;
    p.ident = 0x0815;
    sim::bus<1> bus;
    mock_serial line{format(19200), &bus};
    const std::array<std::uint8_t, 2> inputs{0xAB, 0xCD};
    bus.add(sc)->set_inputs(inputs);
    master m;
    const time_point start = before_wrap(5ms);
    run_to_wrap(line, 5ms);
    REQUIRE_FALSE(bring_up(line, m, 8, p, cfg_2in_2out));
    const std::array<std::uint8_t, 2> outputs{0x12, 0x34};
    std::array<std::uint8_t, 2> in{};
    REQUIRE_FALSE(data_exchange(line, m, 8, outputs, in));
    CHECK(in == inputs);
    CHECK(std::ranges::equal(bus[0].outputs(), outputs));
    CHECK(first_request_byte(line) == start);
    wrapped(line, start);
}

namespace {

// A MEMOBUS controller: each request handled by the channel's server, answered 1 ms later.
class controller final : public ferrule::mock_peer {
public:
    ferrule::memobus::register_image<256, 16> image;

    void on_receive(mock_serial& line, std::span<const std::uint8_t> bytes,
                    time_point end) override {
        std::array<std::uint8_t, ferrule::memobus::max_message> out{};
        const std::size_t n = channel_.handle(bytes, image, out);
        if (n > 0) line.inject(std::span<const std::uint8_t>(out.data(), n), end + 1ms);
    }

private:
    ferrule::memobus::server channel_;
};

} // namespace

TEST_CASE("tick32: a MEMOBUS read across the wrap", "[tick32][wrap][memobus]") {
    using namespace ferrule::memobus;
    controller plc;
    const std::array<std::uint16_t, 3> values{0x1234, 0xABCD, 7};
    std::copy(values.begin(), values.end(), plc.image.mw().begin() + 100);
    // A TCP connection: 4 Mbaud, so that the bytes take little time.
    mock_serial line{ferrule::serial_format{4'000'000, 8, ferrule::parity::none, 1}, &plc};
    master m;
    const time_point start = before_wrap(500us);
    run_to_wrap(line, 500us);
    std::array<std::uint16_t, 3> out{};
    REQUIRE_FALSE(read_words(line, m, {register_kind::mw, 100}, out));
    CHECK(out == values);
    CHECK(first_request_byte(line) == start);
    wrapped(line, start);
}
