// Gateway mapped mode: the scan list's update modes, round-robin order, byte/word swaps,
// offline / reconnect handling and status, in virtual time (modbus_profibus.md §E).
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <vector>

#include "ferrule/gateway/scan_list.hpp"

using namespace std::chrono_literals;
using namespace ferrule::gateway;
using ferrule::duration;
using ferrule::errc;
using ferrule::time_point;
using ferrule::modbus::device_errc;
using ferrule::modbus::function;
using ferrule::modbus::response;
using bytes = std::vector<std::uint8_t>;

namespace {

constexpr time_point at(duration d) {
    return time_point{} + d;
}

const ferrule::error ok{};
const ferrule::error timeout = errc::timeout;
const ferrule::error refused = device_errc::illegal_data_value;

transaction read(std::uint8_t unit, std::uint16_t address, std::uint16_t count,
                 std::uint16_t input_offset = 0) {
    transaction t;
    t.unit = unit;
    t.function = function::read_holding_registers;
    t.address = address;
    t.count = count;
    t.input_offset = input_offset;
    return t;
}

transaction write(std::uint8_t unit, std::uint16_t address, std::uint16_t count,
                  std::uint16_t output_offset = 0) {
    transaction t;
    t.unit = unit;
    t.function = function::write_multiple_registers;
    t.address = address;
    t.count = count;
    t.output_offset = output_offset;
    return t;
}

response registers(const bytes& data) {
    response r;
    r.function = function::read_holding_registers;
    r.data = data;
    return r;
}

bytes data_of(const scan_list::job& j) {
    return {j.request.data.begin(), j.request.data.end()};
}

// Runs next() at `now` and returns the index started, or -1 for none.
int next_index(scan_list& s, std::span<const std::uint8_t> outputs, time_point now) {
    const auto j = s.next(outputs, now);
    return j ? static_cast<int>(j->index) : -1;
}

} // namespace

TEST_CASE("scan list: cyclic entries run once per interval", "[gateway][scan]") {
    const std::array list{read(1, 0, 1, 0), read(2, 10, 2, 2)};
    scan_list s(list);
    std::array<std::uint8_t, 6> in{};
    const std::array<std::uint8_t, 0> out{};
    REQUIRE(s.size() == 2);
    CHECK(s.wake_at() == time_point::min()); // never started: due at once

    auto j = s.next(out, at(100ms));
    REQUIRE(j);
    CHECK(j->index == 0);
    CHECK(j->unit == 1);
    CHECK(j->request.function == function::read_holding_registers);
    CHECK(j->request.address == 0);
    CHECK(j->request.quantity == 1);
    CHECK(j->request.data.empty());
    s.done(0, ok, registers({0xAB, 0xCD}), in, at(110ms));

    j = s.next(out, at(110ms));
    REQUIRE(j);
    CHECK(j->index == 1);
    CHECK(j->unit == 2);
    CHECK(j->request.address == 10);
    CHECK(j->request.quantity == 2);
    s.done(1, ok, registers({1, 2, 3, 4}), in, at(120ms));
    CHECK(in == std::array<std::uint8_t, 6>{0xAB, 0xCD, 1, 2, 3, 4});

    CHECK_FALSE(s.next(out, at(120ms)));
    CHECK(s.wake_at() == at(200ms)); // entry 0 started at 100 ms
    CHECK_FALSE(s.next(out, at(199ms)));
    CHECK(next_index(s, out, at(200ms)) == 0);
    CHECK(s.wake_at() == at(210ms)); // entry 1 started at 110 ms
    CHECK_FALSE(s.next(out, at(209ms)));
    CHECK(next_index(s, out, at(210ms)) == 1);
    CHECK(s.wake_at() == at(300ms));
}

