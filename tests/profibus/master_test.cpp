// PROFIBUS-DP master (DP-V0) against scripted slaves on mock_serial, in virtual time.
// Master 2, slave 8, ident 0x0815: the golden telegrams of protocols/modbus_profibus.md §B.9.
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "ferrule/core/driver.hpp"
#include "ferrule/sim/mock_serial.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/error.hpp"
#include "ferrule/profibus/master.hpp"

using namespace std::chrono_literals;
using namespace ferrule::profibus;
using ferrule::errc;
using ferrule::mock_serial;
using ferrule::script_step;
using ferrule::time_point;
using bytes = std::vector<std::uint8_t>;

namespace {

const ferrule::serial_format f19200 = format(19200);
const ferrule::duration syn = bit_times(19200, syn_bits);
const ferrule::duration slot = bit_times(19200, 100);
// The slave answers 20 tbit after the request (between min TSDR 11 and max TSDR 60, §B.1).
const ferrule::duration tsdr = bit_times(19200, 20);

// §B.9
const bytes fdl_status_req{0x10, 0x08, 0x02, 0x49, 0x53, 0x16};
const bytes fdl_status_res{0x10, 0x02, 0x08, 0x00, 0x0A, 0x16};
const bytes diag_req_first{0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x6D, 0x3C, 0x3E, 0xF1, 0x16};
const bytes diag_res_sd3{0xA2, 0x82, 0x88, 0x08, 0x3E, 0x3C, 0x02,
                         0x05, 0x00, 0xFF, 0x08, 0x15, 0xAF, 0x16};
const bytes set_prm_req_7d{0x68, 0x0C, 0x0C, 0x68, 0x88, 0x82, 0x7D, 0x3D, 0x3E,
                           0x88, 0x0A, 0x0A, 0x0B, 0x08, 0x15, 0x00, 0xC6, 0x16};
const bytes chk_cfg_req_6d{0x68, 0x07, 0x07, 0x68, 0x88, 0x82, 0x6D,
                           0x3E, 0x3E, 0x11, 0x21, 0x25, 0x16};
const bytes short_ack{0xE5};
const bytes dx_req_5d{0x68, 0x05, 0x05, 0x68, 0x08, 0x02, 0x5D, 0x12, 0x34, 0xAD, 0x16};
const bytes dx_res_dl{0x68, 0x05, 0x05, 0x68, 0x02, 0x08, 0x08, 0xAB, 0xCD, 0x8A, 0x16};
const bytes dx8_req_5d{0xA2, 0x08, 0x02, 0x5D, 0x00, 0x01, 0x02,
                       0x03, 0x04, 0x05, 0x06, 0x07, 0x83, 0x16};
const bytes gc_clear_data{0x68, 0x07, 0x07, 0x68, 0xFF, 0x82, 0x46,
                          0x3A, 0x3E, 0x02, 0x00, 0x41, 0x16};

// The same services with the other FCB/FCV states (FCS by the sum rule of §B.2).
const bytes diag_req_5d{0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x5D, 0x3C, 0x3E, 0xE1, 0x16};
const bytes diag_req_7d{0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x7D, 0x3C, 0x3E, 0x01, 0x16};
const bytes set_prm_req_5d{0x68, 0x0C, 0x0C, 0x68, 0x88, 0x82, 0x5D, 0x3D, 0x3E,
                           0x88, 0x0A, 0x0A, 0x0B, 0x08, 0x15, 0x00, 0xA6, 0x16};
const bytes chk_cfg_req_7d{0x68, 0x07, 0x07, 0x68, 0x88, 0x82, 0x7D,
                           0x3E, 0x3E, 0x11, 0x21, 0x35, 0x16};
const bytes dx_req_7d{0x68, 0x05, 0x05, 0x68, 0x08, 0x02, 0x7D, 0x12, 0x34, 0xCD, 0x16};
const bytes get_cfg_req_6d{0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x6D, 0x3B, 0x3E, 0xF0, 0x16};

// Replies of slave 8.
const bytes diag_res_sd2{0x68, 0x0B, 0x0B, 0x68, 0x82, 0x88, 0x08, 0x3E, 0x3C,
                         0x02, 0x05, 0x00, 0xFF, 0x08, 0x15, 0xAF, 0x16};
// Stat_Diag after Chk_Cfg (§B.6): not ready yet, then ready.
const bytes diag_res_stat{0x68, 0x0B, 0x0B, 0x68, 0x82, 0x88, 0x08, 0x3E, 0x3C,
                          0x02, 0x06, 0x00, 0x02, 0x08, 0x15, 0xB3, 0x16};
const bytes diag_res_ready{0x68, 0x0B, 0x0B, 0x68, 0x82, 0x88, 0x08, 0x3E, 0x3C,
                           0x00, 0x0C, 0x00, 0x02, 0x08, 0x15, 0xB7, 0x16};
const bytes diag_res_wrong_ssap{0x68, 0x0B, 0x0B, 0x68, 0x82, 0x88, 0x08, 0x3E, 0x3D,
                                0x02, 0x05, 0x00, 0xFF, 0x08, 0x15, 0xB0, 0x16};
const bytes dx_res_dh{0x68, 0x05, 0x05, 0x68, 0x02, 0x08, 0x0A, 0xAB, 0xCD, 0x8C, 0x16};
const bytes dx_res_from_9{0x68, 0x05, 0x05, 0x68, 0x02, 0x09, 0x08, 0xAB, 0xCD, 0x8B, 0x16};
const bytes rs_res{0x10, 0x02, 0x08, 0x03, 0x0D, 0x16};
const bytes get_cfg_res{0x68, 0x07, 0x07, 0x68, 0x82, 0x88, 0x08,
                        0x3E, 0x3B, 0x11, 0x21, 0xBD, 0x16};

const std::array<std::uint8_t, 2> cfg_2in_2out{0x11, 0x21};
const std::array<std::uint8_t, 2> out_1234{0x12, 0x34};

prm_data golden_prm() {
    prm_data p;
    p.station_status = prm::lock_req | prm::wd_on;
    p.wd_fact1 = 10;
    p.wd_fact2 = 10;
    p.min_tsdr = 11;
    p.ident = 0x0815;
    return p;
}

script_step answer(const bytes& req, const bytes& rsp, ferrule::duration delay = tsdr) {
    script_step s;
    s.expect = req;
    s.reply = rsp;
    s.delay = delay;
    return s;
}
script_step silent(const bytes& req) {
    script_step s;
    s.expect = req;
    return s;
}

struct request_on_wire {
    time_point start;
    time_point end;
    bytes data;
};

// The requests on the wire (a session byte that does not follow the previous one starts one).
std::vector<request_on_wire> requests(const mock_serial& line) {
    std::vector<request_on_wire> out;
    time_point last_end = time_point::min();
    for (const auto& b : line.wire()) {
        if (b.origin != ferrule::wire_byte::from::session) continue;
        if (b.start != last_end) out.push_back({b.start, b.end, {}});
        out.back().end = b.end;
        out.back().data.push_back(b.value);
        last_end = b.end;
    }
    return out;
}

// End of the last byte the slaves sent before `t`.
time_point peer_end_before(const mock_serial& line, time_point t) {
    time_point end{};
    for (const auto& b : line.wire())
        if (b.origin == ferrule::wire_byte::from::peer && b.end <= t) end = b.end;
    return end;
}

bytes as_bytes(std::span<const std::uint8_t> s) {
    return bytes(s.begin(), s.end());
}

} // namespace

