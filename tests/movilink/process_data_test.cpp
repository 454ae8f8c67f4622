// Process data helpers against the MTB scaling examples (movilink.md §3.2-3.4).
#include <catch2/catch.hpp>

#include <chrono>
#include <cstdint>
#include <limits>
#include <string_view>

#include "ferrule/movilink/process_data.hpp"

using namespace ferrule::movilink;
using namespace std::chrono_literals;

TEST_CASE("control word 1: the basic control block", "[movilink][process_data]") {
    CHECK(control_word::enable().value == 0x0006); // SC01 p.35
    CHECK(control_word::stop().value == 0x0002);
    CHECK(control_word::rapid_stop().value == 0x0000);
    CHECK(control_word::inhibit().value == 0x0001);
    CHECK(control_word::enable().with_reset().value == 0x0046);
    CHECK(control_word::enable().with_reset().reset());
    CHECK_FALSE(control_word::enable().reset());

    using cmd = control_word::command;
    CHECK(control_word::enable().requested() == cmd::enable);
    CHECK(control_word::stop().requested() == cmd::stop);
    CHECK(control_word::rapid_stop().requested() == cmd::rapid_stop);
    CHECK(control_word::inhibit().requested() == cmd::inhibit);
    // Controller inhibit wins over everything, rapid stop over stop.
    CHECK(control_word{0x0007}.requested() == cmd::inhibit);
    CHECK(control_word{0x0004}.requested() == cmd::rapid_stop);
}

TEST_CASE("status word 1: bits and high byte", "[movilink][process_data]") {
    // M2-rsp PI1 0x0206: ready, PO data enabled, output stage off, unit status 2 "no enable".
    const status_word m2{0x0206};
    CHECK_FALSE(m2.output_stage_enabled());
    CHECK(m2.ready());
    CHECK(m2.po_data_enabled());
    CHECK_FALSE(m2.fault());
    CHECK(m2.unit_status() == status_word::unit_status_no_enable);
    CHECK(m2.fault_number() == 0);

    const status_word running{0x0407};
    CHECK(running.output_stage_enabled());
    CHECK(running.unit_status() == status_word::unit_status_enable);

    const status_word fault{0x2B24}; // fault 43, bit 5 set, not ready
    CHECK(fault.fault());
    CHECK_FALSE(fault.ready());
    CHECK(fault.fault_number() == 43);
    CHECK(fault.unit_status() == 0);

    CHECK(status_word::make(true, true, true, false, 4) == running);
    CHECK(status_word::make(false, false, true, true, 43) == fault);
}

TEST_CASE("status word 1: bits 1 and 5 together", "[movilink][process_data]") {
    // movilink.md §3.3: ready 0 / fault 0 not ready, 0/1 fault, 1/0 ready, 1/1 warning.
    using cond = status_word::condition;
    SECTION("0/0: not ready, the high byte is the unit status") {
        const status_word sw{0x0104};
        CHECK(sw.state() == cond::not_ready);
        CHECK_FALSE(sw.fault());
        CHECK_FALSE(sw.warning());
        CHECK(sw.unit_status() == status_word::unit_status_controller_inhibit);
        CHECK(std::string_view(name(sw.state())) == "not ready");
    }
    SECTION("0/1: fault with its number") {
        const status_word sw{0x2B24};
        CHECK(sw.state() == cond::fault);
        CHECK(sw.fault());
        CHECK_FALSE(sw.warning());
        CHECK(sw.fault_number() == 43);
        CHECK(sw.warning_number() == 0);
        CHECK(sw.unit_status() == 0);
        CHECK(std::string_view(name(sw.state())) == "fault");
    }
    SECTION("1/0: ready, the high byte is the unit status") {
        const status_word sw{0x0407};
        CHECK(sw.state() == cond::ready);
        CHECK_FALSE(sw.fault_or_warning());
        CHECK(sw.unit_status() == status_word::unit_status_enable);
        CHECK(sw.fault_number() == 0);
        CHECK(sw.warning_number() == 0);
    }
    SECTION("1/1: a warning with its number, not a fault") {
        const status_word sw{0x0427}; // ferrule decode movilink 1D 01 05 04 27 07 D0 02 BC 53
        CHECK(sw.state() == cond::warning);
        CHECK(sw.warning());
        CHECK_FALSE(sw.fault());
        CHECK(sw.fault_or_warning());
        CHECK(sw.warning_number() == 4);
        CHECK(sw.fault_number() == 0);
        CHECK(sw.unit_status() == 0);
        CHECK(std::string_view(name(sw.state())) == "warning");
        CHECK(status_word::make(true, true, true, true, 4) == sw);
    }
}