TEST_CASE("scan list: round robin, an always-due entry starves no one", "[gateway][scan]") {
    std::array list{read(1, 0, 1, 0), read(1, 1, 1, 2), read(1, 2, 1, 4)};
    list[0].interval = 0ms;
    list[1].interval = 0ms;
    list[2].interval = 1s;
    scan_list s(list);
    const std::array<std::uint8_t, 0> out{};

    std::vector<int> order;
    for (int k = 0; k < 7; ++k) order.push_back(next_index(s, out, at(0ms)));
    CHECK(order == std::vector<int>{0, 1, 2, 0, 1, 0, 1});

    // Entry 2 falls due while 0 and 1 are always due: it gets the next turn after 1.
    order.clear();
    for (int k = 0; k < 4; ++k) order.push_back(next_index(s, out, at(1s)));
    CHECK(order == std::vector<int>{2, 0, 1, 0});

    // With all three due the order goes round from the one after the last started.
    order.clear();
    for (int k = 0; k < 4; ++k) order.push_back(next_index(s, out, at(2s)));
    CHECK(order == std::vector<int>{1, 2, 0, 1});
}

TEST_CASE("scan list: swaps of read registers into DP inputs", "[gateway][scan]") {
    struct row {
        swap mode;
        std::array<std::uint8_t, 4> dp;
    };
    const std::array rows{row{swap::none, {0x12, 0x34, 0x56, 0x78}},
                          row{swap::bytes, {0x34, 0x12, 0x78, 0x56}},
                          row{swap::words, {0x56, 0x78, 0x12, 0x34}},
                          row{swap::bytes_and_words, {0x78, 0x56, 0x34, 0x12}}};
    for (const row& r : rows) {
        std::array list{read(1, 100, 2, 1)};
        list[0].swap = r.mode;
        scan_list s(list);
        std::array<std::uint8_t, 6> in{};
        REQUIRE(s.next(std::span<const std::uint8_t>{}, at(0ms)));
        s.done(0, ok, registers({0x12, 0x34, 0x56, 0x78}), in, at(5ms));
        CHECK(in == std::array<std::uint8_t, 6>{0, r.dp[0], r.dp[1], r.dp[2], r.dp[3], 0});
        CHECK(s.last_error(0) == ok);
    }
}

TEST_CASE("scan list: swaps of DP outputs into write registers", "[gateway][scan]") {
    struct row {
        swap mode;
        std::array<std::uint8_t, 4> dp;
    };
    const std::array rows{row{swap::none, {0x12, 0x34, 0x56, 0x78}},
                          row{swap::bytes, {0x34, 0x12, 0x78, 0x56}},
                          row{swap::words, {0x56, 0x78, 0x12, 0x34}},
                          row{swap::bytes_and_words, {0x78, 0x56, 0x34, 0x12}}};
    for (const row& r : rows) {
        std::array list{write(3, 0x200, 2, 2)};
        list[0].swap = r.mode;
        scan_list s(list);
        const std::array<std::uint8_t, 6> out{0xEE, 0xEE, r.dp[0], r.dp[1], r.dp[2], r.dp[3]};
        const auto j = s.next(out, at(0ms));
        REQUIRE(j);
        CHECK(j->unit == 3);
        CHECK(j->request.function == function::write_multiple_registers);
        CHECK(j->request.address == 0x200);
        CHECK(j->request.quantity == 2);
        CHECK(data_of(*j) == bytes{0x12, 0x34, 0x56, 0x78});
        std::array<std::uint8_t, 12> pdu{};
        const auto n = ferrule::modbus::encode_request(j->request, pdu);
        REQUIRE(n);
        CHECK(bytes(pdu.begin(), pdu.begin() + static_cast<std::ptrdiff_t>(*n)) ==
              bytes{0x10, 0x02, 0x00, 0x00, 0x02, 0x04, 0x12, 0x34, 0x56, 0x78});
    }
}

TEST_CASE("scan list: a word swap of an odd count leaves the last register", "[gateway][scan]") {
    std::array list{read(1, 0, 3, 0)};
    list[0].swap = swap::words;
    scan_list s(list);
    std::array<std::uint8_t, 6> in{};
    REQUIRE(s.next(std::span<const std::uint8_t>{}, at(0ms)));
    s.done(0, ok, registers({1, 2, 3, 4, 5, 6}), in, at(1ms));
    CHECK(in == std::array<std::uint8_t, 6>{3, 4, 1, 2, 5, 6});
}

