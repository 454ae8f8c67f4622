// The Extended MEMOBUS controller side, memobus::server on a register_image (and
// memobus::server_session framing a TCP stream for it), never allocates: every SFC it serves, its
// error responses 01 / 02 / 03 (unknown SFC and MFC, addresses beyond the image, counts and lengths
// out of limits, writes outside the write range) and the messages it does not answer, in both data
// orders and with area offsets, with the counting global operator new of counting_new.hpp, and the
// count must not move.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "ferrule/memobus/header.hpp"
#include "ferrule/memobus/message.hpp"
#include "ferrule/memobus/register_image.hpp"
#include "ferrule/memobus/server.hpp"
#include "ferrule/memobus/server_session.hpp"

// The counter of counting_new.hpp, whose operator new may be defined in one file only
// (no_heap_test.cpp): an inline variable, so this identical declaration names the same one.
namespace ferrule_test {
inline std::atomic<std::size_t> allocations{0};
} // namespace ferrule_test

using namespace ferrule::memobus;

namespace {

using octets = std::vector<std::uint8_t>;
using image_type = register_image<2048, 256>;

request make(sfc f, std::uint16_t address, std::uint16_t count) {
    request r;
    r.function = f;
    r.cpu = 0x21;
    r.address = address;
    r.count = count;
    return r;
}

octets command(const request& r, std::uint8_t serial, data_order o) {
    octets out(max_message);
    out.resize(*encode_command(r, serial, out, o, 1, 2));
    return out;
}

// A command with a well-formed header around `memobus` (the MEMOBUS part from MFC on).
octets framed(std::uint8_t type, const octets& memobus) {
    octets out(header_size + length_size + memobus.size());
    std::copy(memobus.begin(), memobus.end(), out.begin() + header_size + length_size);
    store_header({static_cast<command_type>(type), 9, 0, 0, static_cast<std::uint16_t>(out.size())},
                 out.data());
    ferrule::store_le16(&out[header_size], static_cast<std::uint16_t>(memobus.size()));
    return out;
}

struct expected_counts {
    std::size_t responses = 0;
    std::size_t sfc_errors = 0;
    std::size_t address_errors = 0;
    std::size_t count_errors = 0;
    std::size_t unanswered = 0;
};

// Every SFC, good and refused, for a server with the write range MW00000…MW01023.
std::vector<octets> messages(data_order o, expected_counts& n) {
    static const std::array<std::uint16_t, 4> values{0x1234, 0xABCD, 0x0001, 0x8000};
    static const std::array<std::uint16_t, 3> addresses{10, 20, 1000};
    static const std::array<std::uint16_t, 4> pairs{10, 0x1111, 20, 0x2222};
    static const std::array<std::uint16_t, 2> far_pair{1500, 0x3333}; // beyond the range
    static const std::array<std::uint8_t, 2> coils{0x05, 0x02};
    std::vector<octets> m;
    std::uint8_t serial = 0;
    const auto good = [&](request r) {
        m.push_back(command(r, serial++, o));
        ++n.responses;
    };
    good(make(sfc::read_coils, 0, 2000));
    good(make(sfc::read_input_relays, 16, 100));
    good(make(sfc::read_holding_registers, 100, 125));
    good(make(sfc::read_input_registers, 0, 125));
    request coil = make(sfc::write_coil, 1600, 1);
    coil.value = coil_on;
    good(coil);
    request single = make(sfc::write_holding_register, 100, 1);
    single.value = 0x1234;
    good(single);
    request loop = make(sfc::loopback, 0, 1);
    loop.value = 0xAAAA;
    good(loop);
    good(make(sfc::read_holding_registers_ext, 0, 2000));
    good(make(sfc::read_input_registers_ext, 0, 200));
    request wx = make(sfc::write_holding_registers_ext, 200, 4);
    wx.words = values;
    good(wx);
    request rr = make(sfc::read_holding_registers_random, 0, 3);
    rr.words = addresses;
    good(rr);
    request wr = make(sfc::write_holding_registers_random, 0, 2);
    wr.words = pairs;
    good(wr);
    request wc = make(sfc::write_coils, 3200, 10);
    wc.bits = coils;
    good(wc);
    request wm = make(sfc::write_holding_registers, 300, 4);
    wm.words = values;
    good(wm);

    // 02: beyond the image (after the offsets of the channel).
    m.push_back(command(make(sfc::read_holding_registers_ext, 2000, 100), serial++, o));
    m.push_back(command(make(sfc::read_input_registers, 250, 10), serial++, o));
    n.address_errors += 2;
    // 03: outside the write range, and counts out of their limits.
    request far = make(sfc::write_holding_registers_ext, 1500, 4);
    far.words = values;
    m.push_back(command(far, serial++, o));
    request far_random = make(sfc::write_holding_registers_random, 0, 1);
    far_random.words = far_pair;
    m.push_back(command(far_random, serial++, o));
    m.push_back(framed(0x11, {0x20, 0x0E, 0x21, 0x00, 0xD0, 0x07})); // 2000 pairs, none sent
    m.push_back(framed(0x11, {0x20, 0x03, 0x21, 0x00, 0x00, 0x00, 0x7E}));
    m.push_back(framed(0x11, {0x20, 0x09, 0x21, 0x00, 0x00, 0x00, 0x0A}));
    n.count_errors += 5;
    // 01: an unknown SFC, MFC 0x43.
    m.push_back(framed(0x11, {0x20, 0x07, 0x21, 0x00, 0x00}));
    m.push_back(
        framed(0x11, {0x43, 0x49, 0x10, 0x00, 0x4D, 0x00, 0x64, 0x00, 0x00, 0x00, 0x02, 0x00}));
    n.sfc_errors += 2;
    // Not answered: a general-purpose message, a response, half a message.
    m.push_back(framed(0x12, {0x34, 0x12}));
    m.push_back(framed(0x19, {0x20, 0x89, 0x01, 0x02}));
    octets half = m.front();
    half.resize(half.size() / 2);
    m.push_back(half);
    n.unanswered += 3;
    return m;
}

} // namespace

