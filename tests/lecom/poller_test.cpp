// LECOM poller: scheduling, priority writes, the live list and the cycle time, against a
// bus of scripted drives on mock_serial, in virtual time.
#include <catch2/catch.hpp>

#include <array>
#include <functional>
#include <vector>

#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/lecom/poller.hpp"

using namespace std::chrono_literals;
using namespace ferrule::lecom;
using ferrule::duration;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::session_action;
using ferrule::time_point;
using bytes = std::vector<std::uint8_t>;

namespace {

const ferrule::serial_format fmt = lenze_4900.format; // 9600 8E1

// Drives at fixed addresses: each answers a RECEIVE with its value (the same for every
// code) after `delay`, a SEND with ACK. A silent drive answers nothing; `no_code` makes it
// answer STX code EOT.
class drive_bus final : public ferrule::mock_peer {
public:
    struct drive {
        std::uint8_t address;
        std::int32_t value; // whole number
        bool silent = false;
        bool no_code = false;
    };
    struct heard {
        time_point start;
        frame request;
    };

    std::vector<drive> drives;
    duration delay = 20ms;
    std::vector<heard> log;

    drive& at(std::uint8_t address) {
        for (auto& d : drives)
            if (d.address == address) return d;
        FAIL("no drive " << int(address));
        return drives.front();
    }

    void on_receive(mock_serial& line, std::span<const std::uint8_t> in, time_point end) override {
        const auto f = parse_request(in);
        REQUIRE(f);
        log.push_back({end - line.format().chars_time(in.size()), *f});
        for (const auto& d : drives) {
            if (d.address != f->address || d.silent) continue;
            frame reply{frame_kind::ack};
            if (f->kind == frame_kind::receive)
                reply = d.no_code ? frame{frame_kind::no_code, 0, f->code, {}}
                                  : frame{frame_kind::data, 0, f->code, *decimal(d.value)};
            std::array<std::uint8_t, max_frame_length> out{};
            const auto n = encode(reply, out);
            REQUIRE(n);
            line.inject(std::span<const std::uint8_t>(out.data(), *n), end + delay);
        }
    }
};

// Runs the poller the way ferrule::run() runs a session, until `stop` holds or the virtual
// time reaches `limit`.
template <class P>
void pump(mock_serial& line, P& p, const std::function<bool()>& stop, time_point limit) {
    std::array<std::uint8_t, 64> buf{};
    while (!stop() && line.now() < limit) {
        const session_action a = p.next(line.now());
        switch (a.what) {
        case session_action::kind::idle: return;
        case session_action::kind::done: FAIL("a poller never finishes"); return;
        case session_action::kind::send:
            if (a.discard_input) line.discard_input();
            REQUIRE_FALSE(line.write(a.bytes).ec);
            break;
        case session_action::kind::wait: {
            const auto r = line.read_some(buf, std::min(a.deadline, limit));
            if (r.bytes > 0) p.on_receive(std::span(buf.data(), r.bytes), line.now());
            break;
        }
        }
    }
}

template <class P>
void pump_until(mock_serial& line, P& p, time_point limit) {
    pump(
        line, p, [] { return false; }, limit);
}

// Wire time of the reply STX C1 C2 <value> ETX BCC to a standard-code read.
duration reply_time(std::int32_t value) {
    std::array<std::uint8_t, max_frame_length> out{};
    return fmt.chars_time(*encode({frame_kind::data, 0, code(50), *decimal(value)}, out));
}

std::vector<time_point> starts_of(const drive_bus& bus, std::uint8_t address,
                                  frame_kind kind = frame_kind::receive) {
    std::vector<time_point> out;
    for (const auto& h : bus.log)
        if (h.request.address == address && h.request.kind == kind) out.push_back(h.start);
    return out;
}

} // namespace