TEST_CASE("scan list: FC 6 and FC 23 requests", "[gateway][scan]") {
    transaction single;
    single.unit = 7;
    single.function = function::write_single_register;
    single.address = 0x0010;
    single.output_offset = 1;
    single.swap = swap::bytes;
    transaction rw;
    rw.unit = 8;
    rw.function = function::read_write_multiple_registers;
    rw.address = 0x0100;
    rw.count = 2;
    rw.write_address = 0x0200;
    rw.write_count = 1;
    rw.input_offset = 2;
    rw.output_offset = 3;
    const std::array list{single, rw};
    scan_list s(list);
    REQUIRE(s.validate(6, 5) == ok);
    CHECK(s.validate(6, 4) == errc::invalid_argument); // FC 23 writes DP bytes 3 and 4
    const std::array<std::uint8_t, 5> out{0x00, 0x34, 0x12, 0xBE, 0xEF};
    std::array<std::uint8_t, 6> in{};

    auto j = s.next(out, at(0ms));
    REQUIRE(j);
    CHECK(j->unit == 7);
    CHECK(j->request.function == function::write_single_register);
    CHECK(j->request.address == 0x0010);
    CHECK(j->request.value == 0x1234);
    CHECK(data_of(*j) == bytes{0x12, 0x34});
    response echo;
    echo.function = function::write_single_register;
    echo.value = 0x1234;
    s.done(0, ok, echo, in, at(10ms));

    j = s.next(out, at(10ms));
    REQUIRE(j);
    CHECK(j->unit == 8);
    CHECK(j->request.function == function::read_write_multiple_registers);
    CHECK(j->request.address == 0x0100);
    CHECK(j->request.quantity == 2);
    CHECK(j->request.write_address == 0x0200);
    CHECK(j->request.write_quantity == 1);
    CHECK(data_of(*j) == bytes{0xBE, 0xEF});
    s.done(1, ok, registers({0xA1, 0xA2, 0xB1, 0xB2}), in, at(20ms));
    CHECK(in == std::array<std::uint8_t, 6>{0, 0, 0xA1, 0xA2, 0xB1, 0xB2});
    CHECK(s.all_succeeded_once());
}

TEST_CASE("scan list: on_change writes after a change and again after a failure",
          "[gateway][scan]") {
    std::array list{write(1, 0x10, 1, 0)};
    list[0].update = update::on_change;
    scan_list s(list);
    std::array<std::uint8_t, 2> out{0x00, 0x05};
    std::array<std::uint8_t, 0> in{};
    CHECK(s.wake_at() == ferrule::never); // no cyclic entry

    // Never written: due once at start.
    auto j = s.next(out, at(0ms));
    REQUIRE(j);
    CHECK(data_of(*j) == bytes{0x00, 0x05});
    s.done(0, ok, response{}, in, at(10ms));
    CHECK_FALSE(s.next(out, at(10ms)));
    CHECK_FALSE(s.next(out, at(5s)));
    CHECK(s.wake_at() == ferrule::never);

    // A change is written; a failed write is written again with the same bytes.
    out[1] = 0x06;
    j = s.next(out, at(6s));
    REQUIRE(j);
    CHECK(data_of(*j) == bytes{0x00, 0x06});
    s.done(0, timeout, response{}, in, at(6100ms));
    CHECK(s.last_error(0) == timeout);
    j = s.next(out, at(6100ms));
    REQUIRE(j);
    CHECK(data_of(*j) == bytes{0x00, 0x06});
    s.done(0, ok, response{}, in, at(6110ms));
    CHECK(s.last_error(0) == ok);
    CHECK_FALSE(s.next(out, at(6110ms)));

    // An exception response fails the write too.
    out[0] = 0x01;
    REQUIRE(s.next(out, at(7s)));
    s.done(0, refused, response{}, in, at(7010ms));
    j = s.next(out, at(7010ms));
    REQUIRE(j);
    CHECK(data_of(*j) == bytes{0x01, 0x06});

    // Outputs that change while the write is out: what was sent counts as written.
    out[1] = 0x07;
    s.done(0, ok, response{}, in, at(7020ms));
    j = s.next(out, at(7020ms));
    REQUIRE(j);
    CHECK(data_of(*j) == bytes{0x01, 0x07});
    s.done(0, ok, response{}, in, at(7030ms));
    CHECK_FALSE(s.next(out, at(7030ms)));

    // Back to bytes written earlier is a change too.
    out[1] = 0x06;
    CHECK(next_index(s, out, at(8s)) == 0);
}