TEST_CASE("profibus master timing constants at 19200", "[profibus][master]") {
    CHECK(syn == 1'718'750ns);
    CHECK(slot == 5'208'334ns);
    CHECK(slot_time_bits(19200) == 100);
    CHECK(slot_time_bits(187'500) == 100);
    CHECK(slot_time_bits(500'000) == 200);
    CHECK(slot_time_bits(1'500'000) == 300);
    CHECK(slot_time_bits(12'000'000) == 1000);
    CHECK(master().config().slot_time == slot);
    master_config fast;
    fast.format = format(1'500'000);
    CHECK(master(fast).config().slot_time == bit_times(1'500'000, 300));
    master_config fixed;
    fixed.slot_time = 20ms;
    CHECK(master(fixed).config().slot_time == 20ms);
}

TEST_CASE("profibus master FDL_Status: golden request without FCB, SD1 reply, wire time",
          "[profibus][master]") {
    const std::array<script_step, 1> steps{answer(fdl_status_req, fdl_status_res)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    REQUIRE_FALSE(fdl_status(line, m, 8));
    CHECK(peer.mismatches() == 0);
    CHECK(as_bytes(m.request_bytes()) == fdl_status_req);
    CHECK(m.response_fn() == response_fn::ok);
    CHECK(m.reply_frame() == frame::sd1);
    CHECK(m.reply().empty());
    CHECK(line.now() == time_point{} + f19200.chars_time(6) + tsdr + f19200.chars_time(6));
    CHECK(m.stats().transactions == 1);
    CHECK(m.stats().succeeded == 1);
    // FDL_Status leaves the FCB alone: the first SRD afterwards is still a first one.
    const std::array<script_step, 1> diag{answer(diag_req_first, diag_res_sd3)};
    ferrule::script_peer peer2(diag);
    line.set_peer(&peer2);
    slave_diag d;
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    CHECK(peer2.mismatches() == 0);
}

TEST_CASE("profibus master bring_up: the §B.6 sequence, FCB toggling and 33 tbit before each "
          "request",
          "[profibus][master]") {
    const std::array<script_step, 7> steps{answer(fdl_status_req, fdl_status_res),
                                           answer(diag_req_first, diag_res_sd3),
                                           answer(set_prm_req_5d, short_ack),
                                           answer(chk_cfg_req_7d, short_ack),
                                           answer(diag_req_5d, diag_res_stat),
                                           answer(diag_req_7d, diag_res_ready),
                                           answer(dx_req_5d, dx_res_dl)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    REQUIRE_FALSE(bring_up(line, m, 8, golden_prm(), cfg_2in_2out));
    CHECK(m.diag().ready());
    CHECK(m.diag().master == 2);
    CHECK(m.diag().ident == 0x0815);
    CHECK(m.diag().status2 == (diag::always_one | diag::wd_on));
    std::array<std::uint8_t, 2> in{};
    REQUIRE_FALSE(data_exchange(line, m, 8, out_1234, in));
    CHECK(in == std::array<std::uint8_t, 2>{0xAB, 0xCD});
    CHECK(peer.finished());
    CHECK(peer.mismatches() == 0);
    const auto reqs = requests(line);
    REQUIRE(reqs.size() == 7);
    CHECK(reqs[0].start == time_point{});
    for (std::size_t i = 1; i < reqs.size(); ++i) {
        CHECK(reqs[i].start - peer_end_before(line, reqs[i].start) == syn);
        CHECK(reqs[i].data == bytes(steps[i].expect.begin(), steps[i].expect.end()));
    }
    CHECK(m.stats().transactions == 7);
    CHECK(m.stats().succeeded == 7);
    CHECK(m.stats().resends == 0);
}

TEST_CASE("profibus master golden Set_Prm 0x7D and Chk_Cfg 0x6D", "[profibus][master]") {
    // pyprofibus built each golden telegram with its own FCB state: Set_Prm as a third
    // request (FCV=1, FCB back to 1), Chk_Cfg as a first one.
    const std::array<script_step, 4> steps{
        answer(diag_req_first, diag_res_sd3), answer(diag_req_5d, diag_res_sd3),
        answer(set_prm_req_7d, short_ack), answer(chk_cfg_req_6d, short_ack)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    slave_diag d;
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    REQUIRE_FALSE(set_prm(line, m, 8, golden_prm()));
    CHECK(as_bytes(m.request_bytes()) == set_prm_req_7d);
    CHECK(m.reply_frame() == frame::short_ack);
    m.reset_fcb(8);
    REQUIRE_FALSE(chk_cfg(line, m, 8, cfg_2in_2out));
    CHECK(as_bytes(m.request_bytes()) == chk_cfg_req_6d);
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
}

TEST_CASE("profibus master Data_Exchange alternates 0x5D / 0x7D; SD3 for 8 outputs",
          "[profibus][master]") {
    const std::array<std::uint8_t, 8> out8{0, 1, 2, 3, 4, 5, 6, 7};
    const std::array<script_step, 5> steps{
        answer(diag_req_first, diag_res_sd3), answer(dx_req_5d, dx_res_dl),
        answer(dx_req_7d, dx_res_dl), answer(dx8_req_5d, short_ack), answer(dx_req_7d, dx_res_dl)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    slave_diag d;
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    std::array<std::uint8_t, 2> in{};
    REQUIRE_FALSE(data_exchange(line, m, 8, out_1234, in));
    CHECK(in == std::array<std::uint8_t, 2>{0xAB, 0xCD});
    CHECK(m.response_fn() == response_fn::data_low);
    REQUIRE_FALSE(data_exchange(line, m, 8, out_1234, in));
    // A slave without inputs answers with the short acknowledgement (§B.5).
    REQUIRE_FALSE(data_exchange(line, m, 8, out8, std::span<std::uint8_t>{}));
    CHECK(as_bytes(m.request_bytes()) == dx8_req_5d);
    CHECK(m.reply().empty());
    in = {};
    REQUIRE_FALSE(data_exchange(line, m, 8, out_1234, in));
    CHECK(in == std::array<std::uint8_t, 2>{0xAB, 0xCD});
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
    CHECK_FALSE(m.data_high());
    CHECK(m.stats().data_high == 0);
}

TEST_CASE("profibus master: a retry after a timeout keeps the FCB; the attempt ends at request "
          "end + slot time",
          "[profibus][master]") {
    const std::array<script_step, 4> steps{answer(diag_req_first, diag_res_sd3), silent(dx_req_5d),
                                           answer(dx_req_5d, dx_res_dl),
                                           answer(dx_req_7d, dx_res_dl)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    slave_diag d;
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    std::array<std::uint8_t, 2> in{};
    REQUIRE_FALSE(data_exchange(line, m, 8, out_1234, in));
    CHECK(m.attempts() == 2);
    REQUIRE_FALSE(data_exchange(line, m, 8, out_1234, in));
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
    const auto reqs = requests(line);
    REQUIRE(reqs.size() == 4);
    CHECK(reqs[1].data == dx_req_5d);
    CHECK(reqs[2].data == dx_req_5d);
    CHECK(reqs[3].data == dx_req_7d);
    CHECK(reqs[2].start == reqs[1].end + slot);
    CHECK(m.stats().timeouts == 1);
    CHECK(m.stats().resends == 1);
    CHECK(m.stats().succeeded == 3);
    CHECK(m.stats().failed == 0);
}

TEST_CASE("profibus master: a silent slave ends the transaction after each attempt's slot time",
          "[profibus][master]") {
    const std::array<script_step, 4> steps{
        answer(diag_req_first, diag_res_sd3), silent(dx_req_5d), silent(dx_req_5d),
        // No reply, so the slave may not have seen that FCB: it starts over (FCV=0).
        answer(diag_req_first, diag_res_sd3)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    slave_diag d;
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    std::array<std::uint8_t, 2> in{};
    const time_point t0 = line.now() + syn;
    CHECK(data_exchange(line, m, 8, out_1234, in) == errc::timeout);
    const ferrule::duration attempt = f19200.chars_time(dx_req_5d.size()) + slot;
    CHECK(line.now() == t0 + 2 * attempt);
    CHECK(m.attempts() == 2);
    CHECK(m.stats().timeouts == 2);
    CHECK(m.stats().failed == 1);
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
}

TEST_CASE("profibus master: a reply with a bad FCS is retried with the same FCB",
          "[profibus][master]") {
    script_step garbled = answer(dx_req_5d, dx_res_dl);
    garbled.corrupt_index = 7; // an input byte: the FCS no longer matches
    garbled.corrupt_mask = 0x01;
    const std::array<script_step, 3> steps{answer(diag_req_first, diag_res_sd3), garbled,
                                           answer(dx_req_5d, dx_res_dl)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    slave_diag d;
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    std::array<std::uint8_t, 2> in{};
    REQUIRE_FALSE(data_exchange(line, m, 8, out_1234, in));
    CHECK(in == std::array<std::uint8_t, 2>{0xAB, 0xCD});
    CHECK(m.stats().bad_checksums == 1);
    CHECK(m.stats().resends == 1);
    CHECK(peer.mismatches() == 0);
    const auto reqs = requests(line);
    REQUIRE(reqs.size() == 3);
    // The retry follows once the line has been idle for TSYN after the garbled reply.
    const time_point garbled_end = peer_end_before(line, reqs[2].start);
    CHECK(reqs[2].start - garbled_end == syn + f19200.char_time());
}

TEST_CASE("profibus master accepts an 8-byte data unit as SD2 and as SD3", "[profibus][master]") {
    const std::array<script_step, 2> steps{answer(diag_req_first, diag_res_sd3),
                                           answer(diag_req_5d, diag_res_sd2)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    for (const frame expected : {frame::sd3, frame::sd2}) {
        slave_diag d;
        REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
        CHECK(m.reply_frame() == expected);
        CHECK(d.status1 == diag::station_not_ready);
        CHECK(d.status2 == (diag::prm_req | diag::always_one));
        CHECK(d.status3 == 0);
        CHECK(d.master == diag::no_master);
        CHECK(d.ident == 0x0815);
        CHECK(d.ext.empty());
        CHECK_FALSE(d.ready());
        CHECK(as_bytes(m.reply()) == bytes{0x02, 0x05, 0x00, 0xFF, 0x08, 0x15});
    }
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("profibus master: RS is the slave's answer, a device error, not retried",
          "[profibus][master]") {
    const std::array<script_step, 3> steps{answer(diag_req_first, diag_res_sd3),
                                           answer(dx_req_5d, rs_res), answer(dx_req_7d, dx_res_dl)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    slave_diag d;
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    std::array<std::uint8_t, 2> in{};
    const std::error_code ec = data_exchange(line, m, 8, out_1234, in);
    CHECK(ec == device_errc::sap_not_active);
    CHECK(ec.category() == device_category());
    CHECK(ec.message() == "slave: SAP not activated (RS)");
    CHECK(m.response_fn() == response_fn::sap_not_active);
    CHECK(m.attempts() == 1);
    CHECK(peer.steps_done() == 2);
    CHECK(m.stats().device_errors == 1);
    CHECK(m.stats().resends == 0);
    CHECK(m.stats().failed == 1);
    // The slave answered: the FCB goes on toggling.
    REQUIRE_FALSE(data_exchange(line, m, 8, out_1234, in));
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
}

TEST_CASE("profibus master: a reply from another station is unexpected_address",
          "[profibus][master]") {
    master_config cfg;
    cfg.retries = 0;
    const std::array<script_step, 2> steps{answer(diag_req_first, diag_res_sd3),
                                           answer(dx_req_5d, dx_res_from_9)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m(cfg);
    slave_diag d;
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    std::array<std::uint8_t, 2> in{};
    CHECK(data_exchange(line, m, 8, out_1234, in) == errc::unexpected_address);
    CHECK(in == std::array<std::uint8_t, 2>{});
    CHECK(m.reply().empty());
    CHECK(m.stats().unexpected_addresses == 1);
    CHECK(m.stats().failed == 1);
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("profibus master: SAPs not swapped in the reply is malformed", "[profibus][master]") {
    master_config cfg;
    cfg.retries = 0;
    const std::array<script_step, 1> steps{answer(diag_req_first, diag_res_wrong_ssap)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m(cfg);
    slave_diag d;
    CHECK(read_slave_diag(line, m, 8, d) == errc::malformed);
    CHECK(m.stats().malformed == 1);
}

TEST_CASE("profibus master Global_Control: golden telegram, no reply, TSYN of quiet",
          "[profibus][master]") {
    const std::array<script_step, 2> steps{silent(gc_clear_data), silent(gc_clear_data)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    global_control gc;
    gc.command = control::clear_data;
    REQUIRE_FALSE(m.start_global_control(gc));
    CHECK(ferrule::run(line, m) == errc::no_response_expected);
    CHECK(as_bytes(m.request_bytes()) == gc_clear_data);
    CHECK(line.now() == time_point{} + f19200.chars_time(gc_clear_data.size()) + syn);
    CHECK(m.stats().unacknowledged == 1);
    CHECK(m.stats().succeeded == 0);
    CHECK(m.stats().failed == 0);
    // The helper treats the missing reply as success.
    CHECK_FALSE(send_global_control(line, m, gc));
    CHECK(m.error() == errc::no_response_expected);
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
    const auto reqs = requests(line);
    REQUIRE(reqs.size() == 2);
    CHECK(reqs[1].start == reqs[0].end + syn);
    CHECK(m.stats().unacknowledged == 2);
}

TEST_CASE("profibus master: a DH reply sets data_high() until the next Data_Exchange",
          "[profibus][master]") {
    const std::array<script_step, 4> steps{
        answer(diag_req_first, diag_res_sd3), answer(dx_req_5d, dx_res_dh),
        answer(diag_req_7d, diag_res_ready), answer(dx_req_5d, dx_res_dl)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    slave_diag d;
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    std::array<std::uint8_t, 2> in{};
    REQUIRE_FALSE(data_exchange(line, m, 8, out_1234, in));
    CHECK(in == std::array<std::uint8_t, 2>{0xAB, 0xCD});
    CHECK(m.data_high());
    CHECK(m.response_fn() == response_fn::data_high);
    CHECK(m.stats().data_high == 1);
    // The master fetches the diagnosis (§B.3); data_high() still tells the last exchange.
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    CHECK(d.ready());
    CHECK(m.data_high());
    REQUIRE_FALSE(data_exchange(line, m, 8, out_1234, in));
    CHECK_FALSE(m.data_high());
    CHECK(m.stats().data_high == 1);
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
}

TEST_CASE("profibus master Get_Cfg returns the configuration bytes", "[profibus][master]") {
    const std::array<script_step, 1> steps{answer(get_cfg_req_6d, get_cfg_res)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    REQUIRE_FALSE(get_cfg(line, m, 8));
    CHECK(as_bytes(m.reply()) == bytes{0x11, 0x21});
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("profibus master bring_up reports a slave that stays not ready", "[profibus][master]") {
    const std::array<script_step, 6> steps{
        answer(fdl_status_req, fdl_status_res), answer(diag_req_first, diag_res_sd3),
        answer(set_prm_req_5d, short_ack),      answer(chk_cfg_req_7d, short_ack),
        answer(diag_req_5d, diag_res_stat),     answer(diag_req_7d, diag_res_stat)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m;
    CHECK(bring_up(line, m, 8, golden_prm(), cfg_2in_2out, 2) == device_errc::not_ready);
    CHECK(peer.mismatches() == 0);
    CHECK(peer.finished());
}

TEST_CASE("profibus master refuses bad requests and a second start", "[profibus][master]") {
    master m;
    CHECK(m.start_slave_diag(127) == errc::invalid_argument);
    CHECK(m.start_slave_diag(2) == errc::invalid_argument); // its own address
    CHECK(m.start_global_control({}, 128) == errc::invalid_argument);
    const std::array<std::uint8_t, max_data + 1> too_long{};
    CHECK(m.start_data_exchange(8, too_long) == errc::invalid_argument);
    CHECK(m.stats().transactions == 0);
    REQUIRE_FALSE(m.start_fdl_status(8));
    CHECK(m.start_slave_diag(8) == errc::busy);
    CHECK(m.busy());
}

TEST_CASE("profibus device_category messages", "[profibus][master]") {
    CHECK(std::error_code(device_errc::user_error).message() == "slave: user error (UE)");
    CHECK(std::error_code(device_errc::no_resource).message() ==
          "slave: no resources for the request (RR)");
    CHECK(std::error_code(device_errc::no_response_data).message() ==
          "slave: no response data (NR)");
    CHECK(std::string(device_category().name()) == "profibus");
    CHECK(response_error(response_fn::no_resource) == device_errc::no_resource);
    CHECK_FALSE(response_error(response_fn::data_low));
}

TEST_CASE("profibus master: the reply's first character must arrive within the slot time",
          "[profibus][master]") {
    master_config cfg;
    cfg.retries = 0;
    // First character complete exactly at request end + TSL: the telegram may go on past it.
    const ferrule::duration just_in_time = slot - f19200.char_time();
    const std::array<script_step, 2> steps{answer(diag_req_first, diag_res_sd2, just_in_time),
                                           answer(diag_req_5d, diag_res_sd2, just_in_time + 1ns)};
    ferrule::script_peer peer(steps);
    mock_serial line(f19200, &peer);
    master m(cfg);
    slave_diag d;
    REQUIRE_FALSE(read_slave_diag(line, m, 8, d));
    CHECK(d.ident == 0x0815);
    const auto first = requests(line).at(0);
    CHECK(line.now() == first.end + slot + f19200.chars_time(diag_res_sd2.size() - 1));
    // One nanosecond later is too late.
    CHECK(read_slave_diag(line, m, 8, d) == errc::timeout);
    const auto second = requests(line).at(1);
    CHECK(line.now() == second.end + slot);
    CHECK(peer.mismatches() == 0);
}

TEST_CASE("profibus master: on a link faster than its format the next request waits TSYN after "
          "the reply only",
          "[profibus][master]") {
    // A pty: the reply is back long before the request's computed end at 19200 Bd.
    master m;
    const time_point t0{};
    REQUIRE_FALSE(m.start_fdl_status(8));
    const auto sent = m.next(t0);
    REQUIRE(sent.what == ferrule::session_action::kind::send);
    CHECK(as_bytes(sent.bytes) == fdl_status_req);
    CHECK(sent.discard_input);
    m.on_receive(fdl_status_res, t0 + 100us);
    REQUIRE(m.next(t0 + 100us).what == ferrule::session_action::kind::done);
    REQUIRE_FALSE(m.error());
    m.clear();
    REQUIRE_FALSE(m.start_fdl_status(8));
    const auto wait = m.next(t0 + 100us);
    REQUIRE(wait.what == ferrule::session_action::kind::wait);
    CHECK(wait.deadline == t0 + 100us + syn);
    CHECK(m.next(t0 + 100us + syn).what == ferrule::session_action::kind::send);
}
