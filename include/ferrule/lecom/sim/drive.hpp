// A simulated Lenze drive behind a LECOM slave: a code table that answers RECEIVE and SEND
// the way a drive does, and a speed model that runs in simulated time. For tests and the
// simulator; pair it with lecom::slave (station.hpp does).
//
//   RECEIVE   the code's value in its format (VD / VH / VS), or STX C1 C2 EOT when the
//             drive has no such code (S1 p.8-21); a subcode other than 0 does not exist,
//             as on the 82XX drives (lecom.md §3)
//   SEND      ACK when the code exists, is writable, the value has the code's format and is
//             within its range; NAK otherwise (S1 p.8-20). Strings are read-only (S1 p.8-19).
//             00 / x0 writes are applied the same way; the slave sends no reply (S1 p.8-24)
//
// The code table. Numbers from lecom.md are cited; the rest is this simulator's model:
//
//   code   fmt  access  meaning (unit)           4900 model          8200 model
//   C0009  VD   rw      LECOM unit address       1…99 without x0 (S1 p.6-3); writing moves
//                                                 the drive to the new address
//   C0011  VD   rw      maximum speed            0…6000 rpm, 3000    7.5…480 Hz, 50
//   C0012  VD   rw      acceleration time (s)    0…999.99, 2         0…1300, 5
//   C0013  VD   rw      deceleration time (s)    0…999.99, 2         0…1300, 5
//   C0040  VD   rw      controller enable        0 inhibit / 1 enable; starts at 1, as the
//                                                 manual's C0068 example reads (S1 p.8-22)
//   C0043  VD   rw      trip reset               reads 1 while a fault is active; writing 0
//                                                 resets it (the sim's; not in lecom.md)
//   C0046  VD   rw      speed setpoint           ±6000 rpm           ±480 Hz
//   C0050  VD   ro      actual speed             follows C0046, see below
//   C0067  VD   ro      fault: trip number       0 = none (S5: operating-fault numbers)
//   C0068  VH   ro      operating state          see state_bits (the bits differ per family,
//                                                 lecom.md §2: these are the sim's)
//   C0125  VD   rw      baud code                0…4, 0; kept, not acted on (the mapping is
//                                                 not in lecom.md §3; a pty has no baud)
//   C0200  VS   ro      software id              "4902 DC sim"       "82EV sim"
//
// The two families differ only in these limits, the unit and C0200; the reply forms of the
// 4900 (bare EOT / NAK) are the slave's bare_replies.
//
// Speed model (not the manual's): while the controller is enabled and no fault is active,
// C0050 follows C0046, limited to ±C0011, linearly: C0012 is the time from 0 to C0011 when
// the speed grows, C0013 when it falls; through zero it first falls to 0. Controller
// inhibit and a fault set the speed to 0 at once (the sim has no load that would coast).
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "ferrule/core/error.hpp"
#include "ferrule/core/result.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/lecom/code.hpp"
#include "ferrule/lecom/constants.hpp"
#include "ferrule/lecom/frame.hpp"
#include "ferrule/lecom/value.hpp"

namespace ferrule::lecom::sim {

enum class drive_family : std::uint8_t {
    lenze_4900, // 4900 DC speed controller (LECOM paper): speeds in rpm
    lenze_8200, // 8200 inverter with the 2102 module: speeds in Hz
};

// The simulated drive's codes.
namespace code_number {
inline constexpr std::uint16_t c0009_unit_address = 9; // S1 p.6-3
inline constexpr std::uint16_t c0011_max_speed = 11;
inline constexpr std::uint16_t c0012_accel_time = 12;
inline constexpr std::uint16_t c0013_decel_time = 13;
inline constexpr std::uint16_t c0040_controller_enable = 40; // S1 p.8-24 example
inline constexpr std::uint16_t c0043_trip_reset = 43;
inline constexpr std::uint16_t c0046_speed_setpoint = 46; // S1 p.8-22 example
inline constexpr std::uint16_t c0050_actual_speed = 50;
inline constexpr std::uint16_t c0067_fault = 67;           // S5
inline constexpr std::uint16_t c0068_operating_state = 68; // S1 p.8-22, S5
inline constexpr std::uint16_t c0125_baud = 125;           // LECOM paper, lecom.md §3
inline constexpr std::uint16_t c0200_software_id = 200;    // S1 p.8-19
} // namespace code_number

// C0068 as the simulator sets it (a model: lecom.md §2 warns the bits differ per family).
// The positions follow the 9200 list of S5.
namespace state_bits {
inline constexpr std::uint16_t fault = 0x0001;       // bits 0-3 operating fault: 1 while tripped
inline constexpr std::uint16_t enabled = 0x0100;     // bit 8: controller enabled, no fault
inline constexpr std::uint16_t running = 0x0400;     // bit 10: actual speed not 0
inline constexpr std::uint16_t at_setpoint = 0x4000; // bit 14: enabled, actual speed = setpoint
} // namespace state_bits

struct code_entry {
    std::uint16_t code = 0;
    value_format format = value_format::decimal; // decimal, hex or string
    bool read_only = false;
    bool whole = false;  // a decimal without fraction (addresses, switches, numbers)
    std::int32_t lo = 0; // what a write must keep to: FIX32 for VD, the number for VH
    std::int32_t hi = 0;
    std::int32_t value = 0;  // FIX32 for VD, the number for VH; live codes are computed
    std::uint8_t digits = 0; // VD: decimals written at least; VH: hex digits
};

struct drive_config {
    drive_family family = drive_family::lenze_4900;
    std::uint8_t address = 1; // C0009
};

class drive {
public:
    static constexpr std::size_t code_count = 12;

