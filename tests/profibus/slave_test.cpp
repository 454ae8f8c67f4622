// DP-V0 slave session, driven directly with telegrams in virtual time: the golden exchange
// of protocols/modbus_profibus.md §B.9 (master 2, slave 8, ident 0x0815, cfg 0x11 0x21),
// the state machine, FCB repeats, the watchdog, Global_Control and diagnosis with DH.
#include <catch2/catch.hpp>

#include <optional>
#include <vector>

#include "ferrule/profibus/slave.hpp"

using namespace std::chrono_literals;
using namespace ferrule::profibus;
using ferrule::duration;
using ferrule::session_action;
using ferrule::time_point;
using bytes = std::vector<std::uint8_t>;

namespace {

const bytes cfg{0x11, 0x21};

slave_config config() {
    slave_config c;
    c.baud = 19'200;
    c.address = 8;
    c.ident = 0x0815;
    c.cfg = cfg;
    return c;
}

// The golden requests (§B.9) and the ones built from them.
const bytes fdl_status_req{0x10, 0x08, 0x02, 0x49, 0x53, 0x16};
const bytes diag_req{0x68, 0x05, 0x05, 0x68, 0x88, 0x82, 0x6D, 0x3C, 0x3E, 0xF1, 0x16};
const bytes set_prm_req{0x68, 0x0C, 0x0C, 0x68, 0x88, 0x82, 0x7D, 0x3D, 0x3E,
                        0x88, 0x0A, 0x0A, 0x0B, 0x08, 0x15, 0x00, 0xC6, 0x16};
const bytes chk_cfg_req{0x68, 0x07, 0x07, 0x68, 0x88, 0x82, 0x6D,
                        0x3E, 0x3E, 0x11, 0x21, 0x25, 0x16};
const bytes clear_data_req{0x68, 0x07, 0x07, 0x68, 0xFF, 0x82, 0x46,
                           0x3A, 0x3E, 0x02, 0x00, 0x41, 0x16};
const bytes sc_reply{0xE5};

bytes telegram_bytes(std::uint8_t da, std::uint8_t sa, std::uint8_t fc, std::uint8_t dsap,
                     std::uint8_t ssap, const bytes& data) {
    telegram t;
    t.da = da;
    t.sa = sa;
    t.fc = fc;
    t.dsap = dsap;
    t.ssap = ssap;
    t.data = data;
    bytes out(max_telegram);
    out.resize(*encode(t, out));
    return out;
}

bytes data_exchange_req(const bytes& outputs, bool fcb, std::uint8_t sa = 2) {
    return telegram_bytes(8, sa, request_code(request_fn::srd_high, fcb, true), no_sap, no_sap,
                          outputs);
}

struct reply {
    bytes data;
    time_point start;       // of the reply's first byte
    time_point request_end; // the request's last byte
};

// A line with the slave on it: a request takes its wire time, the reply comes when the
// slave's next() says send.
struct bench {
    slave s{config()};
    time_point now{};

