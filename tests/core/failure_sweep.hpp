// The failure-point sweep shared by every protocol's failure_sweep_test.cpp: one full
// transaction on a fresh rig counts its I/O operations N (mock_serial::io_operations), then for
// k = 1..N a fresh rig runs the same transaction with operation k failing; the transaction
// must end as the test's `failed` check says, and the next one, without a failure, must
// succeed. INFO names k, so a failure names its point.
//
// A Rig is default-constructible and has a mock_serial `line` (the operations its constructor
// makes, e.g. bringing a slave up, are not swept); `transaction(rig)` runs one
// transaction and returns its outcome; `failed(rig, outcome, k)` (k: the operation that
// failed) and `succeeded(rig, outcome)` check it. A session that never finishes (movilink::cyclic,
// lecom::poller) starts its next transaction in the driver step that ends one: that step's
// operation, the last one a transaction makes, is the next one's; `carried` = 1 leaves it out.
#pragma once

#include <catch2/catch.hpp>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <system_error>
#include <vector>

#include "ferrule/core/time.hpp"
#include "ferrule/host/serve.hpp"
#include "ferrule/sim/mock_serial.hpp"

namespace ferrule::test {

// Not an error of ferrule's: what a test sees in the outcome came from the stream.
inline const ferrule::error injected =
    ferrule::from_error_code(std::make_error_code(std::errc::io_error));

// A master after one transaction that failed with `expected`: free again, its outcome kept,
// counted once as failed and never as a success.
template <class Master>
void failed_once(const Master& m, std::error_code expected) {
    CHECK(m.error() == expected);
    CHECK_FALSE(m.busy());
    CHECK(m.stats().transactions == 1);
    CHECK(m.stats().succeeded == 0);
    CHECK(m.stats().failed == 1);
}

// A blocking transaction (run()) whose I/O operation k failed: it ended right there, with the
// stream's error, and sent nothing again.
template <class Master>
void ended_at_failure(const mock_serial& line, const Master& m, std::size_t k) {
    CHECK(line.io_operations() == k);
    failed_once(m, injected);
    CHECK(m.stats().resends == 0);
}

// Steps a poll_driver, 100 us of virtual time apart and `limit` steps at the most, until
// `count()` goes up: a session that never finishes (movilink::cyclic, lecom::poller,
// profibus::cycle) has ended its next transaction. Returns by how much it went up.
template <class Driver, class Count>
std::uint32_t step_until_next(mock_serial& line, Driver& driver, Count count, int limit = 10'000) {
    const std::uint32_t before = count();
    for (int i = 0; i < limit && count() == before; ++i) {
        driver.step();
        line.advance(std::chrono::microseconds(100));
    }
    return count() - before;
}

template <class Rig, class Transaction, class Failed, class Succeeded>
void failure_sweep(Transaction transaction, Failed failed, Succeeded succeeded,
                   std::size_t carried = 0) {
    std::size_t n = 0;
    {
        Rig rig;
        const std::size_t setup = rig.line.io_operations();
        succeeded(rig, transaction(rig));
        n = rig.line.io_operations() - setup - carried;
    }
    REQUIRE(n > 0);
    for (std::size_t k = 1; k <= n; ++k) {
        INFO("I/O operation " << k << " of " << n << " fails");
        Rig rig;
        rig.line.fail_at(k, injected);
        failed(rig, transaction(rig), k);
        INFO("the next transaction, without a failure");
        succeeded(rig, transaction(rig));
    }
}

// Stations: `line` has no peer, the test puts each request on it (mock_serial::inject) and
// serves the station for a while with host::serve_while, as firmware or ferrule-sim would.

// Serves `station` on `line` for `window` of virtual time; a transport error ends one
// serve_while() and serving starts again, as an application restarting it would. Returns the
// number of transport errors.
template <class Station>
std::size_t serve_for(mock_serial& line, Station& station, duration window) {
    const time_point end = line.now() + window;
    std::size_t errors = 0;
    while (before(line.now(), end))
        if (host::serve_while(line, station, std::chrono::milliseconds(1),
                              [&] { return before(line.now(), end); }))
            ++errors;
    return errors;
}

struct served {
    std::vector<std::uint8_t> sent; // what the station put on the line
    std::size_t errors = 0;         // transport errors while serving
};

// Puts `request` on the line and serves for `window`.
template <class Station>
served serve_request(mock_serial& line, Station& station, std::span<const std::uint8_t> request,
                     duration window) {
    const std::size_t from = line.wire().size();
    line.inject(request, line.now());
    served s;
    s.errors = serve_for(line, station, window);
    for (const wire_byte& b : line.wire().subspan(from))
        if (b.origin == wire_byte::from::session) s.sent.push_back(b.value);
    return s;
}

// The sweep for a station rig (a mock_serial `line` without a peer), whose `transaction(rig)`
// serves one request (serve_request). With operation k failing the station meets one
// transport error and sends either the whole reply a clean transaction gets or, when the
// failed operation is the reply's write, nothing; never a part of it, never late.
template <class Rig, class Transaction, class Succeeded>
void station_sweep(Transaction transaction, Succeeded succeeded) {
    const std::vector<std::uint8_t> reply = [&] {
        Rig rig;
        return transaction(rig).sent;
    }();
    std::size_t unanswered = 0;
    failure_sweep<Rig>(
        transaction,
        [&](Rig&, const served& s, std::size_t) {
            CHECK(s.errors == 1);
            if (s.sent.empty())
                ++unanswered;
            else
                CHECK(s.sent == reply);
        },
        succeeded);
    CHECK(unanswered == 1);
}

} // namespace ferrule::test
