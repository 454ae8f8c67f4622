#include "profibus_text.hpp"

#include <fmt/core.h>

#include <algorithm>

#include "ferrule/profibus/constants.hpp"

namespace ferrule::cli::profibus_text {

namespace {
namespace pb = ferrule::profibus;

constexpr flag status_1[] = {{pb::diag::station_non_existent, "Station_Non_Existent"},
                             {pb::diag::station_not_ready, "Station_Not_Ready"},
                             {pb::diag::cfg_fault, "Cfg_Fault"},
                             {pb::diag::ext_diag, "Ext_Diag"},
                             {pb::diag::not_supported, "Not_Supported"},
                             {pb::diag::invalid_slave_response, "Invalid_Slave_Response"},
                             {pb::diag::prm_fault, "Prm_Fault"},
                             {pb::diag::master_lock, "Master_Lock"}};
constexpr flag status_2[] = {
    {pb::diag::prm_req, "Prm_Req"},         {pb::diag::stat_diag, "Stat_Diag"},
    {pb::diag::always_one, "always 1"},     {pb::diag::wd_on, "WD_On"},
    {pb::diag::freeze_mode, "Freeze_Mode"}, {pb::diag::sync_mode, "Sync_Mode"},
    {pb::diag::deactivated, "Deactivated"}};
constexpr flag status_3[] = {{pb::diag::ext_diag_overflow, "Ext_Diag_Overflow"}};
constexpr flag prm[] = {{pb::prm::lock_req, "Lock_Req"},
                        {pb::prm::unlock_req, "Unlock_Req"},
                        {pb::prm::sync_req, "Sync_Req"},
                        {pb::prm::freeze_req, "Freeze_Req"},
                        {pb::prm::wd_on, "WD_On"}};
constexpr flag control[] = {{pb::control::clear_data, "Clear_Data"},
                            {pb::control::unfreeze, "Unfreeze"},
                            {pb::control::freeze, "Freeze"},
                            {pb::control::unsync, "Unsync"},
                            {pb::control::sync, "Sync"}};
} // namespace

const std::span<const flag> station_status_1{status_1};
const std::span<const flag> station_status_2{status_2};
const std::span<const flag> station_status_3{status_3};
const std::span<const flag> prm_status{prm};
const std::span<const flag> control_command{control};

std::vector<std::string> bit_names(std::uint8_t b, std::span<const flag> flags) {
    std::vector<std::string> out;
    for (const flag& f : flags)
        if (b & f.bit) out.push_back(f.name);
    for (unsigned i = 0; i < 8; ++i) {
        const auto bit = static_cast<std::uint8_t>(1u << i);
        const bool named =
            std::any_of(flags.begin(), flags.end(), [bit](const flag& f) { return f.bit == bit; });
        if ((b & bit) && !named) out.push_back(fmt::format("bit {}", i));
    }
    return out;
}

std::string join(const std::vector<std::string>& names) {
    std::string s;
    for (const auto& x : names) s += (s.empty() ? "" : ", ") + x;
    return s.empty() ? "-" : s;
}

} // namespace ferrule::cli::profibus_text