TEST_CASE("scan list: an on_change read runs until it first succeeds", "[gateway][scan]") {
    std::array list{read(1, 0, 1, 0)};
    list[0].update = update::on_change;
    scan_list s(list);
    std::array<std::uint8_t, 2> in{};
    const std::span<const std::uint8_t> out{};
    CHECK(next_index(s, out, at(0ms)) == 0);
    s.done(0, timeout, response{}, in, at(100ms));
    CHECK(next_index(s, out, at(100ms)) == 0);
    s.done(0, ok, registers({0x0A, 0x0B}), in, at(200ms));
    CHECK(in == std::array<std::uint8_t, 2>{0x0A, 0x0B});
    CHECK_FALSE(s.next(out, at(200ms)));
    CHECK_FALSE(s.next(out, at(1h)));
}

TEST_CASE("scan list: trigger runs once per change of the trigger byte", "[gateway][scan]") {
    std::array list{write(1, 0x20, 1, 0)};
    list[0].update = update::trigger;
    list[0].trigger_offset = 2;
    scan_list s(list);
    REQUIRE(s.validate(0, 3) == ok);
    std::array<std::uint8_t, 3> out{0x11, 0x22, 5};
    std::array<std::uint8_t, 0> in{};

    // The byte's value at the first call counts as seen, data changes do not start it.
    CHECK_FALSE(s.next(out, at(0ms)));
    out[1] = 0x23;
    CHECK_FALSE(s.next(out, at(1s)));
    CHECK(s.wake_at() == ferrule::never);

    out[2] = 6;
    auto j = s.next(out, at(2s));
    REQUIRE(j);
    CHECK(data_of(*j) == bytes{0x11, 0x23});
    s.done(0, ok, response{}, in, at(2010ms));
    CHECK_FALSE(s.next(out, at(2010ms)));
    CHECK_FALSE(s.next(out, at(3s)));

    // A failed run waits for the next change.
    out[2] = 7;
    REQUIRE(s.next(out, at(4s)));
    s.done(0, timeout, response{}, in, at(4100ms));
    CHECK(s.last_error(0) == timeout);
    CHECK_FALSE(s.next(out, at(4100ms)));
    out[2] = 8;
    CHECK(next_index(s, out, at(5s)) == 0);
    // Any different value counts, also going back.
    s.done(0, ok, response{}, in, at(5010ms));
    out[2] = 7;
    CHECK(next_index(s, out, at(6s)) == 0);
}

TEST_CASE("scan list: a trigger byte that differs at the first call waits for a change",
          "[gateway][scan]") {
    std::array list{read(4, 0, 1, 0)};
    list[0].update = update::trigger;
    list[0].trigger_offset = 0;
    scan_list s(list);
    std::array<std::uint8_t, 1> out{0x80};
    CHECK_FALSE(s.next(out, at(0ms)));
    CHECK_FALSE(s.next(out, at(1s)));
    out[0] = 0x81;
    const auto j = s.next(out, at(2s));
    REQUIRE(j);
    CHECK(j->unit == 4);
    CHECK(j->request.function == function::read_holding_registers);
}