TEST_CASE("six drives, one code each: the cycle is the sum of the transactions",
          "[lecom][poller][timing]") {
    // The LECOM paper's bus: six drives, 9600 8E1, each asked for one code in turn.
    drive_bus bus;
    for (std::uint8_t a = 1; a <= 6; ++a)
        bus.drives.push_back({a, a * 250}); // 250 … 1500: 3- and 4-digit replies
    bus.delay = 20ms;
    poller_config cfg;
    cfg.master.turnaround = 2ms;
    poller<> p(cfg);
    for (std::uint8_t a = 1; a <= 6; ++a) REQUIRE(p.add({a, code(50)}));
    mock_serial line(fmt, &bus);
    pump(
        line, p, [&] { return p.cycles() >= 3; }, time_point{} + 10s);
    REQUIRE(p.cycles() == 3);
    duration expected{};
    for (const auto& d : bus.drives)
        expected += fmt.chars_time(6) + 20ms + reply_time(d.value) + cfg.master.turnaround;
    CHECK(p.last_cycle_time() == expected);
    // 6 × (6.875 + 20 + 2) ms + 3 × 9.2 ms + 3 × 10.3 ms of replies (3 and 4 digits).
    CHECK(expected ==
          6 * (fmt.chars_time(6) + 22ms) + 3 * fmt.chars_time(8) + 3 * fmt.chars_time(9));
    const auto first = starts_of(bus, 1);
    REQUIRE(first.size() == 4);
    for (std::size_t i = 1; i < first.size(); ++i) CHECK(first[i] - first[i - 1] == expected);
    CHECK(p.completed() == 18);
    for (std::size_t i = 0; i < 6; ++i) {
        CHECK(p.state(i).valid);
        CHECK(p.state(i).reads == 3);
        CHECK(p.state(i).last.whole() == static_cast<std::int32_t>(250 * (i + 1)));
    }
    // Round the list in item order.
    for (std::size_t i = 0; i < bus.log.size(); ++i) CHECK(bus.log[i].request.address == i % 6 + 1);
    CHECK(p.session().stats().resends == 0);
}

TEST_CASE("writes go before the next due poll, first in first out", "[lecom][poller][write]") {
    drive_bus bus;
    bus.drives = {{1, 100}, {2, 200}, {3, 300}};
    poller<4, 2> p;
    REQUIRE(p.add({1, code(50)}));
    REQUIRE(p.add({2, code(50)}));
    REQUIRE(p.add({3, code(50)}));
    mock_serial line(fmt, &bus);
    // Let the first poll start, then queue two writes while it runs.
    pump(
        line, p, [&] { return !bus.log.empty(); }, time_point{} + 1s);
    REQUIRE_FALSE(p.write(2, code(11), *decimal(1500)));
    REQUIRE_FALSE(p.write(3, code(11), *decimal(1200)));
    CHECK(p.write(3, code(11), *decimal(1)) == errc::busy); // MaxWrites = 2
    CHECK(p.queued_writes() == 2);
    pump(
        line, p, [&] { return p.completed() >= 6; }, time_point{} + 1s);
    REQUIRE(bus.log.size() >= 6);
    // poll 1 (already running), write @2, write @3, then the polls carry on: 2, 3, 1.
    CHECK(bus.log[0].request.kind == frame_kind::receive);
    CHECK(bus.log[0].request.address == 1);
    CHECK(bus.log[1].request.kind == frame_kind::send);
    CHECK(bus.log[1].request.address == 2);
    CHECK(bus.log[1].request.value.whole() == 1500);
    CHECK(bus.log[2].request.kind == frame_kind::send);
    CHECK(bus.log[2].request.address == 3);
    CHECK(bus.log[3].request.address == 2);
    CHECK(bus.log[4].request.address == 3);
    CHECK(bus.log[5].request.address == 1);
    CHECK(p.drive(2)->writes == 1);
    CHECK(p.drive(3)->writes == 1);
    CHECK(p.drive(1)->writes == 0);
    CHECK(p.queued_writes() == 0);
    CHECK(p.write(100, code(11), *decimal(1)) == errc::invalid_argument);
}

TEST_CASE("a write is reported as an event, a group write as no_response_expected",
          "[lecom][poller][write]") {
    drive_bus bus;
    bus.drives = {{1, 100}};
    poller<2, 2> p;
    REQUIRE(p.add({1, code(50), 1s}));
    mock_serial line(fmt, &bus);
    REQUIRE_FALSE(p.write(1, code(11), *decimal(7)));
    REQUIRE_FALSE(p.write(0, code(40), *decimal(0))); // every drive
    pump(
        line, p, [&] { return p.completed() >= 1; }, time_point{} + 1s);
    CHECK(p.last_event().what == poll_event::kind::write);
    CHECK(p.last_event().address == 1);
    CHECK(p.last_event().code == code(11));
    CHECK(p.last_event().value.whole() == 7);
    CHECK_FALSE(p.last_event().error);
    pump(
        line, p, [&] { return p.completed() >= 2; }, time_point{} + 1s);
    CHECK(p.last_event().what == poll_event::kind::write);
    CHECK(p.last_event().address == 0);
    CHECK(p.error() == errc::no_response_expected);
    pump(
        line, p, [&] { return p.completed() >= 3; }, time_point{} + 1s);
    CHECK(p.last_event().what == poll_event::kind::read);
    CHECK(p.last_event().item == 0);
    CHECK(p.last_event().value.whole() == 100);
    // The poll follows the broadcast's spacing at once.
    const auto broadcast = starts_of(bus, 0, frame_kind::send);
    REQUIRE(broadcast.size() == 1);
    CHECK(starts_of(bus, 1).front() == broadcast[0] + fmt.chars_time(9) + processing_time);
    CHECK(p.drive(1)->writes == 1);
}

