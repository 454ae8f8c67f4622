// Blocking DP-V0 master access over any byte_stream: one call, one transaction, driven by
// ferrule::run(). For a non-blocking main loop use master + poll_driver.
//
// bring_up() is the master's start-up of one slave (§B.6, pyprofibus dp_master): FDL_Status,
// Slave_Diag, Set_Prm, Chk_Cfg, then Slave_Diag until the slave is ready for Data_Exchange.
// Then data_exchange() cyclically; when it reports data_high() (DH, §B.3) the slave has new
// diagnosis: fetch it with read_slave_diag().
#pragma once

#include <cstdint>
#include <span>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/core/error.hpp"
#include "ferrule/profibus/error.hpp"
#include "ferrule/profibus/master.hpp"
#include "ferrule/profibus/services.hpp"

namespace ferrule::profibus {

namespace detail {
template <session_stream S>
ferrule::error transact(S& stream, master& m, ferrule::error started) {
    if (started) return started;
    return run(stream, m);
}
} // namespace detail

// FDL_Status (§B.5): is a station at `da`?
template <session_stream S>
ferrule::error fdl_status(S& stream, master& m, std::uint8_t da) {
    return detail::transact(stream, m, m.start_fdl_status(da));
}

// Slave_Diag (SAP 60): the diagnosis into `out`; out.ext spans the master's buffer, valid
// until its next start.
template <session_stream S>
ferrule::error read_slave_diag(S& stream, master& m, std::uint8_t da, slave_diag& out) {
    if (auto ec = detail::transact(stream, m, m.start_slave_diag(da))) return ec;
    out = m.diag();
    return {};
}

// Set_Prm (SAP 61).
template <session_stream S>
ferrule::error set_prm(S& stream, master& m, std::uint8_t da, const prm_data& p) {
    return detail::transact(stream, m, m.start_set_prm(da, p));
}

// Chk_Cfg (SAP 62): the configuration identifiers the master expects.
template <session_stream S>
ferrule::error chk_cfg(S& stream, master& m, std::uint8_t da, std::span<const std::uint8_t> cfg) {
    return detail::transact(stream, m, m.start_chk_cfg(da, cfg));
}

// Get_Cfg (SAP 59): the slave's configuration identifiers, in m.reply().
template <session_stream S>
ferrule::error get_cfg(S& stream, master& m, std::uint8_t da) {
    return detail::transact(stream, m, m.start_get_cfg(da));
}

// Data_Exchange (default SAP): sends `outputs`, receives exactly inputs_out.size() input
// bytes (else errc::malformed). m.data_high() tells whether the slave answered DH.
template <session_stream S>
ferrule::error data_exchange(S& stream, master& m, std::uint8_t da,
                             std::span<const std::uint8_t> outputs,
                             std::span<std::uint8_t> inputs_out) {
    if (auto ec = detail::transact(stream, m, m.start_data_exchange(da, outputs))) return ec;
    const auto in = m.reply();
    if (in.size() != inputs_out.size()) return errc::malformed;
    for (std::size_t i = 0; i < in.size(); ++i) inputs_out[i] = in[i];
    return {};
}

// Global_Control (SAP 58) to DA 127 (every slave) or one slave: no reply, so {} once the
// line has been idle for TSYN.
template <session_stream S>
ferrule::error send_global_control(S& stream, master& m, const global_control& gc,
                                   std::uint8_t da = broadcast_address) {
    const ferrule::error ec = detail::transact(stream, m, m.start_global_control(gc, da));
    if (ec == errc::no_response_expected) return {};
    return ec;
}

// What a Slave_Diag read during start-up says of slave and master `master`: empty when the
// slave is ready for Data_Exchange; device_errc::master_lock when Diag.Master_Add names
// another master (the slave acknowledged Set_Prm and Chk_Cfg but did not take them); else
// prm_fault or cfg_fault when the diagnosis says so, or not_ready.
inline ferrule::error start_up_verdict(const slave_diag& d, std::uint8_t master) noexcept {
    if (locked_to_other(d, master)) return device_errc::master_lock;
    if (d.ready()) return {};
    if (d.status1 & diag::prm_fault) return device_errc::prm_fault;
    if (d.status1 & diag::cfg_fault) return device_errc::cfg_fault;
    return device_errc::not_ready;
}

// The master's start-up of slave `da` (§B.6): FDL_Status → Slave_Diag → Set_Prm → Chk_Cfg →
// Slave_Diag until ready() (at most diag_polls times). The slave's FCB starts over
// (reset_fcb). Returns the first error, device_errc::master_lock at once, else the verdict
// of the last diagnosis (start_up_verdict).
template <session_stream S>
ferrule::error bring_up(S& stream, master& m, std::uint8_t da, const prm_data& p,
                        std::span<const std::uint8_t> cfg, unsigned diag_polls = 10) {
    m.reset_fcb(da);
    slave_diag d;
    if (auto ec = fdl_status(stream, m, da)) return ec;
    if (auto ec = read_slave_diag(stream, m, da, d)) return ec;
    if (auto ec = set_prm(stream, m, da, p)) return ec;
    if (auto ec = chk_cfg(stream, m, da, cfg)) return ec;
    ferrule::error verdict = start_up_verdict(d, m.config().address);
    for (unsigned i = 0; i < diag_polls; ++i) {
        if (auto ec = read_slave_diag(stream, m, da, d)) return ec;
        verdict = start_up_verdict(d, m.config().address);
        if (!verdict || verdict == device_errc::master_lock) return verdict;
    }
    return verdict;
}

} // namespace ferrule::profibus