TEST_CASE("scan list: a unit goes offline, is skipped, probed, and comes back", "[gateway][scan]") {
    std::array list{read(5, 0, 1, 0), read(5, 1, 1, 2), read(9, 0, 1, 4)};
    for (auto& t : list) t.interval = 0ms;
    scan_list s(list, node_policy{3, 1s});
    std::array<std::uint8_t, 6> in{};
    const std::span<const std::uint8_t> out{};

    CHECK_FALSE(s.online(5)); // not heard from yet, not offline either
    CHECK(s.offline_count() == 0);
    CHECK(s.first_offline() == 0);

    // Unit 9 answers, unit 5 times out on both of its entries: failures of 5 count in a row.
    CHECK(next_index(s, out, at(0ms)) == 0);
    s.done(0, timeout, response{}, in, at(100ms));
    CHECK(next_index(s, out, at(100ms)) == 1);
    s.done(1, timeout, response{}, in, at(200ms));
    CHECK(next_index(s, out, at(200ms)) == 2);
    s.done(2, ok, registers({0x99, 0x99}), in, at(210ms));
    CHECK(s.online(9));
    CHECK_FALSE(s.online(5));
    CHECK(s.offline_count() == 0);
    CHECK(next_index(s, out, at(210ms)) == 0);
    s.done(0, timeout, response{}, in, at(310ms)); // third in a row: offline at 310 ms
    CHECK(s.offline_count() == 1);
    CHECK(s.first_offline() == 5);
    CHECK_FALSE(s.online(5));
    CHECK(s.online(9));
    CHECK(s.last_error(0) == timeout);

    // Skipped until 1.310 s: only unit 9 runs.
    for (int k = 0; k < 3; ++k) {
        CHECK(next_index(s, out, at(400ms)) == 2);
        s.done(2, ok, registers({0x99, 0x99}), in, at(410ms));
    }
    CHECK(s.wake_at() == at(400ms)); // entry 2, interval 0, started at 400 ms
    CHECK(next_index(s, out, at(1309ms)) == 2);
    // Entry 2 started at 1309 ms with interval 0, the reconnect time of unit 5 is 1310 ms.
    CHECK(s.wake_at() == at(1309ms));

    // At 1.310 s one entry of unit 5 is the probe; its other entry is skipped meanwhile.
    CHECK(next_index(s, out, at(1310ms)) == 0);
    CHECK(next_index(s, out, at(1310ms)) == 2);
    CHECK(next_index(s, out, at(1310ms)) == 2);
    s.done(0, timeout, response{}, in, at(1410ms)); // the probe failed: still offline
    CHECK(s.offline_count() == 1);
    CHECK(next_index(s, out, at(2309ms)) == 2);
    CHECK(next_index(s, out, at(2310ms)) == 0); // 1 s after the probe started
    s.done(0, ok, registers({0x55, 0x55}), in, at(2320ms));
    CHECK(s.online(5));
    CHECK(s.offline_count() == 0);
    CHECK(s.first_offline() == 0);
    CHECK(in == std::array<std::uint8_t, 6>{0x55, 0x55, 0, 0, 0x99, 0x99});

    // Online again: both of its entries run in turn.
    CHECK(next_index(s, out, at(2320ms)) == 1);
    CHECK(next_index(s, out, at(2320ms)) == 2);
    CHECK(next_index(s, out, at(2320ms)) == 0);
}

TEST_CASE("scan list: exception responses keep the unit online", "[gateway][scan]") {
    std::array list{read(6, 0, 1, 0)};
    list[0].interval = 0ms;
    scan_list s(list, node_policy{2, 1s});
    std::array<std::uint8_t, 2> in{0x77, 0x77};
    const std::span<const std::uint8_t> out{};

    for (int k = 0; k < 5; ++k) {
        CHECK(next_index(s, out, at(0ms)) == 0);
        s.done(0, refused, response{}, in, at(10ms));
    }
    CHECK(s.online(6));
    CHECK(s.offline_count() == 0);
    CHECK(s.last_error(0) == refused);
    CHECK_FALSE(s.all_succeeded_once());
    CHECK(in == std::array<std::uint8_t, 2>{0x77, 0x77}); // inputs untouched

    // A timeout, an exception, a timeout: not two failures in a row.
    CHECK(next_index(s, out, at(20ms)) == 0);
    s.done(0, timeout, response{}, in, at(30ms));
    CHECK(next_index(s, out, at(30ms)) == 0);
    s.done(0, refused, response{}, in, at(40ms));
    CHECK(next_index(s, out, at(40ms)) == 0);
    s.done(0, timeout, response{}, in, at(50ms));
    CHECK(s.online(6));
    CHECK(next_index(s, out, at(50ms)) == 0);
    s.done(0, timeout, response{}, in, at(60ms));
    CHECK_FALSE(s.online(6));
    CHECK(s.first_offline() == 6);
    CHECK_FALSE(s.next(out, at(1059ms)));
    CHECK(s.wake_at() == at(1060ms));

    // An exception answer to the probe brings it back.
    CHECK(next_index(s, out, at(1060ms)) == 0);
    s.done(0, refused, response{}, in, at(1070ms));
    CHECK(s.online(6));
    CHECK(s.offline_count() == 0);
}

