// The gateway's GSD file (examples/gateway/ferrule_gateway.gsd, protocols/modbus_profibus.md
// §B.8): every module's bytes are configuration identifiers whose sizes are the ones its name
// gives, and a master configured from the file brings the gateway up with each module and gets
// the paper's command through (gateway::sim::rig, virtual time).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include "ferrule/gateway/sim/rig.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/profibus/access.hpp"
#include "ferrule/profibus/services.hpp"

using namespace ferrule;
namespace pb = ferrule::profibus;
namespace gw = ferrule::gateway;
using octets = std::vector<std::uint8_t>;

namespace {

struct module {
    std::string name;
    octets cfg;
};

struct gsd {
    std::vector<module> modules;
    std::vector<std::pair<std::string, std::string>> keys;

    std::optional<long> number(const std::string& key) const {
        for (const auto& [k, v] : keys)
            if (k == key) return std::strtol(v.c_str(), nullptr, 0);
        return std::nullopt;
    }
};

// `Key = value` lines and `Module = "name" 0x.., 0x..` lines; comments start with ';'.
gsd read_gsd(const std::string& path) {
    std::ifstream in(path);
    REQUIRE(in.good());
    gsd g;
    const std::regex module_line(R"re(^Module\s*=\s*"([^"]*)"\s*(.*)$)re");
    const std::regex key_line(R"(^([A-Za-z0-9_.]+)\s*=\s*(\S+))");
    const std::regex id(R"(0x([0-9A-Fa-f]{2}))");
    std::string line;
    while (std::getline(in, line)) {
        line = line.substr(0, line.find(';'));
        std::smatch m;
        if (std::regex_search(line, m, module_line)) {
            module mod{m[1], {}};
            const std::string bytes = m[2];
            for (auto it = std::sregex_iterator(bytes.begin(), bytes.end(), id);
                 it != std::sregex_iterator(); ++it)
                mod.cfg.push_back(static_cast<std::uint8_t>(std::stoul((*it)[1], nullptr, 16)));
            g.modules.push_back(mod);
        } else if (std::regex_search(line, m, key_line)) {
            g.keys.emplace_back(m[1], m[2]);
        }
    }
    return g;
}

const std::string gsd_path =
    std::string(FERRULE_TESTS_DIR) + "/../examples/gateway/ferrule_gateway.gsd";

// "Transparent 16 bytes + status word": 16 bytes out, 16 + 2 in.
pb::io_sizes sizes_named(const std::string& name) {
    std::smatch m;
    const std::regex pattern(R"(^Transparent (\d+) bytes( \+ status word)?$)");
    REQUIRE(std::regex_match(name, m, pattern));
    const std::size_t n = std::stoul(m[1]);
    return {m[2].matched ? n + 2 : n, n};
}

} // namespace

TEST_CASE("gateway GSD: identification and limits", "[profibus][gsd]") {
    const gsd g = read_gsd(gsd_path);
    CHECK(g.number("Ident_Number") == 0x0815); // ferrule-sim profibus-gateway --ident
    CHECK(g.number("Protocol_Ident") == 0);
    CHECK(g.number("Station_Type") == 0);
    CHECK(g.number("Modular_Station") == 1);
    CHECK(g.number("MaxTsdr_19.2") == pb::max_tsdr_bits(19'200));
    CHECK(g.number("MaxTsdr_187.5") == pb::max_tsdr_bits(187'500));
    // The six standard bytes and the gateway's one device-related block.
    CHECK(g.number("Max_Diag_Data_Len") ==
          static_cast<long>(pb::diag::standard_size + gw::diag_block_size));
    CHECK(g.number("User_Prm_Data_Len") == 0);
    REQUIRE(g.modules.size() == 7);
    // The first module is the simulator's default --cfg 24 14.
    CHECK(g.modules.front().cfg == octets{0x24, 0x14});
}

TEST_CASE("gateway GSD: module bytes are identifiers of the sizes their names say",
          "[profibus][gsd]") {
    const gsd g = read_gsd(gsd_path);
    REQUIRE_FALSE(g.modules.empty());
    for (const module& m : g.modules) {
        INFO(m.name);
        const auto s = pb::cfg_io_sizes(m.cfg);
        REQUIRE(s);
        const pb::io_sizes want = sizes_named(m.name);
        CHECK(s->inputs == want.inputs);
        CHECK(s->outputs == want.outputs);
        CHECK(static_cast<long>(s->inputs) <= *g.number("Max_Input_Len"));
        CHECK(static_cast<long>(s->outputs) <= *g.number("Max_Output_Len"));
    }
}

TEST_CASE("gateway GSD: each module brings the gateway up and carries the paper's command",
          "[profibus][gsd][gateway]") {
    const gsd g = read_gsd(gsd_path);
    const auto ident = static_cast<std::uint16_t>(*g.number("Ident_Number"));
    for (const module& m : g.modules) {
        INFO(m.name);
        const bool status_word = m.name.find("status word") != std::string::npos;
        gw::config c;
        c.dp.address = 8;
        c.dp.ident = ident;
        c.dp.cfg = m.cfg;
        c.modbus.inter_frame_gap = modbus::t35(c.modbus.format);
        c.status_word = status_word;
        gw::sim::rig<1> rig(c);
        modbus::server_config drive;
        drive.units = {1};
        REQUIRE(rig.drives().add(drive));
        mock_serial dp_line(pb::format(19'200), &rig);
        pb::master master;

        pb::prm_data p;
        p.ident = ident;
        REQUIRE_FALSE(pb::bring_up(dp_line, master, 8, p, m.cfg));
        const auto s = *pb::cfg_io_sizes(m.cfg);
        octets out(s.outputs, 0);
        const octets start{0x06, 0xC8, 0x00, 0x00, 0x25};
        std::copy(start.begin(), start.end(), out.begin());
        octets in(s.inputs, 0);
        const std::size_t reply_at = status_word ? 2 : 0;
        const auto replied = [&] {
            return std::equal(start.begin(), start.end(), in.begin() + static_cast<long>(reply_at));
        };
        for (int cycle = 0; cycle < 40 && !replied(); ++cycle)
            REQUIRE_FALSE(pb::data_exchange(dp_line, master, 8, out, in));
        CHECK(replied());
        if (status_word) CHECK((in[0] << 8 | in[1]) == (gw::status::data_valid | 0x1F00));
    }
}
