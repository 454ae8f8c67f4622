// A simulated variable-frequency drive behind a Modbus server: a data model (data_model.hpp)
// for server<M>, with a speed model that runs in simulated time. For tests and the simulator.
//
// The gateway paper (seeds/002) drives a VFD over Modbus RTU with four classes of command:
// start / stop, read the drive's state, write a parameter, read a parameter. Its one example
// is the start command: slave 1, FC 6, register 0xC800 = 0x0025, on the wire
// 01 06 C8 00 00 25 76 71. The paper gives no other register, so everything below except
// 0xC800 and its value 0x0025 meaning "start" is this simulator's model.
//
// Holding registers (FC 3 / 6 / 16 / 23; FC 4 reads the same map, as many drives do):
//
//   address  access  meaning                       range, default
//   0xC800   rw      control word (see control)    reserved bits must be 0; 0x0025 = start
//   0xC801   rw      frequency setpoint, 0.01 Hz   0 … max frequency (0xC900), 0
//   0xC802   ro      status word (see status)
//   0xC803   ro      output frequency, 0.01 Hz     magnitude; the direction is in the status
//   0xC804   ro      fault code                    0 = none, else what trip() was given
//   0xC900   rw      max frequency, 0.01 Hz        1000 … 40000 (10 … 400 Hz), 5000
//   0xC901   rw      acceleration time, 0.1 s      0 … 6000, 50: 0 Hz to max frequency
//   0xC902   rw      deceleration time, 0.1 s      0 … 6000, 50: max frequency to 0 Hz
//   0xC903   rw      baud rate select              0 … 3: 19200 / 9600 / 4800 / 2400, the
//                                                  paper's four rates; kept, not acted on
//
// Coils 0-15 (FC 1 / 5 / 15) are the bits of the control word, discrete inputs 0-15 (FC 2)
// those of the status word. The device identification (FC 43 / 14) is "ferrule",
// "sim-vfd", "1.0".
//
// Exceptions (Modbus Application Protocol V1.1b3 §7): an address that is not in the map,
// also inside a multi-register request, or a write to a read-only register: 02 illegal data
// address; a value outside its range or a reserved control bit set: 03 illegal data value.
// A write that fails changes nothing, a multi-register write is checked whole first.
//
// Speed model (not a real drive's): while run, enable and no fault, the output frequency
// follows the setpoint (0 while "setpoint enable" is off), limited to the max frequency,
// linearly: the acceleration time is the time from 0 to max frequency when it grows, the
// deceleration time when it falls; reversing first falls to 0. Run off ramps down to 0.
// Enable off or a fault set the output to 0 at once (the sim has no load that would coast).
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "ferrule/core/bytes.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/modbus/constants.hpp"
#include "ferrule/modbus/data_model.hpp"

namespace ferrule::modbus::sim {

// The simulated drive's registers.
namespace vfd_register {
inline constexpr std::uint16_t control_word = 0xC800; // the paper's start command register
inline constexpr std::uint16_t frequency_setpoint = 0xC801;
inline constexpr std::uint16_t status_word = 0xC802;
inline constexpr std::uint16_t output_frequency = 0xC803;
inline constexpr std::uint16_t fault_code = 0xC804;
inline constexpr std::uint16_t max_frequency = 0xC900;
inline constexpr std::uint16_t acceleration_time = 0xC901;
inline constexpr std::uint16_t deceleration_time = 0xC902;
inline constexpr std::uint16_t baud_select = 0xC903;
} // namespace vfd_register

// Control word bits (the sim's; 0x0025 = run | enable | setpoint enable, the paper's start).
namespace control {
inline constexpr std::uint16_t run = 0x0001;                           // 0: ramp down to 0 (stop)
inline constexpr std::uint16_t reverse = 0x0002;                       // direction of rotation
inline constexpr std::uint16_t enable = 0x0004;                        // 0: output off at once
inline constexpr std::uint16_t fault_reset = 0x0008;                   // 0 -> 1 clears a fault
inline constexpr std::uint16_t setpoint_enable = 0x0020;               // 0: the ramp heads for 0 Hz
inline constexpr std::uint16_t start = run | enable | setpoint_enable; // 0x0025
inline constexpr std::uint16_t defined = run | reverse | enable | fault_reset | setpoint_enable;
} // namespace control

// Status word bits (the sim's).
namespace status {
inline constexpr std::uint16_t ready = 0x0001;    // enabled and no fault
inline constexpr std::uint16_t running = 0x0002;  // run accepted, or the output not yet 0
inline constexpr std::uint16_t reverse = 0x0004;  // output turning in reverse
inline constexpr std::uint16_t fault = 0x0008;    // a fault is active (see fault code)
inline constexpr std::uint16_t at_speed = 0x0010; // running and output = setpoint
} // namespace status

class vfd {
public:
    struct parameter {
        std::uint16_t address;
        std::uint16_t lo, hi, value;
    };
    static constexpr std::size_t parameter_count = 4;

