// The Extended MEMOBUS master, its access helpers and the register names never allocate:
// reads, writes, a stale serial, garbage, timeouts with resends and the controller's error
// codes on a scripted line, run with the counting global operator new of counting_new.hpp
// and the count must not move.
#include <catch2/catch.hpp>

#include <array>
#include <atomic>
#include <cstddef>
#include <memory>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/memobus/access.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/names.hpp"

// The counter of counting_new.hpp, whose operator new may be defined in one file only
// (no_heap_test.cpp): an inline variable, so this identical declaration names the same one.
namespace ferrule_test {
inline std::atomic<std::size_t> allocations{0};
} // namespace ferrule_test

using namespace std::chrono_literals;
using namespace ferrule::memobus;

namespace {

std::vector<std::uint8_t> command(const request& r, std::uint8_t serial) {
    std::vector<std::uint8_t> out(max_message);
    out.resize(*encode_command(r, serial, out));
    return out;
}

std::vector<std::uint8_t> reply(const std::vector<std::uint8_t>& cmd, const response& rsp) {
    const auto req = parse_request(std::span<const std::uint8_t>(cmd).subspan(header_size));
    std::vector<std::uint8_t> out(max_message);
    out.resize(*encode_response(load_header(cmd.data()), *req, rsp, out));
    return out;
}

std::vector<std::uint8_t> error_reply(const std::vector<std::uint8_t>& cmd) {
    std::vector<std::uint8_t> out(max_message);
    out.resize(
        *encode_error(load_header(cmd.data()), cmd[15], cmd[16], device_errc::address_error, out));
    return out;
}

request make(sfc f, std::uint16_t address, std::uint16_t count) {
    request r;
    r.function = f;
    r.address = address;
    r.count = count;
    return r;
}

} // namespace

TEST_CASE("memobus master traffic allocates nothing", "[alloc][memobus]") {
    // Every frame and script step is built before counting starts. Per round: a read of 4
    // MW (a stale answer first, garbage before it on odd rounds), a write of 2 MW, a read of
    // 10 coils timing out once and then answered, and a read of IW answered with an error.
    const std::array<std::uint16_t, 4> words{1, 2, 3, 4};
    const std::array<std::uint16_t, 2> written{7, 8};
    const std::array<std::uint8_t, 2> packed{0x05, 0x02};
    const std::array<std::uint8_t, 3> noise{0xDE, 0xAD, 0x00};
    std::vector<std::vector<std::uint8_t>> frames;
    frames.reserve(200);
    std::vector<ferrule::script_step> steps;
    std::uint8_t serial = 0;
    constexpr int rounds = 20;
    for (int i = 0; i < rounds; ++i) {
        response w;
        w.words = words;
        frames.push_back(command(make(sfc::read_holding_registers_ext, 100, 4), serial));
        frames.push_back(reply(frames.back(), w));
        auto stale = frames.back();
        stale[1] = static_cast<std::uint8_t>(serial - 1);
        stale.insert(stale.end(), frames.back().begin(), frames.back().end());
        frames.push_back(stale);
        ferrule::script_step s;
        s.expect = frames[frames.size() - 3];
        s.reply = frames.back();
        s.delay = 1ms;
        if (i % 2 == 1) s.noise = noise;
        steps.push_back(s);
        ++serial;

        request wr = make(sfc::write_holding_registers_ext, 200, 2);
        wr.words = written;
        frames.push_back(command(wr, serial));
        frames.push_back(reply(frames.back(), {}));
        steps.push_back({frames[frames.size() - 2], frames.back(), 1ms});
        ++serial;

        frames.push_back(command(make(sfc::read_coils, 1600, 10), serial++));
        steps.push_back({frames.back(), {}, 1ms});
        response b;
        b.bits = packed;
        frames.push_back(command(make(sfc::read_coils, 1600, 10), serial++));
        frames.push_back(reply(frames.back(), b));
        steps.push_back({frames[frames.size() - 2], frames.back(), 1ms});

        frames.push_back(command(make(sfc::read_input_registers_ext, 0, 1), serial++));
        frames.push_back(error_reply(frames.back()));
        steps.push_back({frames[frames.size() - 2], frames.back(), 1ms});
    }
    auto peer = std::make_unique<ferrule::script_peer>(steps);
    auto line = std::make_unique<ferrule::mock_serial>(
        ferrule::serial_format{4'000'000, 8, ferrule::parity::none, 1}, peer.get());
    master_config cfg;
    cfg.response_timeout = 50ms;
    cfg.retries = 1;
    auto m = std::make_unique<master>(cfg);

    std::size_t failures = 0;
    std::size_t errors = 0;
    const auto before = ferrule_test::allocations.load();
    for (int i = 0; i < rounds; ++i) {
        std::array<std::uint16_t, 4> r{};
        failures += static_cast<bool>(read(*line, *m, "MW00100", r));
        failures += r != words;
        failures += static_cast<bool>(write_words(*line, *m, mw(200), written));
        std::array<bool, 10> bits{};
        failures += static_cast<bool>(read_bits(*line, *m, *try_parse_register("MB001000"), bits));
        failures += !bits[0] || bits[1] || !bits[2] || !bits[9];
        std::array<std::uint16_t, 1> in{};
        errors += read_words(*line, *m, iw(0), in) == device_errc::address_error;
        std::array<char, max_register_name> name{};
        failures += !format_register(mb(100, 10), name);
        line->clear_wire_log();
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(failures == 0);
    CHECK(errors == rounds);
    CHECK(peer->finished());
    CHECK(peer->mismatches() == 0);
    CHECK(m->stats().stale == rounds);
    CHECK(m->stats().timeouts == rounds);
    CHECK(m->stats().malformed == rounds / 2);
    CHECK(m->stats().device_errors == rounds);
}