TEST_CASE("scan list: status of several offline units", "[gateway][scan]") {
    const std::array list{read(30, 0, 1, 0), read(12, 0, 1, 2), read(20, 0, 1, 4),
                          read(12, 5, 1, 6)};
    scan_list s(list, node_policy{1, 1s});
    std::array<std::uint8_t, 8> in{};
    const std::span<const std::uint8_t> out{};
    CHECK_FALSE(s.online(1)); // not in the list
    CHECK_FALSE(s.online(0));

    CHECK(next_index(s, out, at(0ms)) == 0);
    s.done(0, timeout, response{}, in, at(10ms));
    CHECK(s.offline_count() == 1);
    CHECK(s.first_offline() == 30);
    CHECK(next_index(s, out, at(10ms)) == 1);
    s.done(1, ok, registers({1, 2}), in, at(20ms));
    CHECK(next_index(s, out, at(20ms)) == 2);
    s.done(2, ferrule::error(errc::bad_checksum), response{}, in, at(30ms));
    CHECK(next_index(s, out, at(30ms)) == 3);
    s.done(3, ok, registers({3, 4}), in, at(40ms));
    CHECK(s.offline_count() == 2);
    CHECK(s.first_offline() == 20);
    CHECK(s.online(12));
    CHECK_FALSE(s.online(20));
    CHECK_FALSE(s.online(30));
    CHECK_FALSE(s.all_succeeded_once());
    CHECK(s.last_error(2) == errc::bad_checksum);
    CHECK(s.last_error(4) == errc::invalid_argument); // no such entry
    CHECK(in == std::array<std::uint8_t, 8>{0, 0, 1, 2, 0, 0, 3, 4});
}

TEST_CASE("scan list: offline_after 0 never takes a unit offline", "[gateway][scan]") {
    std::array list{read(2, 0, 1, 0)};
    list[0].interval = 0ms;
    scan_list s(list, node_policy{0, 1s});
    std::array<std::uint8_t, 2> in{};
    for (int k = 0; k < 10; ++k) {
        CHECK(next_index(s, std::span<const std::uint8_t>{}, at(k * 1ms)) == 0);
        s.done(0, timeout, response{}, in, at(k * 1ms));
    }
    CHECK(s.offline_count() == 0);
    CHECK_FALSE(s.online(2)); // never answered
}

TEST_CASE("scan list: all_succeeded_once is data valid", "[gateway][scan]") {
    const std::array list{read(1, 0, 1, 0), write(1, 0, 1, 0)};
    scan_list s(list);
    std::array<std::uint8_t, 2> in{};
    const std::array<std::uint8_t, 2> out{1, 2};
    CHECK_FALSE(s.all_succeeded_once());
    CHECK(next_index(s, out, at(0ms)) == 0);
    s.done(0, ok, registers({9, 9}), in, at(10ms));
    CHECK_FALSE(s.all_succeeded_once());
    CHECK(next_index(s, out, at(10ms)) == 1);
    s.done(1, ok, response{}, in, at(20ms));
    CHECK(s.all_succeeded_once());
    // Later failures do not take it back: "executed successfully at least once" (§E).
    CHECK(next_index(s, out, at(100ms)) == 0);
    s.done(0, timeout, response{}, in, at(200ms));
    CHECK(s.all_succeeded_once());
}

TEST_CASE("scan list: done() refuses register data that does not fit", "[gateway][scan]") {
    const std::array list{read(1, 0, 2, 2)};
    scan_list s(list);
    std::array<std::uint8_t, 6> in{};
    std::array<std::uint8_t, 5> small{};
    const std::span<const std::uint8_t> out{};
    REQUIRE(s.next(out, at(0ms)));
    s.done(0, ok, registers({1, 2}), in, at(10ms)); // one register for two
    CHECK(s.last_error(0) == errc::malformed);
    CHECK(in == std::array<std::uint8_t, 6>{});
    CHECK(s.online(1)); // it answered
    REQUIRE(s.next(out, at(100ms)));
    s.done(0, ok, registers({1, 2, 3, 4}), small, at(110ms));
    CHECK(s.last_error(0) == errc::buffer_too_small);
    CHECK(small == std::array<std::uint8_t, 5>{});
    CHECK_FALSE(s.all_succeeded_once());
    s.done(7, ok, registers({1, 2, 3, 4}), in, at(120ms)); // no such entry: ignored
    CHECK(in == std::array<std::uint8_t, 6>{});
}