    vfd() = default;

    // --- data_model ------------------------------------------------------------------------
    std::uint8_t read_bits(function fc, std::uint16_t address, std::uint16_t quantity,
                           std::span<std::uint8_t> out) const noexcept {
        if (std::size_t{address} + quantity > 16) return illegal_address;
        const std::uint16_t word = fc == function::read_coils ? control_ : status_word();
        for (std::size_t i = 0; i < quantity; ++i)
            if ((word >> (address + i)) & 1u)
                out[i / 8] = static_cast<std::uint8_t>(out[i / 8] | 1u << i % 8);
        return 0;
    }

    std::uint8_t read_registers(function, std::uint16_t address, std::uint16_t quantity,
                                std::span<std::uint8_t> out) const noexcept {
        for (std::size_t i = 0; i < quantity; ++i) {
            const std::size_t a = std::size_t{address} + i;
            if (a > 0xFFFF || !readable(static_cast<std::uint16_t>(a))) return illegal_address;
        }
        for (std::size_t i = 0; i < quantity; ++i)
            store_be16(out.data() + 2 * i, read(static_cast<std::uint16_t>(address + i)));
        return 0;
    }

    std::uint8_t write_coils(std::uint16_t address, std::uint16_t quantity,
                             std::span<const std::uint8_t> packed) noexcept {
        if (std::size_t{address} + quantity > 16) return illegal_address;
        std::uint16_t word = control_;
        for (std::size_t i = 0; i < quantity; ++i) {
            const auto mask = static_cast<std::uint16_t>(1u << (address + i));
            word = (packed[i / 8] >> i % 8) & 1u ? static_cast<std::uint16_t>(word | mask)
                                                 : static_cast<std::uint16_t>(word & ~mask);
        }
        if (const auto e = check(vfd_register::control_word, word)) return e;
        apply(vfd_register::control_word, word);
        return 0;
    }

    std::uint8_t write_registers(std::uint16_t address, std::uint16_t quantity,
                                 std::span<const std::uint8_t> data) noexcept {
        // The whole write is checked before any of it is applied. A max frequency below the
        // setpoint written with it is checked against the new max.
        std::uint16_t new_max = param(vfd_register::max_frequency);
        for (std::size_t i = 0; i < quantity; ++i) {
            const std::size_t a = std::size_t{address} + i;
            if (a > 0xFFFF || !writable(static_cast<std::uint16_t>(a))) return illegal_address;
            if (a == vfd_register::max_frequency) new_max = load_be16(data.data() + 2 * i);
        }
        for (std::size_t i = 0; i < quantity; ++i) {
            const auto a = static_cast<std::uint16_t>(address + i);
            const std::uint16_t v = load_be16(data.data() + 2 * i);
            if (const auto e = check(a, v, new_max)) return e;
        }
        for (std::size_t i = 0; i < quantity; ++i)
            apply(static_cast<std::uint16_t>(address + i), load_be16(data.data() + 2 * i));
        return 0;
    }

    std::string_view device_id(std::uint8_t object_id) const noexcept {
        switch (object_id) {
        case 0: return "ferrule";
        case 1: return "sim-vfd";
        case 2: return "1.0";
        default: return {};
        }
    }

    // --- simulation --------------------------------------------------------------------------
    // Runs the speed model up to `now`; the first call only sets the clock, earlier times are
    // ignored.
    void advance(time_point now) noexcept {
        if (clock_set_ && !before(now_, now)) return;
        if (clock_set_) integrate(now - now_);
        clock_set_ = true;
        now_ = now;
    }

    // A fault with this code (0xC804; 0 clears it): the output drops to 0 at once until a
    // fault reset (control bit 3 from 0 to 1) or reset_fault().
    void trip(std::uint16_t code) noexcept {
        fault_ = code;
        integrate({});
    }
    void reset_fault() noexcept { fault_ = 0; }

    std::uint16_t control_word() const noexcept { return control_; }
    std::uint16_t setpoint() const noexcept { return setpoint_; }
    std::uint16_t fault_code() const noexcept { return fault_; }
    // Output frequency in 0.01 Hz, negative in reverse.
    std::int32_t output() const noexcept { return static_cast<std::int32_t>(std::lround(f_)); }
    std::uint16_t status_word() const noexcept {
        std::uint16_t s = 0;
        if (enabled()) s |= status::ready;
        if (run_accepted() || output() != 0) s |= status::running;
        if (output() < 0 || (output() == 0 && (control_ & control::reverse))) s |= status::reverse;
        if (fault_ != 0) s |= status::fault;
        if (run_accepted() && f_ == target()) s |= status::at_speed;
        return s;
    }
    std::span<const parameter> parameters() const noexcept { return params_; }

private:
    static constexpr std::uint8_t illegal_address = code_of(exception_code::illegal_data_address);
    static constexpr std::uint8_t illegal_value = code_of(exception_code::illegal_data_value);

