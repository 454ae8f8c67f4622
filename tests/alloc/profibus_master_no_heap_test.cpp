// The PROFIBUS-DP master and the FDL codec never allocate: start-up, Data_Exchange with
// timeouts, FCS errors, DH and RS replies, and Global_Control on a scripted line, and the
// cycle over three simulated slaves under poll_driver, run with the counting global operator
// new of counting_new.hpp and the count must not move.
#include <catch2/catch.hpp>

#include <array>
#include <atomic>
#include <cstddef>
#include <memory>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/cycle.hpp"
#include "ferrule/profibus/fdl.hpp"
#include "ferrule/profibus/sim/bus.hpp"
#include "ferrule/sim/mock_serial.hpp"

// The counter of counting_new.hpp, whose operator new may be defined in one file only
// (no_heap_test.cpp): an inline variable, so this identical declaration names the same one.
namespace ferrule_test {
inline std::atomic<std::size_t> allocations{0};
} // namespace ferrule_test

using namespace std::chrono_literals;
using namespace ferrule::profibus;

namespace {

using bytes = std::vector<std::uint8_t>;

// Master 2 and slave 8 (§B.9).
bytes wire(std::uint8_t da, std::uint8_t sa, std::uint8_t fc, std::uint8_t dsap, std::uint8_t ssap,
           const bytes& du) {
    telegram t;
    t.da = da;
    t.sa = sa;
    t.fc = fc;
    t.dsap = dsap;
    t.ssap = ssap;
    t.data = du;
    bytes out(max_telegram);
    out.resize(*encode(t, out));
    return out;
}
bytes request(std::uint8_t fc, std::uint8_t dsap, const bytes& du = {}) {
    return wire(8, 2, fc, dsap, dsap == no_sap ? no_sap : master_sap, du);
}
bytes reply(response_fn fn, std::uint8_t ssap, const bytes& du = {}) {
    return wire(2, 8, response_code(fn), ssap == no_sap ? no_sap : master_sap, ssap, du);
}

} // namespace