    explicit drive(const drive_config& cfg = {}) noexcept
        : family_(cfg.family), codes_(factory_codes(cfg.family)) {
        if (is_unit_address(cfg.address))
            entry(code_number::c0009_unit_address)->value = cfg.address * value::scale;
    }

    // The reply to a request addressed to this drive: data or no_code to a RECEIVE, ACK or
    // NAK to a SEND. Requests to 00 / x0 are handled the same way; their reply is not sent.
    frame handle(const frame& request, time_point now) noexcept {
        advance(now);
        const code_entry* e = request.code.subcode == 0 ? find(request.code.code) : nullptr;
        if (request.kind == frame_kind::receive) {
            if (!e) return {frame_kind::no_code, 0, request.code, {}};
            return {frame_kind::data, 0, request.code, read(*e)};
        }
        if (request.kind == frame_kind::send && e && write(*e, request.value))
            return frame{frame_kind::ack};
        return frame{frame_kind::nak};
    }

    // Runs the speed model up to `now`; the first call only sets the clock, earlier times
    // are ignored.
    void advance(time_point now) noexcept {
        if (clock_set_ && !before(now_, now)) return;
        if (clock_set_) integrate(now - now_);
        clock_set_ = true;
        now_ = now;
    }

    // A fault with this trip number (C0067; 0 is none): the speed drops to 0 until
    // reset_trip() or a write of 0 to C0043.
    void trip(std::uint16_t number) noexcept {
        fault_ = number;
        integrate({});
    }
    void reset_trip() noexcept { fault_ = 0; }

    // The value a RECEIVE of `c` would return (at the last advance()).
    result<value> value_of(std::uint16_t c) const noexcept {
        const code_entry* e = find(c);
        if (!e) return errc::invalid_argument;
        return read(*e);
    }

    // Sets a stored code's value (FIX32 for VD, the number for VH) without the checks of a
    // SEND; live codes (C0043, C0050, C0067, C0068, C0200) cannot be set.
    bool preset(std::uint16_t c, std::int32_t v) noexcept {
        code_entry* e = entry(c);
        if (!e || is_live(c)) return false;
        e->value = v;
        integrate({});
        return true;
    }

    std::uint8_t address() const noexcept {
        return static_cast<std::uint8_t>(stored(code_number::c0009_unit_address) / value::scale);
    }
    bool enabled() const noexcept {
        return stored(code_number::c0040_controller_enable) != 0 && fault_ == 0;
    }
    std::uint16_t fault() const noexcept { return fault_; }
    // Actual speed, FIX32 (C0050).
    std::int32_t speed() const noexcept { return static_cast<std::int32_t>(std::llround(speed_)); }
    std::uint16_t operating_state() const noexcept {
        std::uint16_t s = 0;
        if (fault_ != 0) s |= state_bits::fault;
        if (enabled()) s |= state_bits::enabled;
        if (speed() != 0) s |= state_bits::running;
        if (enabled() && speed_ == target()) s |= state_bits::at_setpoint;
        return s;
    }
    drive_family family() const noexcept { return family_; }
    std::string_view software_id() const noexcept {
        return family_ == drive_family::lenze_4900 ? "4902 DC sim" : "82EV sim";
    }
    std::span<const code_entry> codes() const noexcept { return codes_; }
    const code_entry* find(std::uint16_t c) const noexcept {
        for (const auto& e : codes_)
            if (e.code == c) return &e;
        return nullptr;
    }

private:
    using code_table = std::array<code_entry, code_count>;

    static constexpr std::int32_t fix(std::int32_t whole) noexcept { return whole * value::scale; }

    static constexpr code_entry setting(std::uint16_t c, std::int32_t lo, std::int32_t hi,
                                        std::int32_t def, std::uint8_t digits = 0) noexcept {
        return {c, value_format::decimal, false, false, lo, hi, def, digits};
    }
    static constexpr code_entry number(std::uint16_t c, std::int32_t lo, std::int32_t hi,
                                       std::int32_t def) noexcept {
        return {c, value_format::decimal, false, true, fix(lo), fix(hi), fix(def), 0};
    }
    static constexpr code_entry live(std::uint16_t c, value_format f = value_format::decimal,
                                     std::uint8_t digits = 0) noexcept {
        return {c, f, true, false, 0, 0, 0, digits};
    }

