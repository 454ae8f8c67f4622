// The features DESIGN.md promises every master (retries, a fault latch after
// fault_threshold failed attempts in a row, statistics, a cheap success test), checked under
// one set of names for every master session so that they cannot drift apart: a master that
// loses or renames one fails to compile here. The LECOM master, the Modbus client and the
// PROFIBUS master have no fault latch yet: in them it would outgrow the firmware size
// budgets (.ci/run). movilink::cyclic drives a movilink::master the
// application owns, lecom::poller its own lecom::master (session()): theirs are these.
#include <catch2/catch.hpp>

#include <concepts>
#include <cstdint>
#include <system_error>
#include <type_traits>
#include <utility>

#include "ferrule/core/fault_latch.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/dimetix/sensor.hpp"
#include "ferrule/lecom/master.hpp"
#include "ferrule/lecom/poller.hpp"
#include "ferrule/memobus/master.hpp"
#include "ferrule/modbus/client.hpp"
#include "ferrule/movilink/cyclic.hpp"
#include "ferrule/movilink/master.hpp"
#include "ferrule/profibus/master.hpp"

namespace {

template <class M>
concept master_features = ferrule::master_session<M> && requires(M& m, const M& c) {
    // retries, configured
    { c.config().retries } -> std::convertible_to<unsigned>;
    // the finished transaction
    { c.busy() } -> std::same_as<bool>;
    { c.error() } -> std::same_as<ferrule::error>;
    { c.succeeded() } -> std::same_as<bool>;
    { c.attempts() } -> std::same_as<unsigned>;
    {m.clear()};
    // statistics
    { c.stats().transactions } -> std::convertible_to<std::uint32_t>;
    { c.stats().succeeded } -> std::convertible_to<std::uint32_t>;
    { c.stats().failed } -> std::convertible_to<std::uint32_t>;
};

// The fault latch (core/fault_latch.hpp), configured and read under these names.
template <class M>
concept latches_faults = master_features<M> && requires(M& m, const M& c) {
    { c.config().fault_threshold } -> std::convertible_to<unsigned>;
    { c.fault_latched() } -> std::same_as<bool>;
    { c.consecutive_failures() } -> std::same_as<unsigned>;
    {m.reset_fault()};
};

static_assert(latches_faults<ferrule::movilink::master>);
static_assert(latches_faults<ferrule::dimetix::sensor>);
static_assert(latches_faults<ferrule::memobus::master>);
static_assert(latches_faults<ferrule::lecom::master>);
static_assert(
    std::same_as<
        std::remove_cvref_t<decltype(std::declval<const ferrule::lecom::poller<>&>().session())>,
        ferrule::lecom::master>);
static_assert(latches_faults<ferrule::modbus::client>);
static_assert(master_features<ferrule::modbus::basic_client<
                  ferrule::modbus::link_mode::rtu,
                  ferrule::modbus::functions<ferrule::modbus::function::read_holding_registers>>>);
static_assert(latches_faults<ferrule::profibus::master>);

} // namespace

TEST_CASE("fault_latch: retries while allowed, latches at the threshold, a success clears",
          "[core][master_features]") {
    ferrule::fault_latch l;
    // Attempt 1 of 3 (2 retries), threshold 4.
    CHECK(l.retry(1, 2, 4));
    CHECK(l.retry(2, 2, 4));
    CHECK_FALSE(l.retry(3, 2, 4)); // no retry left
    CHECK(l.consecutive_failures() == 3);
    CHECK_FALSE(l.fault_latched());
    CHECK_FALSE(l.retry(1, 2, 4)); // the fourth in a row latches: not resent
    CHECK(l.fault_latched());
    l.reset_fault();
    CHECK_FALSE(l.fault_latched());
    CHECK(l.consecutive_failures() == 0);
    // A failure that may not be retried counts too; a success clears the count.
    CHECK_FALSE(l.retry(1, 2, 4, false));
    CHECK(l.consecutive_failures() == 1);
    l.succeeded();
    CHECK(l.consecutive_failures() == 0);
    // Threshold 0: never latched.
    for (unsigned i = 0; i < 100; ++i) CHECK_FALSE(l.retry(5, 2, 0));
    CHECK_FALSE(l.fault_latched());
}
