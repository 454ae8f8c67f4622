// MOVILINK process data: control word 1, status word 1 and the scaling of PD words
// (movilink.md §3.2-3.4; MTB "control word 1", "status word 1", "scaling examples").
// PD words go on the wire as 16-bit values; signed quantities are two's complement.
#pragma once

#include <chrono>
#include <cstdint>

namespace ferrule::movilink {

// Control word 1, basic control block = bits 0-7 (MTB 5947079179).
struct control_word {
    static constexpr std::uint16_t controller_inhibit_bit = 0x0001; // 1 = inhibit
    static constexpr std::uint16_t enable_rapid_stop_bit = 0x0002;  // 1 = enable, 0 = rapid stop
    static constexpr std::uint16_t enable_stop_bit = 0x0004;        // 1 = enable, 0 = stop
    static constexpr std::uint16_t reset_bit = 0x0040;              // fault reset

    // What the basic control block asks for, highest priority first.
    enum class command : std::uint8_t { inhibit, rapid_stop, stop, enable };

    std::uint16_t value = 0;

    // 0x0006 = enable (SC01 p.35); the others follow from the bit table.
    static constexpr control_word enable() noexcept { return {0x0006}; }
    static constexpr control_word stop() noexcept { return {0x0002}; }
    static constexpr control_word rapid_stop() noexcept { return {0x0000}; }
    static constexpr control_word inhibit() noexcept { return {controller_inhibit_bit}; }
    constexpr control_word with_reset() const noexcept {
        return {static_cast<std::uint16_t>(value | reset_bit)};
    }

    constexpr command requested() const noexcept {
        if (value & controller_inhibit_bit) return command::inhibit;
        if (!(value & enable_rapid_stop_bit)) return command::rapid_stop;
        if (!(value & enable_stop_bit)) return command::stop;
        return command::enable;
    }
    constexpr bool reset() const noexcept { return (value & reset_bit) != 0; }

    friend constexpr bool operator==(control_word, control_word) = default;
};

// The manual's name of what the basic control block asks for (MTB 5947079179).
constexpr const char* name(control_word::command c) noexcept {
    switch (c) {
    case control_word::command::inhibit: return "controller inhibit";
    case control_word::command::rapid_stop: return "rapid stop";
    case control_word::command::stop: return "stop";
    case control_word::command::enable: return "enable";
    }
    return "unknown";
}

// Status word 1 (MTB 5947088779; MDXB p.93).
struct status_word {
    static constexpr std::uint16_t output_stage_enabled_bit = 0x0001;
    static constexpr std::uint16_t ready_bit = 0x0002;
    static constexpr std::uint16_t po_data_enabled_bit = 0x0004;
    static constexpr std::uint16_t fault_warning_bit = 0x0020; // fault / warning

    // High byte when no fault or warning is signalled (movilink.md §3.3: MTB 0x1 controller
    // inhibit; MOVIMOT list 2 no enable, 4 enable).
    static constexpr std::uint8_t unit_status_controller_inhibit = 0x1;
    static constexpr std::uint8_t unit_status_no_enable = 0x2;
    static constexpr std::uint8_t unit_status_enable = 0x4;

    // What bits 1 (ready) and 5 (fault/warning) say together (movilink.md §3.3, MOVITRAC 31
    // unit profile p.35): 0/0 not ready, 0/1 fault, 1/0 ready, 1/1 warning.
    enum class condition : std::uint8_t { not_ready, fault, ready, warning };

    std::uint16_t value = 0;

    static constexpr status_word make(bool output_stage_enabled, bool ready, bool po_data_enabled,
                                      bool fault_or_warning, std::uint8_t high_byte) noexcept {
        return {static_cast<std::uint16_t>((std::uint16_t{high_byte} << 8) |
                                           (output_stage_enabled ? output_stage_enabled_bit : 0) |
                                           (ready ? ready_bit : 0) |
                                           (po_data_enabled ? po_data_enabled_bit : 0) |
                                           (fault_or_warning ? fault_warning_bit : 0))};
    }

    constexpr bool output_stage_enabled() const noexcept {
        return (value & output_stage_enabled_bit) != 0;
    }
    constexpr bool ready() const noexcept { return (value & ready_bit) != 0; }
    constexpr bool po_data_enabled() const noexcept { return (value & po_data_enabled_bit) != 0; }
    // Bit 5 alone: a fault or a warning is pending; ready() tells which.
    constexpr bool fault_or_warning() const noexcept { return (value & fault_warning_bit) != 0; }
    constexpr condition state() const noexcept {
        if (fault_or_warning()) return ready() ? condition::warning : condition::fault;
        return ready() ? condition::ready : condition::not_ready;
    }
    constexpr bool fault() const noexcept { return state() == condition::fault; }
    constexpr bool warning() const noexcept { return state() == condition::warning; }
    // Bit 5 decides what the high byte holds: the fault or warning number, else the unit
    // status. Each accessor returns 0 when the high byte holds something else.
    constexpr std::uint8_t unit_status() const noexcept {
        return fault_or_warning() ? 0 : high_byte();
    }
    constexpr std::uint8_t fault_number() const noexcept { return fault() ? high_byte() : 0; }
    constexpr std::uint8_t warning_number() const noexcept { return warning() ? high_byte() : 0; }