TEST_CASE("scan list: next() skips writes whose bytes the outputs do not hold", "[gateway][scan]") {
    const std::array list{write(1, 0, 2, 2)};
    scan_list s(list);
    const std::array<std::uint8_t, 5> out{};
    CHECK_FALSE(s.next(out, at(0ms)));
    const std::array<std::uint8_t, 6> enough{0, 0, 1, 2, 3, 4};
    const auto j = s.next(enough, at(0ms));
    REQUIRE(j);
    CHECK(data_of(*j) == bytes{1, 2, 3, 4});
}

TEST_CASE("scan list: validate() refusals", "[gateway][scan]") {
    const auto check = [](const transaction& t, std::size_t in, std::size_t out) {
        const std::array list{t};
        return scan_list(list).validate(in, out);
    };
    const std::error_code bad = ferrule::error(errc::invalid_argument);

    CHECK(check(read(1, 0, 125, 0), 250, 0) == ok);
    CHECK(check(read(1, 0, 126, 0), 252, 0) == bad);
    CHECK(check(read(1, 0, 0, 0), 250, 0) == bad);
    CHECK(check(read(1, 0xFFFF, 1, 0), 2, 0) == ok);
    CHECK(check(read(1, 0xFFFF, 2, 0), 4, 0) == bad); // address + count beyond 65536
    CHECK(check(read(0, 0, 1, 0), 2, 0) == bad);
    CHECK(check(read(247, 0, 1, 0), 2, 0) == ok);
    CHECK(check(read(248, 0, 1, 0), 2, 0) == bad);
    CHECK(check(read(1, 0, 2, 1), 4, 0) == bad); // DP bytes 1…4 of 4
    CHECK(check(read(1, 0, 2, 1), 5, 0) == ok);

    auto input = read(1, 0, 2, 0);
    input.function = function::read_input_registers;
    CHECK(check(input, 4, 0) == ok);
    input.count = 126;
    CHECK(check(input, 252, 0) == bad);

    CHECK(check(write(1, 0, 123, 0), 0, 246) == ok);
    CHECK(check(write(1, 0, 124, 0), 0, 248) == bad);
    CHECK(check(write(1, 0, 0, 0), 0, 246) == bad);
    CHECK(check(write(1, 0, 2, 3), 0, 6) == bad);
    CHECK(check(write(1, 0, 2, 3), 0, 7) == ok);

    transaction single;
    single.function = function::write_single_register;
    single.output_offset = 2;
    CHECK(check(single, 0, 4) == ok);
    CHECK(check(single, 0, 3) == bad);
    single.count = 2;
    CHECK(check(single, 0, 4) == bad);

    transaction rw;
    rw.function = function::read_write_multiple_registers;
    rw.count = 125;
    rw.write_count = 121;
    CHECK(check(rw, 250, 242) == ok);
    CHECK(check(rw, 249, 242) == bad);
    CHECK(check(rw, 250, 241) == bad);
    rw.count = 126;
    CHECK(check(rw, 252, 242) == bad);
    rw.count = 125;
    rw.write_count = 122;
    CHECK(check(rw, 250, 244) == bad);
    rw.write_count = 0;
    CHECK(check(rw, 250, 244) == bad);

    for (const function f : {function::read_coils, function::read_discrete_inputs,
                             function::write_single_coil, function::write_multiple_coils,
                             function::diagnostics, function::encapsulated_interface}) {
        auto t = read(1, 0, 1, 0);
        t.function = f;
        CHECK(check(t, 10, 10) == bad);
    }

    auto trig = read(1, 0, 1, 0);
    trig.update = update::trigger;
    trig.trigger_offset = 3;
    CHECK(check(trig, 2, 4) == ok);
    CHECK(check(trig, 2, 3) == bad);

    auto odd = read(1, 0, 1, 0);
    odd.swap = static_cast<swap>(4);
    CHECK(check(odd, 2, 0) == bad);
    odd = read(1, 0, 1, 0);
    odd.update = static_cast<update>(3);
    CHECK(check(odd, 2, 0) == bad);

    std::vector<transaction> many(scan_list::max_transactions, read(1, 0, 1, 0));
    CHECK(scan_list(many).validate(2, 0) == ok);
    many.push_back(read(1, 0, 1, 0));
    scan_list too_many(many);
    CHECK(too_many.validate(2, 0) == bad);
    CHECK_FALSE(too_many.next(std::span<const std::uint8_t>{}, at(0ms)));
    CHECK(too_many.wake_at() == ferrule::never);
}

