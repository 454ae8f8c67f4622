// DP-V0 service data units: Slave_Diag, Set_Prm and configuration identifiers, with the bytes
// of protocols/modbus_profibus.md §B.5 and §B.9.
#include <catch2/catch.hpp>

#include <array>
#include <vector>

#include "ferrule/profibus/services.hpp"

using namespace ferrule::profibus;
using ferrule::errc;
using bytes = std::vector<std::uint8_t>;

TEST_CASE("profibus Slave_Diag: the real ET200S in WPRM and the round trip", "[profibus]") {
    const bytes et200s{0x02, 0x05, 0x00, 0xFF, 0x80, 0xE0};
    const auto d = parse_slave_diag(et200s);
    REQUIRE(d);
    CHECK(d->status1 == diag::station_not_ready);
    CHECK(d->status2 == (diag::prm_req | diag::always_one));
    CHECK(d->master == diag::no_master);
    CHECK(d->ident == 0x80E0);
    CHECK(d->ext.empty());
    CHECK_FALSE(d->ready());
    std::array<std::uint8_t, 16> out{};
    REQUIRE(*encode_slave_diag(*d, out) == 6u);
    CHECK(bytes(out.begin(), out.begin() + 6) == et200s);

    slave_diag ready;
    ready.master = 2;
    ready.ident = 0x0815;
    CHECK(ready.ready());
    const bytes ext{0x03, 0x01, 0x02};
    ready.ext = ext;
    REQUIRE(*encode_slave_diag(ready, out) == 9u);
    CHECK(bytes(out.begin(), out.begin() + 9) ==
          bytes{0x00, 0x04, 0x00, 0x02, 0x08, 0x15, 0x03, 0x01, 0x02});
    CHECK(parse_slave_diag(bytes{0x02, 0x05, 0x00, 0xFF, 0x80}).error() == errc::malformed);
}

TEST_CASE("profibus Set_Prm: the golden request and a real S7's", "[profibus]") {
    const auto p = parse_prm(bytes{0x88, 0x0A, 0x0A, 0x0B, 0x08, 0x15, 0x00});
    REQUIRE(p);
    CHECK(p->station_status == (prm::lock_req | prm::wd_on));
    CHECK(p->watchdog_on());
    CHECK(p->watchdog() == std::chrono::milliseconds(1000));
    CHECK(p->min_tsdr == 11);
    CHECK(p->ident == 0x0815);
    CHECK(p->user.empty());
    // S7: Lock + Sync + Freeze + WD, 13 × 15 × 10 ms, DP-V1 bytes c0 00 00 as user data
    const bytes s7_prm{0xB8, 0x0D, 0x0F, 0x0B, 0x80, 0xE0, 0x00, 0xC0, 0x00, 0x00};
    const auto s7 = parse_prm(s7_prm); // its user data spans s7_prm
    REQUIRE(s7);
    CHECK(s7->watchdog() == std::chrono::milliseconds(1950));
    CHECK(s7->user.size() == 3);
    std::array<std::uint8_t, 16> out{};
    REQUIRE(*encode_prm(*s7, out) == 10u);
    CHECK(bytes(out.begin(), out.begin() + 10) == s7_prm);
    CHECK(parse_prm(bytes{0x88, 0x0A}).error() == errc::malformed);
}

TEST_CASE("profibus configuration identifiers give the I/O sizes", "[profibus]") {
    CHECK(cfg_io_sizes(bytes{0x11, 0x21})->inputs == 2);
    CHECK(cfg_io_sizes(bytes{0x11, 0x21})->outputs == 2);
    // 0x31: 2 bytes in and out; 0x71: 2 words in and out (4 bytes each); 0xF3 consistent
    CHECK(cfg_io_sizes(bytes{0x31})->inputs == 2);
    CHECK(cfg_io_sizes(bytes{0x71})->outputs == 4);
    CHECK(cfg_io_sizes(bytes{0xF3})->inputs == 8);
    // Empty slot, then a special identifier: in+out, no vendor bytes, 4 words out, 2 bytes in
    const auto s = cfg_io_sizes(bytes{0x00, 0xC0, 0x43, 0x01});
    REQUIRE(s);
    CHECK(s->outputs == 8);
    CHECK(s->inputs == 2);
    // A special identifier whose length byte is missing
    CHECK(cfg_io_sizes(bytes{0x40}).error() == errc::malformed);
    CHECK(cfg_io_sizes(bytes{0x82, 0x01}).error() == errc::malformed);
}

TEST_CASE("profibus Set_Prm sends Lock_Req unless told otherwise", "[profibus][lock]") {
    prm_data p;
    p.ident = 0x0815;
    CHECK(p.lock_request() == prm_lock::lock);
    std::array<std::uint8_t, 16> out{};
    REQUIRE(*encode_prm(p, out) == prm::standard_size);
    CHECK(out[0] == prm::lock_req);
    // Bits 7 / 6 of Station_Status, row by row (FPBA-01 "SAP 61", Festo CP FB13-E).
    const auto lock_of = [](std::uint8_t status) {
        prm_data q;
        q.station_status = status;
        return q.lock_request();
    };
    CHECK(lock_of(0x00) == prm_lock::overwrite);
    CHECK(lock_of(prm::wd_on | prm::sync_req) == prm_lock::overwrite);
    CHECK(lock_of(prm::lock_req) == prm_lock::lock);
    CHECK(lock_of(0xB8) == prm_lock::lock); // an S7: Lock, Sync, Freeze, WD_On
    CHECK(lock_of(prm::unlock_req) == prm_lock::unlock);
    CHECK(lock_of(prm::lock_req | prm::unlock_req) == prm_lock::unlock);
}

TEST_CASE("profibus Set_Prm watchdog factors for a time in milliseconds", "[profibus]") {
    prm_data p;
    p.set_watchdog_ms(1000); // 100 units: 10 × 10
    CHECK(p.wd_fact1 == 10);
    CHECK(p.wd_fact2 == 10);
    p.set_watchdog_ms(1950); // the S7's 13 × 15
    CHECK(p.watchdog() == std::chrono::milliseconds(1950));
    p.set_watchdog_ms(5); // rounded up to one unit
    CHECK(p.watchdog() == std::chrono::milliseconds(10));
    p.set_watchdog_ms(2570); // 257 units, a prime above 255: the next time that splits
    CHECK(p.watchdog() >= std::chrono::milliseconds(2570));
    CHECK(p.watchdog() < std::chrono::milliseconds(2570 + 10 * 17));
    p.set_watchdog_ms(650'250); // the largest: 255 × 255
    CHECK(p.wd_fact1 == 255);
    CHECK(p.wd_fact2 == 255);
}