    friend constexpr bool operator==(status_word, status_word) = default;

private:
    constexpr std::uint8_t high_byte() const noexcept {
        return static_cast<std::uint8_t>(value >> 8);
    }
};

constexpr const char* name(status_word::condition c) noexcept {
    switch (c) {
    case status_word::condition::not_ready: return "not ready";
    case status_word::condition::fault: return "fault";
    case status_word::condition::ready: return "ready";
    case status_word::condition::warning: return "warning";
    }
    return "unknown";
}

namespace detail {
// Rounds to nearest (halves away from zero) and saturates to int16; NaN gives 0.
constexpr std::uint16_t saturate_round_16(double x) noexcept {
    if (x != x) return 0;
    if (x >= 32767.0) return 0x7FFF;
    if (x <= -32768.0) return 0x8000;
    const auto r = static_cast<std::int32_t>(x < 0 ? x - 0.5 : x + 0.5);
    return static_cast<std::uint16_t>(static_cast<std::int16_t>(r));
}
constexpr double signed_16(std::uint16_t w) noexcept {
    return static_cast<std::int16_t>(w);
}
} // namespace detail

// Speed: 1 digit = 0.2 rpm, sign = direction (MTB: CW 400 rpm -> 0x07D0, CCW 750 -> 0xF15A).
inline constexpr double rpm_per_digit = 0.2;
constexpr std::uint16_t rpm_to_digits(double rpm) noexcept {
    return detail::saturate_round_16(rpm * 5.0); // 5 digits per rpm, exact for 0.3 rpm too
}
constexpr double digits_to_rpm(std::uint16_t digits) noexcept {
    return detail::signed_16(digits) * rpm_per_digit;
}

// Relative speed: 0x4000 = +100 %, 0xC000 = -100 % (MTB: 25 % -> 0x1000, -75 % -> 0xD000).
// Exact 16384 scaling; MOVIMOT's example rounds with 0.0061 %/digit (movilink.md §3.4).
inline constexpr double percent_full_scale = 0x4000;
constexpr std::uint16_t percent_to_digits(double percent) noexcept {
    return detail::saturate_round_16(percent * percent_full_scale / 100.0);
}
constexpr double digits_to_percent(std::uint16_t digits) noexcept {
    return detail::signed_16(digits) * 100.0 / percent_full_scale;
}

// Current: 1 digit = 0.1 % of the rated current I_N (MTB: 45 % -> 0x01C2, 115.5 % -> 0x0483).
constexpr std::uint16_t current_to_digits(double percent_of_rated) noexcept {
    return detail::saturate_round_16(percent_of_rated * 10.0);
}
constexpr double digits_to_current(std::uint16_t digits) noexcept {
    return detail::signed_16(digits) / 10.0;
}

// Ramp: 1 digit = 1 ms (MTB: 300 ms -> 0x012C, 1.4 s -> 0x0578); saturates to 0..65535 ms.
constexpr std::uint16_t ramp_to_digits(std::chrono::milliseconds ramp) noexcept {
    if (ramp.count() <= 0) return 0;
    if (ramp.count() >= 0xFFFF) return 0xFFFF;
    return static_cast<std::uint16_t>(ramp.count());
}
constexpr std::chrono::milliseconds digits_to_ramp(std::uint16_t digits) noexcept {
    return std::chrono::milliseconds{digits};
}

// Position: 4096 increments per motor revolution, 32-bit in two PD words, high word first
// (MTB: 35 rev CCW -> 0xFFFD 0xD000, 19 rev CW -> 0x0001 0x3000).
inline constexpr std::int32_t increments_per_revolution = 4096;

struct position_words {
    std::uint16_t high = 0;
    std::uint16_t low = 0;
    friend constexpr bool operator==(position_words, position_words) = default;
};

constexpr position_words increments_to_words(std::int32_t increments) noexcept {
    const auto u = static_cast<std::uint32_t>(increments);
    return {static_cast<std::uint16_t>(u >> 16), static_cast<std::uint16_t>(u)};
}
constexpr std::int32_t words_to_increments(position_words w) noexcept {
    return static_cast<std::int32_t>((std::uint32_t{w.high} << 16) | w.low);
}
// Rounds to the nearest increment, saturating to the int32 range; NaN gives 0.
constexpr std::int32_t revolutions_to_increments(double revolutions) noexcept {
    const double x = revolutions * increments_per_revolution;
    if (x != x) return 0;
    if (x >= 2147483647.0) return 2147483647;
    if (x <= -2147483648.0) return -2147483647 - 1;
    return static_cast<std::int32_t>(x < 0 ? x - 0.5 : x + 0.5);
}
constexpr double increments_to_revolutions(std::int32_t increments) noexcept {
    return static_cast<double>(increments) / increments_per_revolution;
}

} // namespace ferrule::movilink