    std::optional<reply> request(const bytes& req) {
        now += format(19'200).chars_time(req.size());
        s.on_receive(req, now);
        const time_point end = now;
        for (;;) {
            const session_action a = s.next(now);
            if (a.what == session_action::kind::send) {
                reply r{bytes(a.bytes.begin(), a.bytes.end()), now, end};
                now += format(19'200).chars_time(a.bytes.size());
                return r;
            }
            // A reply is due within max TSDR; a later deadline is the watchdog's.
            if (a.what == session_action::kind::wait && a.deadline - end <= 10ms) {
                now = a.deadline;
                continue;
            }
            return std::nullopt;
        }
    }

    void bring_up() {
        REQUIRE(request(set_prm_req)->data == sc_reply);
        REQUIRE(request(chk_cfg_req)->data == sc_reply);
        REQUIRE(s.state() == slave_state::data_exchange);
    }
};

} // namespace

TEST_CASE("profibus slave answers the golden exchange byte for byte", "[profibus][slave]") {
    bench b;
    CHECK(b.s.state() == slave_state::wait_prm);
    // FDL_Status in every state: SD1, FC 0x00
    CHECK(b.request(fdl_status_req)->data == bytes{0x10, 0x02, 0x08, 0x00, 0x0A, 0x16});
    // Slave_Diag in Wait_Prm: Station_Not_Ready, Prm_Req, master FF, ident 0815 (SD3)
    CHECK(b.request(diag_req)->data == bytes{0xA2, 0x82, 0x88, 0x08, 0x3E, 0x3C, 0x02, 0x05, 0x00,
                                             0xFF, 0x08, 0x15, 0xAF, 0x16});
    // The golden telegrams were made one by one: after Slave_Diag's FCB = 1 the golden Set_Prm
    // (FCV = 1, FCB = 1) would be a repeat of it (§B.3). A slave just powered on takes it.
    b = bench{};
    CHECK(b.request(set_prm_req)->data == sc_reply);
    CHECK(b.s.state() == slave_state::wait_cfg);
    CHECK(b.s.master_address() == 2);
    CHECK(b.s.watchdog() == 1000ms);
    CHECK(b.request(chk_cfg_req)->data == sc_reply);
    CHECK(b.s.state() == slave_state::data_exchange);
    CHECK(b.s.input_size() == 2);
    CHECK(b.s.output_size() == 2);
    // Data_Exchange: 12 34 out, AB CD in, DL
    const bytes in{0xAB, 0xCD};
    b.s.set_inputs(in);
    const bytes out{0x12, 0x34};
    CHECK(data_exchange_req(out, false) ==
          bytes{0x68, 0x05, 0x05, 0x68, 0x08, 0x02, 0x5D, 0x12, 0x34, 0xAD, 0x16});
    CHECK(b.request(data_exchange_req(out, false))->data ==
          bytes{0x68, 0x05, 0x05, 0x68, 0x02, 0x08, 0x08, 0xAB, 0xCD, 0x8A, 0x16});
    CHECK(bytes(b.s.outputs().begin(), b.s.outputs().end()) == out);
    // Get_Cfg answers the configuration with the SAPs swapped.
    const auto get_cfg =
        telegram_bytes(8, 2, request_code(request_fn::srd_high, true, true), 59, 62, {});
    CHECK(b.request(get_cfg)->data ==
          telegram_bytes(2, 8, response_code(response_fn::data_low), 62, 59, cfg));
    // Slave_Diag in Data_Exchange: ready, parameterized by master 2, watchdog on
    const auto diag = b.request(diag_req);
    const bytes du(diag->data.begin() + 6, diag->data.end() - 2);
    const auto d = parse_slave_diag(du);
    REQUIRE(d);
    CHECK(d->ready());
    CHECK(d->master == 2);
    CHECK(d->status2 == (diag::always_one | diag::wd_on));
}

TEST_CASE("profibus slave replies after min TSDR, 11 bit times or as Set_Prm says",
          "[profibus][slave]") {
    bench b;
    const auto r = b.request(fdl_status_req);
    CHECK(r->start - r->request_end == bit_times(19'200, 11));
    CHECK(bit_times(19'200, 11) < bit_times(19'200, max_tsdr_bits(19'200)));
    // Set_Prm with min_TSDR 20
    const bytes prm{0x88, 0x0A, 0x0A, 20, 0x08, 0x15, 0x00};
    const auto set =
        telegram_bytes(8, 2, request_code(request_fn::srd_high, true, false), 61, 62, prm);
    CHECK(b.request(set)->data == sc_reply);
    const auto ack = b.request(fdl_status_req);
    CHECK(ack->start - ack->request_end == bit_times(19'200, 20));
}

TEST_CASE("profibus slave: a repeated FCB gets the stored reply, not a second execution",
          "[profibus][slave]") {
    bench b;
    b.bring_up();
    const bytes in1{0x01, 0x02};
    b.s.set_inputs(in1);
    const bytes out1{0x11, 0x11};
    const auto first = b.request(data_exchange_req(out1, false));
    CHECK(b.s.stats().data_exchanges == 1);
    // The master did not get the reply and sends again with the same FCB, new outputs even:
    // the slave answers what it answered and executes nothing.
    const bytes in2{0x03, 0x04};
    b.s.set_inputs(in2);
    const bytes out2{0x22, 0x22};
    // An FDL_Status in between does not replace the stored reply.
    CHECK(b.request(fdl_status_req));
    const auto again = b.request(data_exchange_req(out2, false));
    CHECK(again->data == first->data);
    CHECK(b.s.stats().repeats == 1);
    CHECK(b.s.stats().data_exchanges == 1);
    CHECK(bytes(b.s.outputs().begin(), b.s.outputs().end()) == out1);
    // The toggled FCB is a new request.
    const auto next = b.request(data_exchange_req(out2, true));
    CHECK(next->data ==
          telegram_bytes(2, 8, response_code(response_fn::data_low), no_sap, no_sap, in2));
    CHECK(bytes(b.s.outputs().begin(), b.s.outputs().end()) == out2);
    // Another master's telegram with that FCB is not a repeat of master 2's.
    CHECK(b.s.stats().data_exchanges == 2);
}

TEST_CASE("profibus slave: wrong ident, wrong configuration, wrong output length",
          "[profibus][slave]") {
    bench b;
    SECTION("an ident that is not the slave's: Prm_Fault, stays in Wait_Prm") {
        const bytes prm{0x88, 0x0A, 0x0A, 0x0B, 0x47, 0x11, 0x00};
        CHECK(b.request(telegram_bytes(8, 2, request_code(request_fn::srd_high, true, false), 61,
                                       62, prm))
                  ->data == sc_reply);
        CHECK(b.s.state() == slave_state::wait_prm);
        CHECK((b.s.diagnosis().status1 & diag::prm_fault) != 0);
        CHECK(b.s.stats().prm_faults == 1);
        // Chk_Cfg before parameters: acknowledged, not acted upon
        CHECK(b.request(chk_cfg_req)->data == sc_reply);
        CHECK(b.s.state() == slave_state::wait_prm);
        CHECK((b.s.diagnosis().status2 & diag::prm_req) != 0);
    }
    SECTION("a configuration that is not the slave's: Cfg_Fault, back to Wait_Prm") {
        CHECK(b.request(set_prm_req)->data == sc_reply);
        const bytes other{0x13};
        CHECK(b.request(telegram_bytes(8, 2, request_code(request_fn::srd_high, false, true), 62,
                                       62, other))
                  ->data == sc_reply);
        CHECK(b.s.state() == slave_state::wait_prm);
        CHECK((b.s.diagnosis().status1 & diag::cfg_fault) != 0);
    }
    SECTION("outputs of another length: back to Wait_Prm, RS") {
        b.bring_up();
        const bytes three{1, 2, 3};
        CHECK(b.request(data_exchange_req(three, false))->data ==
              bytes{0x10, 0x02, 0x08, 0x03, 0x0D, 0x16});
        CHECK(b.s.state() == slave_state::wait_prm);
        CHECK(b.s.stats().length_faults == 1);
    }
    SECTION("Data_Exchange before Data_Exchange state: RS, not ready") {
        const bytes two{1, 2};
        CHECK(b.request(data_exchange_req(two, false))->data ==
              bytes{0x10, 0x02, 0x08, 0x03, 0x0D, 0x16});
        CHECK((b.s.diagnosis().status1 & diag::station_not_ready) != 0);
    }
}

TEST_CASE("profibus slave watchdog: silence of the master sends it to Wait_Prm, outputs zero",
          "[profibus][slave]") {
    bench b;
    b.bring_up();
    const bytes out{0x55, 0xAA};
    const auto r = b.request(data_exchange_req(out, false));
    REQUIRE(r);
    CHECK(b.s.wake_at() == r->request_end + 1000ms);
    // Just before the watchdog time: still exchanging.
    const time_point expiry = b.s.wake_at();
    CHECK(b.s.next(expiry - 1us).what == session_action::kind::wait);
    CHECK(b.s.state() == slave_state::data_exchange);
    CHECK(b.s.next(expiry).what == session_action::kind::idle);
    CHECK(b.s.state() == slave_state::wait_prm);
    CHECK(b.s.stats().watchdog_expiries == 1);
    CHECK(b.s.outputs()[0] == 0);
    CHECK(b.s.outputs()[1] == 0);
    CHECK(b.s.master_address() == diag::no_master);
}

TEST_CASE("profibus slave Global_Control: Clear_Data, Freeze, Sync", "[profibus][slave]") {
    bench b;
    b.bring_up();
    const bytes out{0x12, 0x34};
    REQUIRE(b.request(data_exchange_req(out, false)));
    // Clear_Data to 127: no reply, outputs zero and kept so
    CHECK_FALSE(b.request(clear_data_req));
    CHECK(b.s.clear_data());
    CHECK(b.s.outputs()[0] == 0);
    REQUIRE(b.request(data_exchange_req(out, true)));
    CHECK(b.s.outputs()[0] == 0);
    const auto operate = [&](std::uint8_t command, std::uint8_t group) {
        const bytes du{command, group};
        return telegram_bytes(127, 2, request_code(request_fn::sdn_high, false, false), 58, 62, du);
    };
    CHECK_FALSE(b.request(operate(0, 0)));
    CHECK_FALSE(b.s.clear_data());
    REQUIRE(b.request(data_exchange_req(out, false)));
    CHECK(b.s.outputs()[0] == 0x12);
    // Freeze: the replies carry the inputs of the moment of the command.
    const bytes before{0x01, 0x01};
    b.s.set_inputs(before);
    CHECK_FALSE(b.request(operate(control::freeze, 0)));
    const bytes after{0x02, 0x02};
    b.s.set_inputs(after);
    CHECK(b.request(data_exchange_req(out, true))->data ==
          telegram_bytes(2, 8, response_code(response_fn::data_low), no_sap, no_sap, before));
    CHECK_FALSE(b.request(operate(control::unfreeze, 0)));
    CHECK(b.request(data_exchange_req(out, false))->data ==
          telegram_bytes(2, 8, response_code(response_fn::data_low), no_sap, no_sap, after));
    // Sync: outputs received are applied at the next Sync.
    CHECK_FALSE(b.request(operate(control::sync, 0)));
    const bytes held{0x77, 0x77};
    REQUIRE(b.request(data_exchange_req(held, true)));
    CHECK(b.s.outputs()[0] == 0x12);
    CHECK_FALSE(b.request(operate(control::sync, 0)));
    CHECK(b.s.outputs()[0] == 0x77);
    // A group the slave is not in is ignored.
    CHECK_FALSE(b.request(operate(control::clear_data, 0x04)));
    CHECK_FALSE(b.s.clear_data());
}

TEST_CASE("profibus slave: new diagnosis makes Data_Exchange answer DH until it is fetched",
          "[profibus][slave]") {
    bench b;
    b.bring_up();
    const bytes out{0, 0};
    const bytes block{0x03, 0x01, 0x80}; // device-related block, 3 bytes
    b.s.set_ext_diag(block, true);
    const auto dh = b.request(data_exchange_req(out, false));
    CHECK(dh->data[6] == response_code(response_fn::data_high));
    const auto diag_reply = b.request(diag_req);
    const bytes du(diag_reply->data.begin() + 9, diag_reply->data.end() - 2);
    const auto d = parse_slave_diag(du);
    REQUIRE(d);
    CHECK((d->status1 & diag::ext_diag) != 0);
    CHECK(bytes(d->ext.begin(), d->ext.end()) == block);
    CHECK(b.request(data_exchange_req(out, true))->data[6] == response_code(response_fn::data_low));
    // The same diagnosis again is no news.
    b.s.set_ext_diag(block, true);
    CHECK(b.request(data_exchange_req(out, false))->data[6] ==
          response_code(response_fn::data_low));
}

TEST_CASE("profibus slave: a locked slave ignores another master's parameters",
          "[profibus][slave]") {
    bench b;
    b.bring_up();
    const bytes prm{0x88, 0x0A, 0x0A, 0x0B, 0x08, 0x15, 0x00};
    CHECK(b.request(
               telegram_bytes(8, 3, request_code(request_fn::srd_high, true, false), 61, 62, prm))
              ->data == sc_reply);
    CHECK(b.s.master_address() == 2);
    CHECK(b.s.state() == slave_state::data_exchange);
    // Master 2 unlocks: free again, back to Wait_Prm.
    const bytes unlock{prm::unlock_req, 0x0A, 0x0A, 0x0B, 0x08, 0x15, 0x00};
    CHECK(b.request(
               telegram_bytes(8, 2, request_code(request_fn::srd_high, true, true), 61, 62, unlock))
              ->data == sc_reply);
    CHECK(b.s.master_address() == diag::no_master);
    CHECK(b.s.state() == slave_state::wait_prm);
}

namespace {

// Set_Prm from master `sa` with Station_Status `status`: watchdog 10 × 10, min_TSDR
// `tsdr`, ident 0x0815, group `group`, User_Prm_Data `user`.
bytes set_prm_from(std::uint8_t sa, std::uint8_t status, std::uint8_t tsdr = 0x0B,
                   std::uint8_t group = 0, const bytes& user = {}) {
    bytes du{status, 0x0A, 0x0A, tsdr, 0x08, 0x15, group};
    du.insert(du.end(), user.begin(), user.end());
    return telegram_bytes(8, sa, request_code(request_fn::srd_high, false, false), 61, 62, du);
}

slave_diag diag_from(bench& b, std::uint8_t sa) {
    const auto r = b.request(
        telegram_bytes(8, sa, request_code(request_fn::srd_high, false, false), 60, 62, {}));
    REQUIRE(r);
    const bytes du(r->data.begin() + 6, r->data.end() - 2); // SD3: 6 bytes of diagnosis
    const auto d = parse_slave_diag(du);
    REQUIRE(d);
    return *d;
}

bytes user_prm_of(const slave& s) {
    return {s.user_prm().begin(), s.user_prm().end()};
}

} // namespace

// Lock_Req / Unlock_Req, row by row (prm_lock in services.hpp: IEC 61158 as ABB FPBA-01
// "SAP 61" and Festo CP FB13-E print it).
TEST_CASE("profibus slave Set_Prm Lock 0 / Unlock 0: only min_TSDR and User_Prm_Data",
          "[profibus][slave][lock]") {
    bench b;
    SECTION("a slave waiting for parameters takes no others and keeps waiting") {
        CHECK(b.request(set_prm_from(2, prm::wd_on, 20, 1, {0xAB}))->data == sc_reply);
        CHECK(b.s.state() == slave_state::wait_prm);
        CHECK(b.s.master_address() == diag::no_master);
        CHECK(b.s.watchdog() == duration::zero());
        CHECK(user_prm_of(b.s) == bytes{0xAB});
        const auto ack = b.request(fdl_status_req);
        CHECK(ack->start - ack->request_end == bit_times(19'200, 20));
        const slave_diag d = diag_from(b, 2);
        CHECK((d.status2 & diag::prm_req) != 0);
        CHECK((d.status1 & diag::prm_fault) == 0);
        CHECK(d.master == diag::no_master);
        // Chk_Cfg is still not acted upon: parameters never came.
        CHECK(b.request(chk_cfg_req)->data == sc_reply);
        CHECK(b.s.state() == slave_state::wait_prm);
    }
    SECTION("a slave in Data_Exchange keeps its lock, watchdog, group, state and outputs") {
        b.bring_up();
        const bytes out{0x12, 0x34};
        REQUIRE(b.request(data_exchange_req(out, false)));
        CHECK(b.request(set_prm_from(2, 0x00, 30, 5, {0x01, 0x02}))->data == sc_reply);
        CHECK(b.s.state() == slave_state::data_exchange);
        CHECK(b.s.master_address() == 2);
        CHECK(b.s.watchdog() == 1000ms);
        CHECK(bytes(b.s.outputs().begin(), b.s.outputs().end()) == out);
        CHECK(user_prm_of(b.s) == (bytes{0x01, 0x02}));
        const auto ack = b.request(fdl_status_req);
        CHECK(ack->start - ack->request_end == bit_times(19'200, 30));
        // Group 0 is kept: Global_Control for group 5 (0x05 & 0) is not for this slave.
        const auto before = b.s.stats().global_controls;
        b.request(telegram_bytes(broadcast_address, 2,
                                 request_code(request_fn::sdn_high, false, false), 58, 62,
                                 {control::clear_data, 0x05}));
        CHECK(b.s.stats().global_controls == before);
    }
    SECTION("a wrong ident is not checked: the ident is not a parameter taken here") {
        const bytes du{0x00, 0x0A, 0x0A, 0x0B, 0x12, 0x34, 0x00};
        CHECK(b.request(telegram_bytes(8, 2, request_code(request_fn::srd_high, false, false), 61,
                                       62, du))
                  ->data == sc_reply);
        CHECK((diag_from(b, 2).status1 & diag::prm_fault) == 0);
    }
}

TEST_CASE("profibus slave Set_Prm Lock 1 / Unlock 0: locked to the master, all parameters",
          "[profibus][slave][lock]") {
    bench b;
    CHECK(b.request(set_prm_from(3, prm::lock_req | prm::wd_on, 20, 1, {0xCD}))->data == sc_reply);
    CHECK(b.s.state() == slave_state::wait_cfg);
    CHECK(b.s.master_address() == 3);
    CHECK(b.s.watchdog() == 1000ms);
    CHECK(user_prm_of(b.s) == bytes{0xCD});
    const slave_diag d = diag_from(b, 3);
    CHECK(d.master == 3);
    CHECK((d.status2 & diag::prm_req) == 0);
    CHECK((d.status2 & diag::wd_on) != 0);
}

TEST_CASE("profibus slave Set_Prm Unlock 1: released for other masters, with or without Lock",
          "[profibus][slave][lock]") {
    const std::uint8_t status =
        GENERATE(std::uint8_t{prm::unlock_req}, std::uint8_t{prm::lock_req | prm::unlock_req});
    bench b;
    b.bring_up();
    CHECK(b.request(set_prm_from(2, status | prm::wd_on, 40, 3, {0xEE}))->data == sc_reply);
    CHECK(b.s.state() == slave_state::wait_prm);
    CHECK(b.s.master_address() == diag::no_master);
    CHECK(b.s.outputs()[0] == 0);
    CHECK(user_prm_of(b.s).empty()); // no parameter taken
    const slave_diag d = diag_from(b, 3);
    CHECK(d.master == diag::no_master);
    CHECK((d.status2 & diag::prm_req) != 0);
    // Another master may lock it now.
    CHECK(b.request(set_prm_from(3, prm::lock_req))->data == sc_reply);
    CHECK(b.s.master_address() == 3);
}

TEST_CASE("profibus slave locked to master 2 refuses every Set_Prm of master 3",
          "[profibus][slave][lock]") {
    const std::uint8_t status =
        GENERATE(std::uint8_t{0x00}, std::uint8_t{prm::lock_req}, std::uint8_t{prm::unlock_req},
                 std::uint8_t{prm::lock_req | prm::unlock_req});
    bench b;
    b.bring_up();
    CHECK(b.request(set_prm_from(3, status | prm::wd_on, 40, 3, {0xEE}))->data == sc_reply);
    CHECK(b.s.state() == slave_state::data_exchange);
    CHECK(b.s.master_address() == 2);
    CHECK(user_prm_of(b.s).empty());
    const auto ack = b.request(fdl_status_req);
    CHECK(ack->start - ack->request_end == bit_times(19'200, 11));
    // Master 3 reads Master_Add 2: the slave is ready, for master 2 (Master_Lock is the
    // reading master's own conclusion, never set by the slave).
    const slave_diag d = diag_from(b, 3);
    CHECK(d.master == 2);
    CHECK(d.ready());
    CHECK((d.status1 & diag::master_lock) == 0);
}

TEST_CASE("profibus slave: broken telegrams and other stations' traffic get no reply",
          "[profibus][slave]") {
    bench b;
    CHECK_FALSE(b.request(bytes{0x10, 0x08, 0x02, 0x49, 0x54, 0x16})); // bad FCS
    CHECK(b.s.stats().bad_checksums == 1);
    CHECK_FALSE(b.request(bytes{0x10, 0x09, 0x02, 0x49, 0x54, 0x16})); // for station 9
    CHECK_FALSE(b.request(bytes{0x10, 0x02, 0x09, 0x00, 0x0B, 0x16})); // station 9's reply
    CHECK_FALSE(b.request(bytes{0xDC, 0x03, 0x02}));                   // a token
    CHECK(b.s.stats().not_ours == 3);
    CHECK_FALSE(b.request(bytes{0x00, 0x55, 0xAA}));
    CHECK(b.request(fdl_status_req)); // still answers after the garbage
}

// Found by fuzz/profibus_slave.cpp: the FDL_Status 10 7F 15 79 0D 16 (to 127) got the reply
// 10 15 08 00 1D 16, which every slave on the line would send at once.
TEST_CASE("profibus slave: only Global_Control is taken from the broadcast address",
          "[profibus][slave]") {
    bench b;
    const auto broadcast = [](std::uint8_t fc, std::uint8_t dsap, const bytes& du) {
        return telegram_bytes(broadcast_address, 21, fc, dsap, dsap == no_sap ? no_sap : master_sap,
                              du);
    };
    CHECK_FALSE(b.request(broadcast(0x79, no_sap, {})));
    CHECK_FALSE(
        b.request(broadcast(request_code(request_fn::sda_high, false, false), no_sap, {0x01})));
    CHECK_FALSE(b.request(broadcast(request_code(request_fn::srd_high, true, false),
                                    static_cast<std::uint8_t>(sap::slave_diag), {})));
    CHECK(b.s.stats().not_ours == 3);
    CHECK(b.s.stats().replies == 0);
    b.bring_up();
    CHECK_FALSE(b.request(clear_data_req));
    CHECK(b.s.stats().global_controls == 1);
    CHECK(b.s.clear_data());
}