    static constexpr code_table factory_codes(drive_family f) noexcept {
        namespace n = code_number;
        const bool dc = f == drive_family::lenze_4900;
        // Model limits: rpm for the DC drive, Hz for the inverter.
        const std::int32_t max_lo = dc ? 0 : 75'000;           // 7.5 Hz
        const std::int32_t max_hi = dc ? fix(6000) : fix(480); // also the setpoint's limit
        const std::int32_t max_def = dc ? fix(3000) : fix(50);
        const std::int32_t ramp_hi = dc ? 9'999'900 : fix(1300);
        const std::int32_t ramp_def = dc ? fix(2) : fix(5);
        return {{
            number(n::c0009_unit_address, 1, 99, 1),
            setting(n::c0011_max_speed, max_lo, max_hi, max_def),
            setting(n::c0012_accel_time, 0, ramp_hi, ramp_def, 2),
            setting(n::c0013_decel_time, 0, ramp_hi, ramp_def, 2),
            number(n::c0040_controller_enable, 0, 1, 1),
            // Writing 0 resets; reads are live.
            {n::c0043_trip_reset, value_format::decimal, false, true, 0, 0, 0, 0},
            setting(n::c0046_speed_setpoint, -max_hi, max_hi, 0),
            live(n::c0050_actual_speed),
            live(n::c0067_fault),
            live(n::c0068_operating_state, value_format::hex, 4),
            number(n::c0125_baud, 0, 4, 0),
            live(n::c0200_software_id, value_format::string),
        }};
    }

    static constexpr bool is_live(std::uint16_t c) noexcept {
        namespace n = code_number;
        return c == n::c0043_trip_reset || c == n::c0050_actual_speed || c == n::c0067_fault ||
               c == n::c0068_operating_state || c == n::c0200_software_id;
    }

    code_entry* entry(std::uint16_t c) noexcept {
        for (auto& e : codes_)
            if (e.code == c) return &e;
        return nullptr;
    }
    std::int32_t stored(std::uint16_t c) const noexcept { return find(c)->value; }

    value read(const code_entry& e) const noexcept {
        namespace n = code_number;
        switch (e.code) {
        case n::c0043_trip_reset: return decimal_fixed(fix(fault_ != 0 ? 1 : 0));
        case n::c0050_actual_speed: return decimal_fixed(speed());
        case n::c0067_fault: return decimal_fixed(fix(fault_));
        case n::c0068_operating_state: return *hex(operating_state(), e.digits);
        case n::c0200_software_id: return *string(software_id());
        default: break;
        }
        if (e.format == value_format::hex)
            return *hex(static_cast<std::uint32_t>(e.value), e.digits);
        return decimal_fixed(e.value, e.digits);
    }

    // A SEND's checks (S1 p.8-20, S2 §6.1) and its effect; false: NAK.
    bool write(const code_entry& e, const value& v) noexcept {
        namespace n = code_number;
        if (e.read_only || v.format != e.format) return false;
        std::int32_t x = 0;
        switch (v.format) {
        case value_format::decimal: x = v.fixed; break;
        case value_format::hex: x = static_cast<std::int32_t>(v.hex); break;
        default: return false; // strings and octets are sent by the drive only (S1 p.8-19)
        }
        if (x < e.lo || x > e.hi || (e.whole && x % value::scale != 0)) return false;
        // 00 and x0 are reserved for group addressing (S1 p.6-3).
        if (e.code == n::c0009_unit_address &&
            !is_unit_address(static_cast<std::uint8_t>(x / value::scale)))
            return false;
        if (e.code == n::c0043_trip_reset) {
            reset_trip();
            return true;
        }
        entry(e.code)->value = x;
        integrate({});
        return true;
    }

    // Where the speed is heading: C0046 within ±C0011 while enabled, else 0.
    double target() const noexcept {
        if (!enabled()) return 0;
        const double max = stored(code_number::c0011_max_speed);
        return std::clamp(static_cast<double>(stored(code_number::c0046_speed_setpoint)), -max,
                          max);
    }

    void integrate(duration dt) noexcept {
        if (!enabled()) {
            speed_ = 0;
            return;
        }
        const double target_speed = target();
        const double max = stored(code_number::c0011_max_speed);
        double t = std::chrono::duration<double>(dt).count();
        while (speed_ != target_speed) {
            const bool through_zero =
                (speed_ > 0 && target_speed < 0) || (speed_ < 0 && target_speed > 0);
            const double goal = through_zero ? 0.0 : target_speed;
            const bool growing = std::abs(goal) > std::abs(speed_);
            const double ramp_s =
                static_cast<double>(stored(growing ? code_number::c0012_accel_time
                                                   : code_number::c0013_decel_time)) /
                value::scale;
            if (ramp_s <= 0 || max <= 0) {
                speed_ = goal;
                continue;
            }
            const double rate = max / ramp_s; // FIX32 per second
            const double need = std::abs(goal - speed_) / rate;
            if (need > t) {
                speed_ += (goal > speed_ ? rate : -rate) * t;
                return;
            }
            speed_ = goal;
            t -= need;
        }
    }

    drive_family family_;
    code_table codes_;
    std::uint16_t fault_ = 0;
    double speed_ = 0; // FIX32 units
    bool clock_set_ = false;
    time_point now_{};
};

} // namespace ferrule::lecom::sim
