// The LECOM master, poller and codec never allocate: reads, writes, broadcasts and faults on
// a scripted line run with the counting global operator new of counting_new.hpp and the
// count must not move.
#include <catch2/catch.hpp>

#include <array>
#include <atomic>
#include <cstddef>
#include <memory>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/lecom/access.hpp"
#include "ferrule/lecom/poller.hpp"

// The counter of counting_new.hpp, whose operator new may be defined in one file only
// (no_heap_test.cpp): an inline variable, so this identical declaration names the same one.
namespace ferrule_test {
inline std::atomic<std::size_t> allocations{0};
} // namespace ferrule_test

using namespace std::chrono_literals;
using namespace ferrule::lecom;

namespace {

std::vector<std::uint8_t> wire(const frame& f) {
    std::vector<std::uint8_t> out(max_frame_length);
    out.resize(*encode(f, out));
    return out;
}

// Drive 01 answers every read with 1500 and every write with ACK, 20 ms after the request;
// nothing else answers.
class one_drive final : public ferrule::mock_peer {
public:
    void on_receive(ferrule::mock_serial& line, std::span<const std::uint8_t> in,
                    ferrule::time_point end) override {
        const auto f = parse_request(in);
        if (!f || f->address != 1) return;
        const frame reply = f->kind == frame_kind::receive
                                ? frame{frame_kind::data, 0, f->code, decimal_fixed(15'000'000)}
                                : frame{frame_kind::ack};
        std::array<std::uint8_t, max_frame_length> out{};
        const auto n = encode(reply, out);
        if (n) line.inject(std::span<const std::uint8_t>(out.data(), *n), end + 20ms);
    }
};

} // namespace

TEST_CASE("LECOM reads, writes, faults and polling allocate nothing", "[alloc][lecom]") {
    // Every script step and telegram is built before counting starts.
    const auto read46 = wire(read_request(1, code(46)));
    const auto reply46 = wire({frame_kind::data, 0, code(46), decimal_fixed(354'000)});
    const auto write11 = wire(write_request(34, code(11), decimal_fixed(952'000)));
    const std::vector<std::uint8_t> ack_{ack}, nak_{nak};
    const auto broadcast = wire(write_request(0, code(40), decimal_fixed(0)));
    std::vector<ferrule::script_step> steps;
    for (int i = 0; i < 20; ++i) {
        ferrule::script_step r;
        r.expect = read46;
        r.reply = reply46;
        r.delay = 20ms;
        if (i % 5 == 2) r.corrupt_index = 8; // bad BCC, resent
        if (i % 5 == 4) r.reply = {};        // timeout, resent
        steps.push_back(r);
        if (i % 5 == 2 || i % 5 == 4) {
            r.corrupt_index = -1;
            r.reply = reply46;
            steps.push_back(r);
        }
        ferrule::script_step w;
        w.expect = write11;
        w.reply = i % 4 == 0 ? std::span<const std::uint8_t>(nak_) : ack_;
        w.delay = 20ms;
        steps.push_back(w);
        if (i % 4 == 0) {
            w.reply = ack_;
            steps.push_back(w);
        }
        ferrule::script_step b;
        b.expect = broadcast;
        steps.push_back(b);
    }
    auto peer = std::make_unique<ferrule::script_peer>(steps);
    auto line = std::make_unique<ferrule::mock_serial>(lenze_4900.format, peer.get());
    auto m = std::make_unique<master>();

    // The counter is the one operator new counts.
    const auto probe_before = ferrule_test::allocations.load();
    auto probe = std::make_unique<int>(1);
    REQUIRE(ferrule_test::allocations.load() == probe_before + 1);

    std::size_t failures = 0;
    const auto before = ferrule_test::allocations.load();
    for (int i = 0; i < 20; ++i) {
        const auto v = read(*line, *m, 1, code(46));
        failures += !v || v->fixed != 354'000;
        failures += static_cast<bool>(write(*line, *m, 34, code(11), decimal_fixed(952'000)));
        failures += static_cast<bool>(write(*line, *m, 0, code(40), decimal_fixed(0)));
        line->clear_wire_log();
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(failures == 0);
    CHECK(peer->finished());
    CHECK(peer->mismatches() == 0);
    CHECK(m->stats().timeouts == 4);
    CHECK(m->stats().bad_checksums == 4);
    CHECK(m->stats().device_errors == 5);
}

TEST_CASE("the LECOM poller allocates nothing", "[alloc][lecom]") {
    auto bus = std::make_unique<one_drive>();
    auto line = std::make_unique<ferrule::mock_serial>(lenze_4900.format, bus.get());
    poller_config cfg;
    cfg.offline_interval = 1s;
    auto p = std::make_unique<poller<4, 2, 2>>(cfg);
    REQUIRE(p->add({1, code(50)}));
    REQUIRE(p->add({1, code(68), 50ms}));
    REQUIRE(p->add({2, code(50), 100ms})); // never answers: goes offline

    std::array<std::uint8_t, 64> buf{};
    const auto before = ferrule_test::allocations.load();
    std::uint32_t queued = 0;
    while (line->now() < ferrule::time_point{} + 3s) {
        if (p->completed() / 10 > queued) queued += !p->write(1, code(11), decimal_fixed(1));
        const auto a = p->next(line->now());
        if (a.what == ferrule::session_action::kind::send) {
            line->discard_input();
            (void)line->write(a.bytes);
        } else if (a.what == ferrule::session_action::kind::wait) {
            const auto r = line->read_some(buf, a.deadline);
            if (r.bytes > 0) p->on_receive(std::span(buf.data(), r.bytes), line->now());
        }
        line->clear_wire_log();
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(p->completed() > 30);
    CHECK(p->drive(1)->writes == queued);
    CHECK(p->drive(1)->failures == 0);
    CHECK_FALSE(p->drive(2)->online);
    CHECK(p->state(0).valid);
}