TEST_CASE("an item with an interval on an idle bus is polled exactly every interval",
          "[lecom][poller][interval]") {
    drive_bus bus;
    bus.drives = {{7, 42}};
    poller<1, 1, 1> p;
    REQUIRE(p.add({7, code(50), 200ms}));
    mock_serial line(fmt, &bus);
    pump_until(line, p, time_point{} + 1100ms);
    const auto starts = starts_of(bus, 7);
    REQUIRE(starts.size() == 6);
    for (std::size_t i = 0; i < starts.size(); ++i)
        CHECK(starts[i] == time_point{} + static_cast<int>(i) * 200ms);
    CHECK(p.state(0).updated - starts.back() == fmt.chars_time(6) + 20ms + reply_time(42));
    // Between the polls the poller waits for the next due time.
    CHECK(p.next(line.now()).what == session_action::kind::wait);
    CHECK(p.next(line.now()).deadline - time_point{} == 1200ms);
}

TEST_CASE("the most overdue item goes first, ties in item order", "[lecom][poller][interval]") {
    drive_bus bus;
    bus.drives = {{1, 1}, {2, 2}};
    poller<2, 1, 2> p;
    REQUIRE(p.add({1, code(50)}));        // every cycle
    REQUIRE(p.add({2, code(50), 100ms})); // every 100 ms
    mock_serial line(fmt, &bus);
    pump_until(line, p, time_point{} + 1s);
    const auto fast = starts_of(bus, 1);
    const auto slow = starts_of(bus, 2);
    const duration slot = fmt.chars_time(6) + 20ms + fmt.chars_time(6); // 1-digit replies
    // Item 1 is due 100 ms after its last start, but item 0 is due since its own last
    // start: whichever is due earlier goes. After item 1 at slot 1 come items 0 at slots 2, 3
    // (due 1 and 2 slots) and 4 (due at 3 slots = 101.25 ms < 1 slot + 100 ms), then item 1
    // at slot 5: a period of 4 slots = 135 ms.
    REQUIRE(slow.size() == 8);
    for (std::size_t i = 0; i < slow.size(); ++i)
        CHECK(slow[i] == time_point{} + static_cast<int>(1 + 4 * i) * slot);
    CHECK(fast.size() + slow.size() == bus.log.size());
    CHECK(bus.log.size() == static_cast<std::size_t>(1s / slot) + 1);
}