TEST_CASE("PROFIBUS master start-up, data exchange and faults allocate nothing",
          "[alloc][profibus]") {
    // Every script step and telegram is built before counting starts.
    const std::uint8_t diag_sap = static_cast<std::uint8_t>(sap::slave_diag);
    const std::uint8_t prm_sap = static_cast<std::uint8_t>(sap::set_prm);
    const std::uint8_t cfg_sap = static_cast<std::uint8_t>(sap::chk_cfg);
    const bytes cfg{0x11, 0x21};
    const bytes outputs{0x12, 0x34};
    prm_data p;
    p.station_status = prm::lock_req | prm::wd_on;
    p.wd_fact1 = 10;
    p.wd_fact2 = 10;
    p.ident = 0x0815;
    bytes prm_du(max_data);
    prm_du.resize(*encode_prm(p, prm_du));
    const auto fc = [](bool fcb, bool fcv) { return request_code(request_fn::srd_high, fcb, fcv); };
    const bytes fdl_req =
        wire(8, 2, request_code(request_fn::fdl_status, false, false), no_sap, no_sap, {});
    const bytes fdl_res = reply(response_fn::ok, no_sap);
    const bytes wprm = reply(response_fn::data_low, diag_sap, {0x02, 0x05, 0x00, 0xFF, 0x08, 0x15});
    const bytes ready =
        reply(response_fn::data_low, diag_sap, {0x00, 0x0C, 0x00, 0x02, 0x08, 0x15});
    const bytes ack{sc};
    const bytes dl = reply(response_fn::data_low, no_sap, {0xAB, 0xCD});
    const bytes dh = reply(response_fn::data_high, no_sap, {0xAB, 0xCD});
    const bytes rs = reply(response_fn::sap_not_active, no_sap);
    const bytes gc = wire(127, 2, request_code(request_fn::sdn_high, false, false),
                          static_cast<std::uint8_t>(sap::global_control), master_sap,
                          {control::clear_data, 0x00});

    // FCB state of slave 8 as the master sends: first 1 with FCV=0, then toggled, FCV=1.
    std::vector<bytes> reqs;
    reqs.reserve(256);
    bool fcb = true;
    bool fcv = false;
    const auto next = [&](std::uint8_t dsap, const bytes& du) -> const bytes& {
        reqs.push_back(request(fc(fcb, fcv), dsap, du));
        fcv = true;
        fcb = !fcb;
        return reqs.back();
    };
    std::vector<ferrule::script_step> steps;
    const auto step = [&](const bytes& req, const bytes& rsp, int corrupt = -1) {
        ferrule::script_step s;
        s.expect = req;
        s.reply = rsp;
        s.delay = 1ms;
        s.corrupt_index = corrupt;
        steps.push_back(s);
    };
    step(fdl_req, fdl_res);
    step(next(diag_sap, {}), wprm);
    step(next(prm_sap, prm_du), ack);
    step(next(cfg_sap, cfg), ack);
    step(next(diag_sap, {}), ready);
    for (int i = 0; i < 20; ++i) {
        const bytes& dx = next(no_sap, outputs);
        if (i % 5 == 1) step(dx, {});    // timeout, retried with the same FCB
        if (i % 5 == 2) step(dx, dl, 7); // FCS error, retried
        step(dx, i % 5 == 3 ? dh : dl);
        if (i % 5 == 3) step(next(diag_sap, {}), ready); // DH: fetch the diagnosis
        if (i % 5 == 4) step(next(no_sap, outputs), rs);
        step(gc, {});
    }
    auto peer = std::make_unique<ferrule::script_peer>(steps);
    auto line = std::make_unique<ferrule::mock_serial>(format(19200), peer.get());
    auto m = std::make_unique<master>();

    // The counter is the one operator new counts.
    const auto probe_before = ferrule_test::allocations.load();
    auto probe = std::make_unique<int>(1);
    REQUIRE(ferrule_test::allocations.load() == probe_before + 1);

    std::size_t failures = 0;
    std::size_t refusals = 0;
    const auto before = ferrule_test::allocations.load();
    failures += static_cast<bool>(bring_up(*line, *m, 8, p, cfg));
    for (int i = 0; i < 20; ++i) {
        std::array<std::uint8_t, 2> in{};
        failures += static_cast<bool>(data_exchange(*line, *m, 8, outputs, in));
        failures += in[1] != 0xCD;
        slave_diag d;
        if (m->data_high()) failures += static_cast<bool>(read_slave_diag(*line, *m, 8, d));
        if (i % 5 == 4)
            refusals += data_exchange(*line, *m, 8, outputs, in) == device_errc::sap_not_active;
        global_control c;
        c.command = control::clear_data;
        failures += static_cast<bool>(send_global_control(*line, *m, c));
        line->clear_wire_log();
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(failures == 0);
    CHECK(refusals == 4);
    CHECK(peer->finished());
    CHECK(peer->mismatches() == 0);
    CHECK(m->stats().timeouts == 4);
    CHECK(m->stats().bad_checksums == 4);
    CHECK(m->stats().data_high == 4);
    CHECK(m->stats().unacknowledged == 20);
}

TEST_CASE("PROFIBUS master cycle over three slaves allocates nothing", "[alloc][profibus]") {
    const std::array<std::uint8_t, 2> cfg_a{0x11, 0x21};
    const std::array<std::uint8_t, 1> cfg_b{0x33};
    const auto slave = [](std::uint8_t address, std::span<const std::uint8_t> cfg) {
        slave_config c;
        c.baud = 187'500;
        c.address = address;
        c.ident = 0x0815;
        c.cfg = cfg;
        return c;
    };
    auto bus = std::make_unique<sim::bus<3>>();
    bus->add(slave(5, cfg_a));
    bus->add(slave(6, cfg_b));
    bus->add(slave(7, cfg_a));
    auto line = std::make_unique<ferrule::mock_serial>(format(187'500), bus.get());
    master_config mc;
    mc.format = format(187'500);
    auto m = std::make_unique<master>(mc);
    std::array<std::uint8_t, 4> out{1, 2, 3, 4};
    std::array<std::array<std::uint8_t, 4>, 3> in{};
    auto slaves = std::make_unique<std::array<cycle_slave, 3>>();
    const std::array<std::span<const std::uint8_t>, 3> cfgs{cfg_a, cfg_b, cfg_a};
    for (std::size_t i = 0; i < 3; ++i) {
        cycle_slave& s = (*slaves)[i];
        s.address = static_cast<std::uint8_t>(5 + i);
        s.prm.ident = 0x0815;
        s.cfg = cfgs[i];
        const std::size_t n = i == 1 ? 4 : 2;
        s.outputs = std::span<const std::uint8_t>(out.data(), n);
        s.inputs = std::span<std::uint8_t>(in[i].data(), n);
    }
    auto c = std::make_unique<cycle>(*m, *slaves);
    ferrule::poll_driver<ferrule::mock_serial, cycle> driver(*line, *c);

    const auto before = ferrule_test::allocations.load();
    const ferrule::time_point limit = line->now() + 5s;
    while (c->passes() < 50 && ferrule::before(line->now(), limit)) {
        driver.step();
        line->advance(20us);
        if (line->wire().size() > 64) line->clear_wire_log();
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(c->passes() == 50);
    CHECK(c->last_pass_exchanges() == 3);
    CHECK((*slaves)[1].failures == 0);
}
