// DP master ↔ gateway ↔ simulated Modbus VFD, in virtual time (gateway::sim::rig): the
// paper's worked example byte for byte (seeds/002), commands faster than the drive line
// carries them (every one delivered or counted as overflow), the watchdog and Clear_Data with
// their safe writes, a drive that stops answering, and the slave's reaction time.
#include <catch2/catch.hpp>

#include <vector>

#include "ferrule/gateway/sim/rig.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/profibus/access.hpp"

using namespace std::chrono_literals;
using namespace ferrule;
namespace pb = ferrule::profibus;
namespace mb = ferrule::modbus;
namespace gw = ferrule::gateway;
using octets = std::vector<std::uint8_t>;

namespace {

// 5 octets out, 5 octets in: the paper's 06 C8 00 00 25 and its echo.
const octets cfg5{0x24, 0x14};
constexpr std::uint16_t ident = 0x0F2A;
const std::array<gw::safe_write, 1> stop{{{1, mb::sim::vfd_register::control_word, 0x0000}}};

gw::config transparent(std::uint32_t dp_baud, std::uint32_t drive_baud) {
    gw::config c;
    c.dp.baud = dp_baud;
    c.dp.address = 8;
    c.dp.ident = ident;
    c.dp.cfg = cfg5;
    c.modbus.format = {drive_baud, 8, parity::even, 1};
    c.modbus.inter_frame_gap = mb::t35(c.modbus.format);
    c.modbus.response_timeout = 100ms;
    c.modbus.retries = 1;
    c.drive = 1;
    c.safe_writes = stop;
    return c;
}

pb::prm_data prm(std::uint8_t wd_fact = 10) {
    pb::prm_data p;
    p.station_status = pb::prm::lock_req | pb::prm::wd_on;
    p.wd_fact1 = wd_fact;
    p.wd_fact2 = 10; // wd_fact × 100 ms
    p.ident = ident;
    return p;
}

// The DP master's side: a mock_serial at the DP baud rate whose peer is the rig.
struct setup {
    gw::sim::rig<2> rig;
    mock_serial dp_line;
    pb::master master;

    setup(std::uint32_t dp_baud, std::uint32_t drive_baud)
        : rig(transparent(dp_baud, drive_baud)), dp_line(pb::format(dp_baud), &rig),
          master(master_config(dp_baud)) {
        mb::server_config drive;
        drive.units = {1};
        drive.format = rig.core().modbus().config().format;
        REQUIRE(rig.drives().add(drive));
    }
    static pb::master_config master_config(std::uint32_t baud) {
        pb::master_config c;
        c.format = pb::format(baud);
        c.address = 2;
        return c;
    }
    std::error_code exchange(const octets& out, octets& in) {
        in.assign(5, 0);
        return pb::data_exchange(dp_line, master, 8, out, in);
    }
    // Bytes the gateway put on the drive line.
    octets drive_requests() const {
        octets out;
        for (const wire_byte& b : const_cast<setup*>(this)->rig.drive_line().wire())
            if (b.origin == wire_byte::from::session) out.push_back(b.value);
        return out;
    }
};

} // namespace

TEST_CASE("gateway: the paper's start command, byte for byte", "[gateway]") {
    setup s(19'200, 9'600);
    REQUIRE_FALSE(pb::bring_up(s.dp_line, s.master, 8, prm(), cfg5));
    const octets start{0x06, 0xC8, 0x00, 0x00, 0x25};
    octets in;
    REQUIRE_FALSE(s.exchange(start, in));
    // The gateway adds the drive's address and the CRC: 01 06 C8 00 00 25 76 71.
    for (int cycle = 0; cycle < 40 && in != start; ++cycle) REQUIRE_FALSE(s.exchange(start, in));
    CHECK(s.drive_requests() == octets{0x01, 0x06, 0xC8, 0x00, 0x00, 0x25, 0x76, 0x71});
    // The drive's echo comes back in the DP inputs.
    CHECK(in == start);
    CHECK(s.rig.drives()[0].drive().control_word() == 0x0025);
    CHECK(s.rig.core().stats().commands == 1);
    CHECK(s.rig.core().stats().delivered == 1);
    CHECK(s.rig.core().stats().replies == 1);
    // The same outputs again are the same command: nothing more goes to the drive.
    for (int cycle = 0; cycle < 10; ++cycle) REQUIRE_FALSE(s.exchange(start, in));
    CHECK(s.drive_requests().size() == 8);
}