TEST_CASE("a silent drive goes offline after offline_after misses and comes back",
          "[lecom][poller][live]") {
    drive_bus bus;
    bus.drives = {{1, 10}, {2, 20}};
    bus.at(2).silent = true;
    poller_config cfg;
    cfg.master.retries = 0;
    cfg.offline_after = 3;
    cfg.offline_interval = 500ms;
    poller<2, 1, 2> p(cfg);
    REQUIRE(p.add({1, code(50)}));
    REQUIRE(p.add({2, code(50)}));
    mock_serial line(fmt, &bus);
    pump(
        line, p, [&] { return p.drive(2)->misses >= 3; }, time_point{} + 10s);
    const drive_state& d2 = *p.drive(2);
    CHECK_FALSE(d2.online);
    CHECK_FALSE(d2.seen);
    CHECK(d2.timeouts == 3);
    CHECK(d2.failures == 3);
    CHECK(d2.transactions == 3);
    CHECK(p.drive(1)->online);
    CHECK(p.state(1).error == errc::timeout);
    CHECK_FALSE(p.state(1).valid);
    CHECK(p.state(1).failures == 3);
    // Offline: probed once per 500 ms, drive 1 gets the bus in between. A probe that comes
    // due waits for the poll under way and for one poll of drive 1, which has been due since
    // its last start: at most two slots of 33.75 ms.
    const time_point went_offline = starts_of(bus, 2).back();
    pump_until(line, p, went_offline + 1300ms);
    const auto probes = starts_of(bus, 2);
    REQUIRE(probes.size() == 5);
    const duration slot = fmt.chars_time(6) + 20ms + fmt.chars_time(7);
    for (std::size_t i = 3; i < probes.size(); ++i) {
        CHECK(probes[i] - probes[i - 1] >= 500ms);
        CHECK(probes[i] - probes[i - 1] <= 500ms + 2 * slot);
    }
    CHECK(p.drive(2)->misses == 5);
    CHECK(p.drive(2)->timeouts == 5);
    // The drive answers again: online at its next probe, polled every cycle.
    bus.at(2).silent = false;
    pump(
        line, p, [&] { return p.drive(2)->online; }, line.now() + 1s);
    CHECK(p.drive(2)->online);
    CHECK(p.drive(2)->seen);
    CHECK(p.drive(2)->misses == 0);
    CHECK(p.state(1).valid);
    CHECK(p.state(1).last.whole() == 20);
    const std::size_t before = starts_of(bus, 2).size();
    pump_until(line, p, line.now() + 200ms);
    CHECK(starts_of(bus, 2).size() >= before + 2);
}

TEST_CASE("per-drive counters, and device errors keep a drive online", "[lecom][poller][live]") {
    drive_bus bus;
    bus.drives = {{1, 10}, {2, 20}};
    bus.at(2).no_code = true;
    poller_config cfg;
    cfg.offline_after = 1;
    poller<3, 2, 2> p(cfg);
    REQUIRE(p.add({1, code(50)}));
    REQUIRE(p.add({1, code(68)}));
    REQUIRE(p.add({2, code(9999)}));
    REQUIRE(p.drives().size() == 2);
    mock_serial line(fmt, &bus);
    REQUIRE_FALSE(p.write(2, code(11), *decimal(5)));
    pump(
        line, p, [&] { return p.completed() >= 7; }, time_point{} + 10s);
    const drive_state& d1 = *p.drive(1);
    const drive_state& d2 = *p.drive(2);
    CHECK(d1.transactions == 4);
    CHECK(d1.failures == 0);
    CHECK(d1.online);
    CHECK(d2.transactions == 3); // a write and two reads
    CHECK(d2.writes == 1);
    CHECK(d2.failures == 2);
    CHECK(d2.timeouts == 0);
    CHECK(d2.online); // "no such code" is an answer
    CHECK(d2.misses == 0);
    CHECK(p.state(2).error == device_errc::code_does_not_exist);
    CHECK(p.state(2).failures == 2);
    CHECK(p.session().stats().resends == 0); // code_does_not_exist is final
    CHECK(p.drive(3) == nullptr);
}

TEST_CASE("add refuses group addresses, bad codes, and more than fits", "[lecom][poller]") {
    poller<3, 1, 2> p;
    CHECK(p.add({0, code(50)}).error() == errc::invalid_argument);
    CHECK(p.add({20, code(50)}).error() == errc::invalid_argument);
    CHECK(p.add({100, code(50)}).error() == errc::invalid_argument);
    CHECK(p.add({1, code_address{6230, 0, false}}).error() == errc::invalid_argument);
    CHECK(p.add({1, code(50), -1ms}).error() == errc::invalid_argument);
    CHECK(*p.add({1, code(50)}) == 0);
    CHECK(*p.add({2, code(50)}) == 1);
    CHECK(p.add({3, code(50)}).error() == errc::buffer_too_small); // a third drive
    CHECK(*p.add({2, code(68)}) == 2);
    CHECK(p.add({1, code(68)}).error() == errc::buffer_too_small); // a fourth item
    CHECK(p.items().size() == 3);
    CHECK(p.items()[2].code == code(68));
    CHECK(p.drives().size() == 2);
    CHECK(p.completed() == 0);
    CHECK(p.cycles() == 0);
}

TEST_CASE("an empty poller is idle", "[lecom][poller]") {
    poller<> p;
    CHECK(p.next(time_point{}).what == session_action::kind::idle);
    static_assert(ferrule::master_session<poller<1, 1, 1>>);
}
