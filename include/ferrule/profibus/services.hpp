// DP-V0 service data units, shared by the slave and the master sessions
// (protocols/modbus_profibus.md §B.5):
//
//   Slave_Diag reply   Station_Status_1/2/3, Diag.Master_Add, Ident_Number (hi, lo),
//                      extended diagnosis blocks…
//   Set_Prm request    Station_Status, WD_Fact_1, WD_Fact_2, min_TSDR, Ident (hi, lo),
//                      Group_Ident, User_Prm_Data…
//   Chk_Cfg / Get_Cfg  identifier bytes (compact or special format)
//   Global_Control     Control_Command, Group_Select
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/profibus/constants.hpp"

namespace ferrule::profibus {

struct slave_diag {
    std::uint8_t status1 = 0;
    std::uint8_t status2 = diag::always_one;
    std::uint8_t status3 = 0;
    std::uint8_t master = diag::no_master;
    std::uint16_t ident = 0;
    std::span<const std::uint8_t> ext{}; // extended diagnosis blocks

    // Ready for Data_Exchange: none of Non_Existent, Not_Ready, Cfg_Fault, Prm_Fault, and no
    // Prm_Req (pyprofibus isReadyDataEx, §B.5).
    constexpr bool ready() const noexcept {
        return (status1 & (diag::station_non_existent | diag::station_not_ready | diag::cfg_fault |
                           diag::prm_fault)) == 0 &&
               (status2 & diag::prm_req) == 0;
    }
};

// Diag.Master_Add names a master other than `master`: the slave is locked to that one, and
// `master` sets Master_Lock in its own view of Station_Status_1 (§B.5).
constexpr bool locked_to_other(const slave_diag& d, std::uint8_t master) noexcept {
    return d.master != diag::no_master && d.master != master;
}

// At least the six standard bytes; the rest is extended diagnosis.
inline result<slave_diag> parse_slave_diag(std::span<const std::uint8_t> du) noexcept {
    if (du.size() < diag::standard_size) return errc::malformed;
    slave_diag d;
    d.status1 = du[0];
    d.status2 = du[1];
    d.status3 = du[2];
    d.master = du[3];
    d.ident = static_cast<std::uint16_t>(du[4] << 8 | du[5]);
    d.ext = du.subspan(diag::standard_size);
    return d;
}

inline result<std::size_t> encode_slave_diag(const slave_diag& d,
                                             std::span<std::uint8_t> out) noexcept {
    const std::size_t n = diag::standard_size + d.ext.size();
    if (n > max_data - 2) return errc::invalid_argument; // DSAP and SSAP travel with it
    if (out.size() < n) return errc::buffer_too_small;
    out[0] = d.status1;
    out[1] = d.status2;
    out[2] = d.status3;
    out[3] = d.master;
    out[4] = static_cast<std::uint8_t>(d.ident >> 8);
    out[5] = static_cast<std::uint8_t>(d.ident);
    for (std::size_t i = 0; i < d.ext.size(); ++i) out[diag::standard_size + i] = d.ext[i];
    return n;
}

// What Set_Prm's Lock_Req (bit 7) and Unlock_Req (bit 6) ask of the slave (IEC 61158 /
// EN 50170 table, as ABB FPBA-01 "SAP 61 (Set_Prm)" and Festo CP FB13-E "Octet 1: Station
// status" print it): 0/0 only min_TSDR and the slave-specific parameters (User_Prm_Data) may
// be overwritten; 1/0 the slave is locked to this master and takes all parameters; 0/1 and
// 1/1 the slave is released (unlocked) for other masters.
enum class prm_lock : std::uint8_t { overwrite, lock, unlock };

struct prm_data {
    // prm::lock_req, unlock_req, sync_req, freeze_req, wd_on. Lock_Req by default: without
    // it a standard slave takes no parameters but min_TSDR and User_Prm_Data.
    std::uint8_t station_status = prm::lock_req;
    std::uint8_t wd_fact1 = 1;
    std::uint8_t wd_fact2 = 1;
    std::uint8_t min_tsdr = 0; // bit times; 0 = keep the slave's
    std::uint16_t ident = 0;
    std::uint8_t group = 0;
    std::span<const std::uint8_t> user{}; // User_Prm_Data