TEST_CASE("gateway: commands faster than the drive line are delivered or counted as overflow",
          "[gateway]") {
    const auto dp_baud = GENERATE(std::uint32_t{19'200}, std::uint32_t{187'500});
    const auto drive_baud =
        GENERATE(std::uint32_t{2'400}, std::uint32_t{9'600}, std::uint32_t{19'200});
    CAPTURE(dp_baud, drive_baud);
    setup s(dp_baud, drive_baud);
    REQUIRE_FALSE(pb::bring_up(s.dp_line, s.master, 8, prm(), cfg5));
    constexpr int sent = 300;
    octets in;
    unsigned dh = 0;
    for (int i = 1; i <= sent; ++i) {
        // A new setpoint every DP cycle: FC 6 to 0xC801.
        const octets cmd{0x06, 0xC8, 0x01, static_cast<std::uint8_t>(i >> 8),
                         static_cast<std::uint8_t>(i)};
        REQUIRE_FALSE(s.exchange(cmd, in));
        if (s.master.data_high()) ++dh;
    }
    // Let the drive line finish what waits.
    s.rig.run_until(s.dp_line.now() + 2s);
    const gw::stats& st = s.rig.core().stats();
    CHECK(st.commands + st.overflowed == sent);
    CHECK(st.delivered + st.failed + st.discarded + s.rig.core().waiting_commands() == st.commands);
    CHECK(st.failed == 0);
    CHECK(s.rig.core().waiting_commands() == 0);
    // Each delivered command reached the drive exactly once.
    CHECK(s.rig.drives()[0].session.stats().requests == st.delivered);
    CHECK(s.rig.drives()[0].session.stats().replies == st.delivered);
    // The last command the drive got is the last one delivered: none was overwritten.
    // A DP cycle at 19.2 kbit/s (about 14 ms) is slower than an FC 6 exchange at 19200
    // baud (about 11 ms): no overflow then; every other pair outruns the drive.
    const bool dp_faster = !(dp_baud == 19'200 && drive_baud == 19'200);
    if (!dp_faster) {
        CHECK(st.overflowed == 0);
        CHECK(dh == 0);
        return;
    }
    CHECK(st.overflowed > 0);
    // The overflow was reported: DH, Ext_Diag and the count in the extended diagnosis.
    CHECK(dh > 0);
    pb::slave_diag d;
    REQUIRE_FALSE(pb::read_slave_diag(s.dp_line, s.master, 8, d));
    REQUIRE(d.ext.size() == gw::diag_block_size);
    CHECK((d.ext[1] & gw::diag_flags::command_overflow) != 0);
    CHECK((d.ext[2] << 8 | d.ext[3]) == static_cast<int>(st.overflowed + st.reply_overflows));
    CHECK((d.status1 & pb::diag::ext_diag) != 0);
    // Read once, the latch opens; the count stays.
    REQUIRE_FALSE(pb::read_slave_diag(s.dp_line, s.master, 8, d));
    CHECK((d.ext[1] & gw::diag_flags::command_overflow) == 0);
    CHECK((d.ext[2] << 8 | d.ext[3]) == static_cast<int>(st.overflowed + st.reply_overflows));
}

TEST_CASE("gateway: DP watchdog expiry stops the drive with the safe write", "[gateway]") {
    setup s(19'200, 19'200);
    REQUIRE_FALSE(pb::bring_up(s.dp_line, s.master, 8, prm(2), cfg5)); // watchdog 200 ms
    const octets start{0x06, 0xC8, 0x00, 0x00, 0x25};
    octets in;
    for (int cycle = 0; cycle < 40 && in != start; ++cycle) REQUIRE_FALSE(s.exchange(start, in));
    REQUIRE(s.rig.drives()[0].drive().control_word() == 0x0025);
    // The master falls silent.
    s.dp_line.advance(300ms);
    CHECK(s.rig.core().dp().state() == pb::slave_state::wait_prm);
    CHECK(s.rig.core().dp().stats().watchdog_expiries == 1);
    CHECK(s.rig.core().stats().dp_losses == 1);
    CHECK(s.rig.core().stats().safe_writes == 1);
    CHECK(s.rig.drives()[0].drive().control_word() == 0x0000);
}

TEST_CASE("gateway: Set_Prm without Lock_Req, or from another master, does not drop DP",
          "[gateway][lock]") {
    setup s(19'200, 19'200);
    REQUIRE_FALSE(pb::bring_up(s.dp_line, s.master, 8, prm(), cfg5));
    const octets start{0x06, 0xC8, 0x00, 0x00, 0x25};
    octets in;
    for (int cycle = 0; cycle < 40 && in != start; ++cycle) REQUIRE_FALSE(s.exchange(start, in));
    REQUIRE(s.rig.drives()[0].drive().control_word() == 0x0025);

    // The locking master's Set_Prm without Lock_Req: only min_TSDR and User_Prm_Data.
    pb::prm_data overwrite = prm(1);
    overwrite.station_status = pb::prm::wd_on;
    REQUIRE_FALSE(pb::set_prm(s.dp_line, s.master, 8, overwrite));
    CHECK(s.rig.core().dp().state() == pb::slave_state::data_exchange);
    CHECK(s.rig.core().dp().watchdog() == 1000ms);

    // Master 3 on the same line: acknowledged, not taken, and told by Master_Add.
    pb::master_config c3 = setup::master_config(19'200);
    c3.address = 3;
    pb::master other(c3);
    CHECK(pb::bring_up(s.dp_line, other, 8, prm(), cfg5) == pb::device_errc::master_lock);
    CHECK(s.rig.core().dp().master_address() == 2);

    REQUIRE_FALSE(s.exchange(start, in));
    CHECK(in == start);
    CHECK(s.rig.core().stats().dp_losses == 0);
    CHECK(s.rig.core().stats().safe_writes == 0);
    CHECK(s.rig.drives()[0].drive().control_word() == 0x0025);
}

TEST_CASE("gateway: Clear_Data discards waiting commands and sends the safe write", "[gateway]") {
    setup s(187'500, 2'400);
    REQUIRE_FALSE(pb::bring_up(s.dp_line, s.master, 8, prm(), cfg5));
    octets in;
    for (int i = 1; i <= 4; ++i) {
        const octets cmd{0x06, 0xC8, 0x01, 0x00, static_cast<std::uint8_t>(i)};
        REQUIRE_FALSE(s.exchange(cmd, in));
    }
    pb::global_control clear;
    clear.command = pb::control::clear_data;
    REQUIRE_FALSE(pb::send_global_control(s.dp_line, s.master, clear));
    s.rig.run_until(s.dp_line.now() + 1s);
    const gw::stats& st = s.rig.core().stats();
    CHECK(st.dp_losses == 1);
    CHECK(st.discarded > 0);
    CHECK(st.delivered + st.failed + st.discarded == st.commands);
    CHECK(st.safe_writes == 1);
    CHECK(s.rig.drives()[0].drive().control_word() == 0x0000);
    CHECK(s.rig.core().dp().outputs()[0] == 0);
}

TEST_CASE("gateway: a drive that stops answering is reported missing", "[gateway]") {
    setup s(19'200, 19'200);
    REQUIRE_FALSE(pb::bring_up(s.dp_line, s.master, 8, prm(), cfg5));
    const octets start{0x06, 0xC8, 0x00, 0x00, 0x25};
    octets in;
    for (int cycle = 0; cycle < 40 && in != start; ++cycle) REQUIRE_FALSE(s.exchange(start, in));
    REQUIRE(in == start);
    CHECK(s.rig.core().online(1));
    s.rig.drives().drop_replies(100);
    const octets read{0x03, 0xC8, 0x02, 0x00, 0x01};
    for (int cycle = 0; cycle < 200 && s.rig.core().stats().failed == 0; ++cycle)
        REQUIRE_FALSE(s.exchange(read, in));
    CHECK(s.rig.core().stats().failed == 1);
    CHECK_FALSE(s.rig.core().online(1));
    REQUIRE_FALSE(s.exchange(read, in));
    // Inputs cleared (drive_loss = clear), status word "one drive missing: unit 1".
    CHECK(in == octets(5, 0));
    CHECK(s.rig.core().status_word() == (gw::status::node_missing << 8 | 1));
    pb::slave_diag d;
    REQUIRE_FALSE(pb::read_slave_diag(s.dp_line, s.master, 8, d));
    REQUIRE(d.ext.size() == gw::diag_block_size);
    CHECK((d.ext[1] & gw::diag_flags::drive_missing) != 0);
    CHECK(d.ext[7] == 0x00); // live list: unit 1 not answering
}

TEST_CASE("gateway: the DP slave answers within max TSDR", "[gateway]") {
    const auto dp_baud = GENERATE(std::uint32_t{19'200}, std::uint32_t{187'500});
    setup s(dp_baud, 9'600);
    REQUIRE_FALSE(pb::bring_up(s.dp_line, s.master, 8, prm(), cfg5));
    octets in;
    const octets cmd{0x06, 0xC8, 0x01, 0x00, 0x10};
    for (int i = 0; i < 20; ++i) REQUIRE_FALSE(s.exchange(cmd, in));
    // Every gap on the DP line from the master's last byte to the slave's first.
    const auto wire = s.dp_line.wire();
    duration longest{};
    std::size_t replies = 0;
    for (std::size_t i = 1; i < wire.size(); ++i) {
        if (wire[i - 1].origin != wire_byte::from::session ||
            wire[i].origin != wire_byte::from::peer)
            continue;
        longest = std::max(longest, wire[i].start - wire[i - 1].end);
        ++replies;
    }
    CHECK(replies > 20);
    CHECK(longest == pb::bit_times(dp_baud, pb::min_tsdr_bits));
    CHECK(longest <= pb::bit_times(dp_baud, pb::max_tsdr_bits(dp_baud)));
}

TEST_CASE("gateway: a reply longer than the DP inputs is counted, not cut", "[gateway]") {
    setup s(19'200, 19'200);
    REQUIRE_FALSE(pb::bring_up(s.dp_line, s.master, 8, prm(), cfg5));
    // Read 5 registers: the 12-byte reply PDU cannot fit 5 input bytes.
    const octets read5{0x03, 0xC8, 0x00, 0x00, 0x05};
    octets in;
    for (int cycle = 0; cycle < 40 && s.rig.core().stats().delivered == 0; ++cycle)
        REQUIRE_FALSE(s.exchange(read5, in));
    REQUIRE_FALSE(s.exchange(read5, in));
    CHECK(s.rig.core().stats().delivered == 1);
    CHECK(s.rig.core().stats().reply_overflows == 1);
    CHECK(in == octets(5, 0));
    CHECK((s.rig.core().status_word() >> 8 & 0x1F) == gw::status::buffer_overflow);
    pb::slave_diag d;
    REQUIRE_FALSE(pb::read_slave_diag(s.dp_line, s.master, 8, d));
    CHECK((d.ext[1] & gw::diag_flags::reply_overflow) != 0);
}

TEST_CASE("gateway: outputs that hold no Modbus request are refused and reported", "[gateway]") {
    setup s(19'200, 19'200);
    REQUIRE_FALSE(pb::bring_up(s.dp_line, s.master, 8, prm(), cfg5));
    const octets junk{0x07, 0x55, 0x55, 0x55, 0x55}; // FC 7 is not forwarded
    octets in;
    for (int cycle = 0; cycle < 5; ++cycle) REQUIRE_FALSE(s.exchange(junk, in));
    CHECK(s.rig.core().stats().invalid == 1);
    CHECK(s.rig.core().stats().commands == 0);
    CHECK(s.rig.drives()[0].session.stats().requests == 0);
    pb::slave_diag d;
    REQUIRE_FALSE(pb::read_slave_diag(s.dp_line, s.master, 8, d));
    CHECK((d.ext[1] & gw::diag_flags::invalid_command) != 0);
}

TEST_CASE("gateway mapped mode: a drive's control word and setpoint out, its status in",
          "[gateway]") {
    // Outputs: control word, setpoint (FC 16 on change). Inputs: status word of the gateway,
    // then the drive's status word and output frequency (FC 3 every 50 ms).
    const octets cfg{0x23, 0x15};
    const std::array<gw::transaction, 2> list{{
        {.unit = 1,
         .function = mb::function::write_multiple_registers,
         .address = mb::sim::vfd_register::control_word,
         .count = 2,
         .output_offset = 0,
         .update = gw::update::on_change},
        {.unit = 1,
         .function = mb::function::read_holding_registers,
         .address = mb::sim::vfd_register::status_word,
         .count = 2,
         .input_offset = 2,
         .interval = 50ms},
    }};
    gw::config c = transparent(187'500, 19'200);
    c.dp.cfg = cfg;
    c.mode = gw::mode::mapped;
    c.transactions = list;
    c.status_word = true;
    gw::sim::rig<2> rig(c);
    mb::server_config drive;
    drive.units = {1};
    drive.format = c.modbus.format;
    REQUIRE(rig.drives().add(drive));
    mock_serial dp_line(pb::format(187'500), &rig);
    pb::master master(setup::master_config(187'500));
    REQUIRE(list.size() == rig.core().transactions().size());
    REQUIRE_FALSE(rig.core().transactions().validate(6, 4));
    REQUIRE_FALSE(pb::bring_up(dp_line, master, 8, prm(), cfg));
    const octets out{0x00, 0x25, 0x13, 0x88}; // start, 50.00 Hz
    octets in(6);
    // The drive ramps to 50 Hz in 5 s (its default acceleration time).
    for (int cycle = 0; cycle < 10000 && dp_line.now() < time_point{} + 6s; ++cycle)
        REQUIRE_FALSE(pb::data_exchange(dp_line, master, 8, out, in));
    CHECK(rig.drives()[0].drive().control_word() == 0x0025);
    // Status word: data valid, no error.
    CHECK((in[0] << 8 | in[1]) == (gw::status::data_valid | gw::status::no_error << 8));
    // The drive's status: ready, running, at speed; output frequency 50.00 Hz.
    const unsigned drive_status = in[2] << 8 | in[3];
    CHECK((drive_status & mb::sim::status::running) != 0);
    CHECK((drive_status & mb::sim::status::at_speed) != 0);
    CHECK((in[4] << 8 | in[5]) == 5000);
    // The write went out once: on change only.
    CHECK(rig.core().transactions().online(1));
    CHECK(rig.core().online(1));
}

TEST_CASE("gateway: a lost DP reply is repeated from the stored one, the command taken once",
          "[gateway]") {
    setup s(19'200, 9'600);
    REQUIRE_FALSE(pb::bring_up(s.dp_line, s.master, 8, prm(), cfg5));
    const octets cmd{0x06, 0xC8, 0x01, 0x01, 0xF4}; // setpoint 5.00 Hz
    octets in;
    REQUIRE_FALSE(s.exchange(cmd, in));
    // The next reply is lost: the master repeats with the same FCB (§B.3), the slave answers
    // its stored reply and executes nothing again.
    s.rig.drop_dp_replies(1);
    REQUIRE_FALSE(s.exchange(cmd, in));
    CHECK(s.master.stats().resends == 1);
    CHECK(s.rig.core().dp().stats().repeats == 1);
    for (int cycle = 0; cycle < 40 && in != cmd; ++cycle) REQUIRE_FALSE(s.exchange(cmd, in));
    CHECK(in == cmd);
    CHECK(s.rig.core().stats().commands == 1);
    CHECK(s.rig.core().stats().delivered == 1);
    CHECK(s.rig.drives()[0].session.stats().requests == 1);
}

TEST_CASE("gateway: with freeze, a DP loss leaves the drive as it is and a lost drive's "
          "inputs stay",
          "[gateway]") {
    gw::config c = transparent(19'200, 19'200);
    c.on_dp_loss = gw::dp_loss::freeze;
    c.on_drive_loss = gw::drive_loss::freeze;
    gw::sim::rig<2> rig(c);
    mb::server_config drive;
    drive.units = {1};
    drive.format = c.modbus.format;
    REQUIRE(rig.drives().add(drive));
    mock_serial dp_line(pb::format(19'200), &rig);
    pb::master master(setup::master_config(19'200));
    REQUIRE_FALSE(pb::bring_up(dp_line, master, 8, prm(2), cfg5)); // watchdog 200 ms
    const octets start{0x06, 0xC8, 0x00, 0x00, 0x25};
    octets in(5);
    for (int cycle = 0; cycle < 40 && in != start; ++cycle)
        REQUIRE_FALSE(pb::data_exchange(dp_line, master, 8, start, in));
    REQUIRE(in == start);
    // The drive stops answering: its inputs are kept.
    rig.drives().drop_replies(100);
    const octets read{0x03, 0xC8, 0x02, 0x00, 0x01};
    for (int cycle = 0; cycle < 200 && rig.core().stats().failed == 0; ++cycle)
        REQUIRE_FALSE(pb::data_exchange(dp_line, master, 8, read, in));
    REQUIRE_FALSE(pb::data_exchange(dp_line, master, 8, read, in));
    CHECK_FALSE(rig.core().online(1));
    CHECK(in == start);
    // The master falls silent: no safe write, the drive keeps running.
    dp_line.advance(300ms);
    CHECK(rig.core().stats().dp_losses == 1);
    CHECK(rig.core().stats().safe_writes == 0);
    CHECK(rig.drives()[0].drive().control_word() == 0x0025);
}
