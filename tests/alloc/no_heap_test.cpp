// ferrule's sessions never allocate: steady-state traffic runs with a counting global
// operator new and the count must not move.
#include <catch2/catch.hpp>

#include <array>
#include <memory>
#include <vector>

#include "counting_new.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/movilink/access.hpp"
#include "ferrule/movilink/cyclic.hpp"

using namespace std::chrono_literals;
using namespace ferrule::movilink;

namespace {
std::vector<std::uint8_t> wire(const telegram& t) {
    std::vector<std::uint8_t> out(max_telegram_size);
    out.resize(*encode(t, out));
    return out;
}
} // namespace

TEST_CASE("the allocation counter sees allocations", "[alloc]") {
    const auto before = ferrule_test::allocations.load();
    auto p = std::make_unique<int>(42);
    CHECK(ferrule_test::allocations.load() == before + 1);
    CHECK(*p == 42);
}

TEST_CASE("MOVILINK cyclic exchange and parameter access allocate nothing", "[alloc][movilink]") {
    constexpr std::size_t cycles = 200;
    const std::array<std::uint16_t, 3> po{0x0006, 0x1388, 0x01F4};
    const auto pd_req = wire({direction::request, 1, pdu_type::pd3, {}, po});
    const auto pd_rsp = wire({direction::response, 1, pdu_type::pd3, {}, {0x0407, 0x1388, 0x0100}});
    const auto rd_req = wire({direction::request,
                              1,
                              pdu_type::param_acyclic,
                              param_channel::make(service::read, 0x2087),
                              {}});
    const auto rd_rsp =
        wire({direction::response, 1, pdu_type::param_acyclic, {0x31, 0, 0x2087, 0x14}, {}});
    const auto wr_req = wire({direction::request,
                              1,
                              pdu_type::param_acyclic,
                              param_channel::make(service::write_volatile, 0x2071, 1),
                              {}});
    const auto wr_rsp =
        wire({direction::response, 1, pdu_type::param_acyclic, {0x33, 0, 0x2071, 1}, {}});
    std::vector<ferrule::script_step> steps;
    for (std::size_t i = 0; i < cycles; ++i) {
        ferrule::script_step s;
        s.delay = 4ms;
        if (i % 10 == 3) {
            s.expect = rd_req;
            s.reply = rd_rsp;
        } else if (i % 10 == 7) {
            s.expect = wr_req;
            s.reply = wr_rsp;
        } else {
            s.expect = pd_req;
            s.reply = pd_rsp;
        }
        steps.push_back(s);
    }
    ferrule::script_peer peer(steps);
    auto line = std::make_unique<ferrule::mock_serial>(default_format, &peer);
    master m;

    std::size_t failures = 0;
    const auto before = ferrule_test::allocations.load();
    for (std::size_t i = 0; i < cycles; ++i) {
        if (i % 10 == 3) {
            const auto r = read_parameter(*line, m, 1, 0x2087);
            failures += !r || *r != 0x14;
        } else if (i % 10 == 7) {
            failures += static_cast<bool>(write_parameter(*line, m, 1, 0x2071, 1));
        } else {
            const auto pi = exchange(*line, m, 1, po);
            failures += !pi || pi->words[1] != 0x1388;
        }
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(failures == 0);
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
}

TEST_CASE("MOVILINK cyclic exchange under the poll driver allocates nothing", "[alloc][movilink]") {
    const std::array<std::uint16_t, 3> po{0x0006, 0x1388, 0x01F4};
    const auto pd_req = wire({direction::request, 1, pdu_type::pd3, {}, po});
    const auto pd_rsp = wire({direction::response, 1, pdu_type::pd3, {}, {0x0407, 0x1388, 0x0100}});
    std::vector<ferrule::script_step> steps(100);
    for (auto& s : steps) {
        s.expect = pd_req;
        s.reply = pd_rsp;
        s.delay = 4ms;
    }
    ferrule::script_peer peer(steps);
    auto line = std::make_unique<ferrule::mock_serial>(default_format, &peer);
    master m;
    cyclic c(m, 1);
    for (std::size_t i = 0; i < 3; ++i) c.set_po(i, po[i]);
    ferrule::poll_driver drv(*line, c);

    const auto before = ferrule_test::allocations.load();
    while (c.cycles() < 100) {
        drv.step();
        line->advance(200us);
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(c.failed_cycles() == 0);
    CHECK(c.pi(1) == 0x1388);
}
