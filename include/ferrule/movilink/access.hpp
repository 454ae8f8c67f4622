// Blocking MOVILINK access over any byte_stream: one call, one transaction, driven by
// ferrule::run(). For a non-blocking main loop use master + poll_driver (or cyclic).
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "ferrule/core/byte_stream.hpp"
#include "ferrule/core/driver.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/movilink/master.hpp"

namespace ferrule::movilink {

// PI words as the drive sent them; `count` = pd_words of the PDU type used.
struct process_input {
    std::array<std::uint16_t, max_pd_words> words{};
    std::size_t count = 0;
};

// Writes PO words and returns the PI words (PD-only types: 1PD, 2PD, 3PD, cyclic or not).
template <session_stream S>
result<process_input> exchange(S& stream, master& m, std::uint8_t address,
                               std::span<const std::uint16_t> po) {
    const pdu_type type = pd_type(po.size(), false, false);
    if (po.empty() || po.size() > max_pd_words) return errc::invalid_argument;
    if (auto ec = m.start_exchange(address, type, po)) return ec;
    if (auto ec = run(stream, m)) return ec;
    process_input pi;
    pi.count = pd_words(type);
    for (std::size_t i = 0; i < pi.count; ++i) pi.words[i] = m.reply().pd[i];
    return pi;
}

// Any parameter service on the acyclic PARAM type (0x86): "all inverters support the READ
// parameter service in PDU type PARAM + 0PD acyclical" (SC01 p.36). Returns the data word.
template <session_stream S>
result<std::uint32_t> parameter(S& stream, master& m, std::uint8_t address, service svc,
                                std::uint16_t index, std::uint32_t value = 0,
                                std::uint8_t subindex = 0) {
    const auto req = param_channel::make(svc, index, value, subindex);
    if (auto ec = m.start_parameter(address, pdu_type::param_acyclic, req)) return ec;
    if (auto ec = run(stream, m)) return ec;
    return m.reply().param.data;
}

template <session_stream S>
result<std::uint32_t> read_parameter(S& stream, master& m, std::uint8_t address,
                                     std::uint16_t index, std::uint8_t subindex = 0) {
    if (!expects_response(address)) return errc::no_response_expected;
    return parameter(stream, m, address, service::read, index, 0, subindex);
}

// `persistent` selects the EEPROM write (0x2): SC01 p.31 warns against it for frequent
// writes, so the default is the volatile (RAM) write.
template <session_stream S>
ferrule::error write_parameter(S& stream, master& m, std::uint8_t address, std::uint16_t index,
                               std::uint32_t value, bool persistent = false,
                               std::uint8_t subindex = 0) {
    const auto r =
        parameter(stream, m, address, persistent ? service::write : service::write_volatile, index,
                  value, subindex);
    if (!r && r.error() == errc::no_response_expected) return {};
    return r.error();
}

} // namespace ferrule::movilink