TEST_CASE("speed: 0.2 rpm per digit", "[movilink][process_data]") {
    CHECK(rpm_to_digits(400) == 0x07D0);  // MTB: CW 400 rpm
    CHECK(rpm_to_digits(-750) == 0xF15A); // MTB: CCW 750 rpm
    CHECK(digits_to_rpm(0x07D0) == Approx(400));
    CHECK(digits_to_rpm(0xF15A) == Approx(-750));
    CHECK(rpm_to_digits(3000) == 0x3A98); // M1's PO2
    CHECK(rpm_to_digits(0.3) == 2);       // 1.5 digits: halves away from zero
    CHECK(rpm_to_digits(0.29) == 1);
    CHECK(rpm_to_digits(-0.3) == 0xFFFE);
    CHECK(rpm_to_digits(1e6) == 0x7FFF); // saturates
    CHECK(rpm_to_digits(-1e6) == 0x8000);
    CHECK(rpm_to_digits(std::numeric_limits<double>::quiet_NaN()) == 0);
    CHECK(digits_to_rpm(0x8000) == Approx(-6553.6));
}

TEST_CASE("relative speed: 0x4000 = 100 %", "[movilink][process_data]") {
    CHECK(percent_to_digits(25) == 0x1000);  // MTB
    CHECK(percent_to_digits(-75) == 0xD000); // MTB
    CHECK(percent_to_digits(100) == 0x4000);
    CHECK(percent_to_digits(-100) == 0xC000);
    // MMOT: -80 % -> 0xCCC5 with 0.0061 %/digit; the exact 16384 scaling gives 0xCCCD.
    CHECK(percent_to_digits(-80) == 0xCCCD);
    CHECK(percent_to_digits(50) == 0x2000); // M2's PO2 "50 %"
    CHECK(digits_to_percent(0x2000) == Approx(50));
    CHECK(digits_to_percent(0xD000) == Approx(-75));
    CHECK(percent_to_digits(300) == 0x7FFF);
}

TEST_CASE("current: 0.1 % of I_N per digit", "[movilink][process_data]") {
    CHECK(current_to_digits(45) == 0x01C2);         // MTB
    CHECK(current_to_digits(115.5) == 0x0483);      // MTB
    CHECK(digits_to_current(0x0320) == Approx(80)); // MFD manual: 0x0320 = 80 %
    CHECK(digits_to_current(0xFFF6) == Approx(-1));
}

TEST_CASE("ramp: 1 ms per digit", "[movilink][process_data]") {
    CHECK(ramp_to_digits(300ms) == 0x012C);  // MTB
    CHECK(ramp_to_digits(1400ms) == 0x0578); // MTB: 1.4 s
    CHECK(ramp_to_digits(3s) == 0x0BB8);     // M2's PO3
    CHECK(ramp_to_digits(-5ms) == 0);
    CHECK(ramp_to_digits(100s) == 0xFFFF);
    CHECK(digits_to_ramp(0x0578) == 1400ms);
}

TEST_CASE("position: 4096 increments per revolution, high word first", "[movilink][process_data]") {
    // MTB: 35 revolutions CCW -> 0xFFFD D000; 19 revolutions CW -> 0x0001 3000.
    CHECK(revolutions_to_increments(-35) == -143360);
    CHECK(increments_to_words(revolutions_to_increments(-35)) == position_words{0xFFFD, 0xD000});
    CHECK(increments_to_words(revolutions_to_increments(19)) == position_words{0x0001, 0x3000});
    CHECK(words_to_increments({0xFFFD, 0xD000}) == -143360);
    CHECK(increments_to_revolutions(words_to_increments({0x0001, 0x3000})) == Approx(19));
    CHECK(revolutions_to_increments(0.5 / 4096) == 1);
    CHECK(revolutions_to_increments(1e9) == 2147483647);
    CHECK(revolutions_to_increments(-1e9) == -2147483647 - 1);
}

TEST_CASE("control word 1: the manual's names of the commands", "[movilink][process_data]") {
    CHECK(std::string_view(name(control_word::enable().requested())) == "enable");
    CHECK(std::string_view(name(control_word::stop().requested())) == "stop");
    CHECK(std::string_view(name(control_word::rapid_stop().requested())) == "rapid stop");
    CHECK(std::string_view(name(control_word::inhibit().requested())) == "controller inhibit");
}