TEST_CASE("the memobus server allocates nothing", "[alloc][memobus]") {
    auto image = std::make_unique<image_type>();
    for (std::size_t i = 0; i < image_type::mw_size; ++i)
        image->set_mw(i, static_cast<std::uint16_t>(i * 3));
    for (std::size_t i = 0; i < image_type::iw_size; ++i)
        image->set_iw(i, static_cast<std::uint16_t>(0x8000 + i));

    channel_config cfg;
    cfg.mw_offset = 16;
    cfg.iw_offset = 8;
    cfg.mb_offset = 4;
    cfg.ib_offset = 2;
    cfg.write_low = 0;
    cfg.write_high = 1023;
    channel_config le = cfg;
    le.order = data_order::little_endian;
    expected_counts be_counts, le_counts;
    const std::vector<octets> be_messages = messages(data_order::big_endian, be_counts);
    const std::vector<octets> le_messages = messages(data_order::little_endian, le_counts);
    auto be_server = std::make_unique<server>(cfg);
    auto le_server = std::make_unique<server>(le);
    auto out = std::make_unique<std::array<std::uint8_t, max_message>>();

    constexpr int rounds = 10;
    std::size_t replies = 0;
    std::size_t unanswered = 0;
    const auto before = ferrule_test::allocations.load();
    for (int round = 0; round < rounds; ++round) {
        for (const auto& msg : be_messages) {
            const std::size_t n = be_server->handle(msg, *image, *out);
            (n > 0 ? replies : unanswered) += 1;
        }
        for (const auto& msg : le_messages) {
            const std::size_t n = le_server->handle(msg, *image, *out);
            (n > 0 ? replies : unanswered) += 1;
        }
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);

    CHECK(unanswered == rounds * (be_counts.unanswered + le_counts.unanswered));
    CHECK(replies + unanswered == rounds * (be_messages.size() + le_messages.size()));
    for (const auto* s : {be_server.get(), le_server.get()}) {
        const channel_stats& st = s->stats();
        CHECK(st.responses == rounds * be_counts.responses);
        CHECK(st.sfc_errors == rounds * be_counts.sfc_errors);
        CHECK(st.address_errors == rounds * be_counts.address_errors);
        CHECK(st.count_errors == rounds * be_counts.count_errors);
        CHECK(st.general == rounds);
    }
    CHECK(image->mw(16 + 200) == 0x1234);
    CHECK(image->mw(16 + 20) == 0x2222);
    CHECK(image->mb(16 * 4 + 1600));
}

TEST_CASE("the memobus server session allocates nothing, framing a TCP stream in pieces",
          "[alloc][memobus]") {
    auto image = std::make_unique<image_type>();
    channel_config cfg;
    cfg.write_high = 1023;
    expected_counts counts;
    const std::vector<octets> messages_ = messages(data_order::big_endian, counts);
    // Whole messages only: in a stream, half a message takes the bytes behind it as its rest.
    octets stream;
    std::size_t whole = 0;
    for (const auto& msg : messages_) {
        if (!parse_message(msg)) continue;
        stream.insert(stream.end(), msg.begin(), msg.end());
        ++whole;
    }
    const std::size_t unanswered = counts.unanswered - (messages_.size() - whole);
    auto session = std::make_unique<server_session>(*image, cfg);

    constexpr int rounds = 10;
    constexpr std::size_t piece = 7; // messages split and joined alike
    std::size_t replies = 0;
    const ferrule::time_point now{};
    const auto before = ferrule_test::allocations.load();
    for (int round = 0; round < rounds; ++round) {
        for (std::size_t at = 0; at < stream.size(); at += piece) {
            const auto bytes = std::span<const std::uint8_t>(stream).subspan(
                at, std::min(piece, stream.size() - at));
            session->on_receive(bytes, now);
            while (session->next(now).what == ferrule::session_action::kind::send) ++replies;
        }
    }
    const auto after = ferrule_test::allocations.load();
    CHECK(after - before == 0);
    CHECK(session->stats().messages == rounds * whole);
    CHECK(replies == rounds * (whole - unanswered));
    CHECK(session->stats().malformed == 0);
    CHECK(session->stats().overflowed == 0);
}