TEST_CASE("scan list: wake_at with offline units and event-driven entries", "[gateway][scan]") {
    SECTION("reconnect times of offline units") {
        std::array list{read(2, 0, 1, 0), write(3, 0, 1, 0)};
        list[0].interval = 500ms;
        list[1].update = update::on_change;
        scan_list s(list, node_policy{1, 1s});
        std::array<std::uint8_t, 2> in{};
        const std::array<std::uint8_t, 2> out{0, 1};
        CHECK(s.wake_at() == time_point::min());

        CHECK(next_index(s, out, at(0ms)) == 0);
        s.done(0, timeout, response{}, in, at(50ms)); // unit 2 offline at 50 ms
        CHECK(next_index(s, out, at(50ms)) == 1);
        s.done(1, timeout, response{}, in, at(60ms)); // unit 3 offline at 60 ms
        CHECK(s.wake_at() == at(1050ms));             // unit 2's reconnect beats its 500 ms
        CHECK_FALSE(s.next(out, at(1049ms)));

        CHECK(next_index(s, out, at(1050ms)) == 0);
        s.done(0, ok, registers({0, 0}), in, at(1060ms));
        CHECK(s.wake_at() == at(1060ms)); // unit 3's reconnect
        CHECK(next_index(s, out, at(1060ms)) == 1);
        s.done(1, timeout, response{}, in, at(1070ms));
        CHECK(s.wake_at() == at(1550ms)); // entry 0 again; unit 3 waits until 2060 ms
        CHECK(next_index(s, out, at(1550ms)) == 0);
        CHECK(s.wake_at() == at(2050ms));
    }
    SECTION("a passed reconnect time with nothing due is no wake-up") {
        std::array list{write(3, 0, 1, 0), read(3, 0, 1, 0)};
        list[0].update = update::on_change;
        list[1].interval = 10s;
        scan_list s(list, node_policy{1, 1s});
        std::array<std::uint8_t, 2> in{};
        const std::array<std::uint8_t, 2> out{0, 1};
        CHECK(next_index(s, out, at(0ms)) == 0);
        s.done(0, ok, response{}, in, at(10ms));
        CHECK(next_index(s, out, at(10ms)) == 1);
        s.done(1, timeout, response{}, in, at(20ms)); // offline at 20 ms
        CHECK(s.wake_at() == at(1020ms));
        CHECK_FALSE(s.next(out, at(1020ms))); // the write has nothing new, the read waits
        CHECK(s.wake_at() == at(10010ms));    // the read started at 10 ms
    }
    SECTION("no cyclic entry and nothing offline") {
        std::array list{write(1, 0, 1, 0)};
        list[0].update = update::trigger;
        scan_list s(list);
        CHECK(s.wake_at() == ferrule::never);
        const std::array<std::uint8_t, 0> none{};
        CHECK(scan_list(std::span<const transaction>{}).wake_at() == ferrule::never);
        CHECK_FALSE(scan_list(std::span<const transaction>{}).next(none, at(0ms)));
    }
}

TEST_CASE("scan list: a trigger byte counts as seen once the outputs hold it", "[gateway][scan]") {
    std::array list{read(1, 0, 1, 0)};
    list[0].update = update::trigger;
    list[0].trigger_offset = 1;
    scan_list s(list);
    CHECK_FALSE(s.next(std::span<const std::uint8_t>{}, at(0ms))); // no DP data yet
    std::array<std::uint8_t, 2> out{0, 3};
    CHECK_FALSE(s.next(out, at(100ms)));
    out[1] = 4;
    CHECK(next_index(s, out, at(200ms)) == 0);
}