    bool enabled() const noexcept { return (control_ & control::enable) && fault_ == 0; }
    bool run_accepted() const noexcept { return enabled() && (control_ & control::run); }

    const parameter* find(std::uint16_t a) const noexcept {
        for (const auto& p : params_)
            if (p.address == a) return &p;
        return nullptr;
    }
    std::uint16_t param(std::uint16_t a) const noexcept { return find(a)->value; }

    static constexpr bool live(std::uint16_t a) noexcept {
        return a == vfd_register::status_word || a == vfd_register::output_frequency ||
               a == vfd_register::fault_code;
    }
    bool writable(std::uint16_t a) const noexcept {
        return a == vfd_register::control_word || a == vfd_register::frequency_setpoint ||
               find(a) != nullptr;
    }
    bool readable(std::uint16_t a) const noexcept { return writable(a) || live(a); }

    std::uint16_t read(std::uint16_t a) const noexcept {
        switch (a) {
        case vfd_register::control_word: return control_;
        case vfd_register::frequency_setpoint: return setpoint_;
        case vfd_register::status_word: return status_word();
        case vfd_register::output_frequency: return static_cast<std::uint16_t>(std::abs(output()));
        case vfd_register::fault_code: return fault_;
        default: return param(a);
        }
    }

    // 0 when `v` may be written to the writable register `a`, else the exception code.
    std::uint8_t check(std::uint16_t a, std::uint16_t v) const noexcept {
        return check(a, v, param(vfd_register::max_frequency));
    }
    std::uint8_t check(std::uint16_t a, std::uint16_t v, std::uint16_t max) const noexcept {
        if (a == vfd_register::control_word) return (v & ~control::defined) ? illegal_value : 0;
        if (a == vfd_register::frequency_setpoint) return v > max ? illegal_value : 0;
        const parameter* p = find(a);
        return v < p->lo || v > p->hi ? illegal_value : 0;
    }

    void apply(std::uint16_t a, std::uint16_t v) noexcept {
        if (a == vfd_register::control_word) {
            const bool reset_edge =
                (v & control::fault_reset) && !(control_ & control::fault_reset);
            if (reset_edge) fault_ = 0;
            control_ = v;
        } else if (a == vfd_register::frequency_setpoint) {
            setpoint_ = v;
        } else {
            for (auto& p : params_)
                if (p.address == a) p.value = v;
        }
        integrate({});
    }

    // Where the output is heading, in 0.01 Hz, signed.
    double target() const noexcept {
        if (!run_accepted() || !(control_ & control::setpoint_enable)) return 0;
        const double f = std::min(setpoint_, param(vfd_register::max_frequency));
        return control_ & control::reverse ? -f : f;
    }

    void integrate(duration dt) noexcept {
        if (!enabled()) {
            f_ = 0;
            return;
        }
        const double goal_f = target();
        const double max = param(vfd_register::max_frequency);
        double t = std::chrono::duration<double>(dt).count();
        while (f_ != goal_f) {
            const bool through_zero = (f_ > 0 && goal_f < 0) || (f_ < 0 && goal_f > 0);
            const double goal = through_zero ? 0.0 : goal_f;
            const bool growing = std::abs(goal) > std::abs(f_);
            const double ramp_s =
                param(growing ? vfd_register::acceleration_time : vfd_register::deceleration_time) /
                10.0;
            if (ramp_s <= 0) {
                f_ = goal;
                continue;
            }
            const double rate = max / ramp_s; // 0.01 Hz per second
            const double need = std::abs(goal - f_) / rate;
            if (need <= t) {
                f_ = goal;
                t -= need;
                continue;
            }
            f_ += (goal > f_ ? rate : -rate) * t;
            return;
        }
    }

    std::uint16_t control_ = 0;
    std::uint16_t setpoint_ = 0;
    std::uint16_t fault_ = 0;
    double f_ = 0;
    std::array<parameter, parameter_count> params_{{
        {vfd_register::max_frequency, 1000, 40000, 5000},
        {vfd_register::acceleration_time, 0, 6000, 50},
        {vfd_register::deceleration_time, 0, 6000, 50},
        {vfd_register::baud_select, 0, 3, 0},
    }};
    bool clock_set_ = false;
    time_point now_{};
};

static_assert(data_model<vfd>);

} // namespace ferrule::modbus::sim