    constexpr bool watchdog_on() const noexcept { return (station_status & prm::wd_on) != 0; }
    constexpr prm_lock lock_request() const noexcept {
        if (station_status & prm::unlock_req) return prm_lock::unlock;
        return (station_status & prm::lock_req) ? prm_lock::lock : prm_lock::overwrite;
    }
    // WD_Fact_1 × WD_Fact_2 × 10 ms (§B.5; DP-V0: the 1 ms base of DP-V1 is not used).
    constexpr duration watchdog() const noexcept {
        return std::chrono::milliseconds(10) * (unsigned{wd_fact1} * wd_fact2);
    }
    // The factors for a watchdog of at least `ms` milliseconds (at most 255 × 255 × 10 ms):
    // an exact split of the 10 ms units when there is one, the factors near its square root.
    constexpr void set_watchdog_ms(unsigned ms) noexcept {
        const unsigned units = std::max(1u, (ms + 9) / 10);
        unsigned root = 1;
        while (root * root < units) ++root;
        for (unsigned f1 = root; f1 <= 255; ++f1)
            if (units % f1 == 0 && units / f1 <= 255) {
                wd_fact1 = static_cast<std::uint8_t>(f1);
                wd_fact2 = static_cast<std::uint8_t>(units / f1);
                return;
            }
        wd_fact1 = static_cast<std::uint8_t>(root);
        wd_fact2 = static_cast<std::uint8_t>((units + root - 1) / root);
    }
};

inline result<prm_data> parse_prm(std::span<const std::uint8_t> du) noexcept {
    if (du.size() < prm::standard_size) return errc::malformed;
    prm_data p;
    p.station_status = du[0];
    p.wd_fact1 = du[1];
    p.wd_fact2 = du[2];
    p.min_tsdr = du[3];
    p.ident = static_cast<std::uint16_t>(du[4] << 8 | du[5]);
    p.group = du[6];
    p.user = du.subspan(prm::standard_size);
    return p;
}

inline result<std::size_t> encode_prm(const prm_data& p, std::span<std::uint8_t> out) noexcept {
    const std::size_t n = prm::standard_size + p.user.size();
    if (n > max_data - 2) return errc::invalid_argument;
    if (out.size() < n) return errc::buffer_too_small;
    out[0] = p.station_status;
    out[1] = p.wd_fact1;
    out[2] = p.wd_fact2;
    out[3] = p.min_tsdr;
    out[4] = static_cast<std::uint8_t>(p.ident >> 8);
    out[5] = static_cast<std::uint8_t>(p.ident);
    out[6] = p.group;
    for (std::size_t i = 0; i < p.user.size(); ++i) out[prm::standard_size + i] = p.user[i];
    return n;
}

// Input and output bytes that configuration identifiers describe (§B.5):
//   compact:  bits 3…0 length − 1, bits 5…4 01 in / 10 out / 11 in+out, bit 6 words,
//             bit 7 consistency; 0x00 is an empty slot
//   special:  bits 5…4 = 00, bits 7…6 00 none / 01 in / 10 out / 11 in+out (one length byte
//             each, out first), bits 3…0 manufacturer bytes that follow; length byte: bits
//             5…0 length − 1, bit 6 words, bit 7 consistency
struct io_sizes {
    std::size_t inputs = 0;
    std::size_t outputs = 0;
};

inline result<io_sizes> cfg_io_sizes(std::span<const std::uint8_t> cfg) noexcept {
    io_sizes s;
    std::size_t i = 0;
    const auto length_of = [](std::uint8_t b, unsigned mask) {
        const std::size_t units = (b & mask) + 1u;
        return (b & 0x40) ? 2 * units : units;
    };
    while (i < cfg.size()) {
        const std::uint8_t id = cfg[i++];
        const unsigned dir = (id >> 4) & 0x3;
        if (dir != 0) { // compact
            const std::size_t n = length_of(id, 0x0F);
            if (dir & 0x1) s.inputs += n;
            if (dir & 0x2) s.outputs += n;
            continue;
        }
        if (id == 0x00) continue; // empty slot
        const unsigned special = id >> 6;
        const std::size_t vendor = id & 0x0F;
        // The output length byte comes before the input length byte.
        if (special & 0x2) {
            if (i >= cfg.size()) return errc::malformed;
            s.outputs += length_of(cfg[i++], 0x3F);
        }
        if (special & 0x1) {
            if (i >= cfg.size()) return errc::malformed;
            s.inputs += length_of(cfg[i++], 0x3F);
        }
        if (cfg.size() - i < vendor) return errc::malformed;
        i += vendor;
    }
    return s;
}

struct global_control {
    std::uint8_t command = 0; // control::clear_data, freeze, unfreeze, sync, unsync
    std::uint8_t group = 0;   // 0: every slave; else the groups whose bit is set
};

} // namespace ferrule::profibus
