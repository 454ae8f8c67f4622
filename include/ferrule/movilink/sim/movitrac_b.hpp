// A simulated SEW MOVITRAC B behind a MOVILINK slave: answers requests with the reply a
// drive would send and runs a simple motor model in simulated time. For tests and the
// simulator; pair it with movilink::slave (bus.hpp does).
//
//   parameter channel  read, write (EEPROM), write volatile (RAM), read minimum / maximum /
//                      default / scale / attribute (movilink.md §2.2, §2.4); return codes
//                      class 8 code 0 + additional code, 5/5 illegal service, 6/8 data
//                      length (§2.5); cyclic types execute a service only when the handshake
//                      bit toggles (§2.3), optionally a few requests late (param_latency)
//   process data       PO/PI words as P870-P875 describe them (§3.1); by default PO1 control
//                      word 1, PO2 speed, PO3 ramp; PI1 status word 1, PI2 speed, PI3 output
//                      current (§3.2-3.4)
//   motor model        the speed follows the setpoint linearly: ramp_reference_rpm per ramp
//                      time; stop ramps down with the PO ramp, rapid stop with a short ramp,
//                      controller inhibit, no hardware enable and faults drop the speed to 0
//   warnings           bit 5 with the drive still ready and running (§3.3: ready 1 / fault 1)
//
// The motor, current and identification values are a model, not measurements.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>

#include "ferrule/core/time.hpp"
#include "ferrule/movilink/constants.hpp"
#include "ferrule/movilink/frame.hpp"
#include "ferrule/movilink/param.hpp"
#include "ferrule/movilink/parameters.hpp"
#include "ferrule/movilink/process_data.hpp"

namespace ferrule::movilink::sim {

using namespace std::chrono_literals;

// The manual's indices (parameters.hpp), under the name the simulator's users know.
namespace parameter_index = movilink::parameter_index;

// P870-P872 choices (movilink.md §3.1).
enum class po_function : std::uint8_t {
    no_function = 0,
    speed = 1,
    current = 2,
    position_lo = 3,
    position_hi = 4,
    max_speed = 5,
    max_current = 6,
    slip = 7,
    ramp = 8,
    control_word_1 = 9,
    control_word_2 = 10,
    speed_percent = 11,
    ipos_po_data = 12,
};

// P873-P875 choices (movilink.md §3.1).
enum class pi_function : std::uint8_t {
    no_function = 0,
    speed = 1,
    output_current = 2,
    active_current = 3,
    position_lo = 4,
    position_hi = 5,
    status_word_1 = 6,
    status_word_2 = 7,
    speed_percent = 8,
    ipos_pi_data = 9,
    reserved = 10,
    status_word_3 = 11,
};

struct parameter {
    std::uint16_t index = 0;
    std::uint8_t subindex = 0;
    std::int32_t value = 0; // RAM, in the manual's unit x 10^-conversion
    std::int32_t min = 0;
    std::int32_t max = 0;
    std::int32_t default_value = 0;
    bool read_only = false;
    bool volatile_only = false;   // a live value or RAM-only setting: never in EEPROM
    std::uint8_t quantity = 0xFF; // read scale: PNO quantity index, 0xFF = not specified
    std::int8_t conversion = 0;   // read scale: value x 10^conversion = SI unit
    std::int32_t eeprom = 0;      // what write (0010) stored; RAM after power_cycle()
};

struct movitrac_b_config {
    double ramp_reference_rpm = 1500; // a ramp time is the time from 0 to this speed
    double max_speed_rpm = 3000;      // setpoints are limited to +-max_speed_rpm
    duration rapid_stop_ramp = 200ms; // ramp used on rapid stop (control word bit 1 = 0)
    duration min_ramp = 100ms;        // shorter PO ramps are raised to this (MOVIMOT: 100 ms)
    duration default_ramp = 1s;       // while no PO word is described as ramp
    unsigned param_latency = 0;       // requests before a cyclic service completes
    bool terminal_enable = true;      // hardware enable terminals (movilink.md §3.1)
    double pole_pairs = 2;            // P002 frequency = speed x pole pairs / 60
    double rated_current_a = 4.0;     // I_N, for P009
    double dc_link_voltage_v = 565;   // P008
    std::int32_t heat_sink_temperature_c = 20; // P014 (MLK31 example: 0x14 = 20 degC)
    double magnetising_current_percent = 30;   // output current with the output stage on
    double acceleration_current_percent = 40;  // added while the speed ramps
    // Fault number when P812 expires: MOVIDRIVE's F43 "RS-485 timeout" (not in movilink.md).
    std::uint8_t rs485_timeout_fault = 43;
};

class movitrac_b {
public:
    static constexpr std::size_t parameter_count = 25;

    explicit movitrac_b(const movitrac_b_config& cfg = {}) noexcept
        : cfg_(cfg), params_(factory_parameters()), param_latency_(cfg.param_latency),
          terminal_enable_(cfg.terminal_enable) {
        ramp_ = cfg_.default_ramp;
    }

    // The reply to a request addressed to this drive (same ADR and TYP, SD2). Group and
    // broadcast requests are processed the same way; their reply is not sent.
    telegram handle(const telegram& request, time_point now) noexcept {
        advance(now);
        if (!is_acyclic(request.type)) {
            // The RS-485 timeout watches cyclic types only (movilink.md §1.6).
            cyclic_seen_ = true;
            last_cyclic_ = now;
        }
        const std::size_t words = pd_words(request.type);
        for (std::size_t i = 0; i < words; ++i) po_[i] = request.pd[i];
        if (words > 0 && value_of(parameter_index::p876_po_data_enable) != 0) take_over_po();

        telegram reply{direction::response, request.address, request.type, {}, {}};
        if (has_param(request.type))
            reply.param =
                is_acyclic(request.type) ? execute(request.param) : cyclic_service(request.param);
        for (std::size_t i = 0; i < words; ++i) {
            pi_[i] = process_input(i);
            reply.pd[i] = pi_[i];
        }
        return reply;
    }

    // Runs the motor model up to `now` (earlier times are ignored).
    void advance(time_point now) noexcept {
        if (!before(now_, now)) return;
        const std::int32_t p812 = value_of(parameter_index::p812_rs485_timeout_delay);
        if (p812 > 0 && cyclic_seen_ && fault_ == 0) {
            const time_point trip = latest(now_, last_cyclic_ + std::chrono::milliseconds{p812});
            if (before(trip, now)) {
                integrate(trip - now_);
                now_ = trip;
                cyclic_seen_ = false; // watched again from the next cyclic telegram
                trip_fault(cfg_.rs485_timeout_fault);
            }
        }
        integrate(now - now_);
        now_ = now;
    }

    // A drive fault: fault bit and number in status word 1, output stage off, speed 0.
    // Cleared by a 0 -> 1 edge of the reset bit (movilink.md §3.2, §8.6). Number 1-255.
    void inject_fault(std::uint8_t number) noexcept {
        if (number != 0) trip_fault(number);
    }

    // A warning: bit 5 and the number in status word 1 while the drive stays ready and keeps
    // running (movilink.md §3.3: ready 1 / fault 1 = warning). A fault takes precedence;
    // cleared like a fault by a reset edge. Number 1-255.
    void inject_warning(std::uint8_t number) noexcept { warning_ = number; }

    // RAM values back from EEPROM (live and RAM-only values to their defaults), motor
    // stopped, no fault, process data and handshake state cleared.
    void power_cycle() noexcept {
        movitrac_b fresh(cfg_);
        for (std::size_t i = 0; i < params_.size(); ++i) {
            parameter& p = fresh.params_[i];
            if (!p.volatile_only) p.value = p.eeprom = params_[i].eeprom;
        }
        fresh.param_latency_ = param_latency_;
        fresh.terminal_enable_ = terminal_enable_;
        fresh.now_ = now_;
        fresh.services_ = services_;
        fresh.eeprom_writes_ = eeprom_writes_;
        *this = fresh;
    }

    // Sets a parameter's RAM and EEPROM value as if configured before (no range check).
    bool preset(std::uint16_t index, std::int32_t value, std::uint8_t subindex = 0) noexcept {
        parameter* p = entry(index, subindex);
        if (!p) return false;
        p->value = p->eeprom = value;
        return true;
    }

    void set_param_latency(unsigned requests) noexcept { param_latency_ = requests; }
    void set_terminal_enable(bool on) noexcept {
        terminal_enable_ = on;
        integrate({});
    }

    const parameter* find(std::uint16_t index, std::uint8_t subindex = 0) const noexcept {
        for (const auto& p : params_)
            if (p.index == index && p.subindex == subindex) return &p;
        return nullptr;
    }
    std::span<const parameter> parameters() const noexcept { return params_; }

    double speed_rpm() const noexcept { return speed_; }
    double setpoint_rpm() const noexcept { return setpoint_; }
    duration ramp() const noexcept { return ramp_; }
    double output_current_percent() const noexcept {
        if (!output_stage_on()) return 0;
        return cfg_.magnetising_current_percent +
               (speed_ != target_rpm() ? cfg_.acceleration_current_percent : 0);
    }
    std::uint8_t fault_number() const noexcept { return fault_; }
    std::uint8_t warning_number() const noexcept { return warning_; }
    control_word control() const noexcept { return cw_; }
    status_word status() const noexcept {
        const bool fault = fault_ != 0;
        const std::uint8_t pending = fault ? fault_ : warning_;
        return status_word::make(output_stage_on(), !fault,
                                 value_of(parameter_index::p876_po_data_enable) != 0, pending != 0,
                                 pending != 0 ? pending : unit_status());
    }
    // Parameter services carried out (handshake repeats and "no service" not counted).
    std::uint32_t services_executed() const noexcept { return services_; }
    // Writes that went to EEPROM (SC01 p.31: limited write cycles).
    std::uint32_t eeprom_writes() const noexcept { return eeprom_writes_; }
    const movitrac_b_config& config() const noexcept { return cfg_; }

private:
    using parameter_table = std::array<parameter, parameter_count>;

    static constexpr parameter live(std::uint16_t index, std::int8_t conversion = 0) noexcept {
        constexpr auto lo = std::numeric_limits<std::int32_t>::min();
        constexpr auto hi = std::numeric_limits<std::int32_t>::max();
        return {index, 0, 0, lo, hi, 0, true, true, 0xFF, conversion, 0};
    }
    static constexpr parameter fixed(std::uint16_t index, std::int32_t v) noexcept {
        return {index, 0, v, v, v, v, true, true, 0xFF, 0, v};
    }
    static constexpr parameter setting(std::uint16_t index, std::int32_t min, std::int32_t max,
                                       std::int32_t def, std::uint8_t quantity = 0xFF,
                                       std::int8_t conversion = 0) noexcept {
        return {index, 0, def, min, max, def, false, false, quantity, conversion, def};
    }
    static constexpr parameter pd_word(std::uint16_t index) noexcept {
        return {index, 0, 0, 0, 0xFFFF, 0, true, true, 0xFF, 0, 0};
    }

    // Sorted by index, so "read attribute" can name the next one.
    static constexpr parameter_table factory_parameters() noexcept {
        namespace ix = parameter_index;
        return {{
            fixed(ix::p076_firmware_basic_unit, 18222911), // sim identification values
            fixed(ix::p070_unit_type, 0x07B00015),
            // Factory mapping PO1 control word 1, PO2 speed, PO3 ramp; PI1 status word 1,
            // PI2 speed, PI3 output current (movilink.md §3.1: MOVITRAC B defaults unknown).
            setting(ix::p870_po1_description, 0, 12, 9),
            setting(ix::p871_po2_description, 0, 12, 1),
            setting(ix::p872_po3_description, 0, 12, 8),
            setting(ix::p873_pi1_description, 0, 11, 6),
            setting(ix::p874_pi2_description, 0, 11, 1),
            setting(ix::p875_pi3_description, 0, 11, 2),
            live(ix::p010_inverter_status),
            live(ix::p000_speed, -3),
            live(ix::p002_frequency, -3),
            live(ix::p004_output_current, -3),
            live(ix::p008_dc_link_voltage, -3),
            live(ix::p009_output_current_a, -3),
            live(ix::p014_heat_sink_temperature),
            pd_word(ix::p094_po1_setpoint),
            pd_word(ix::p095_po2_setpoint),
            pd_word(ix::p096_po3_setpoint),
            pd_word(ix::p097_pi1_actual_value),
            pd_word(ix::p098_pi2_actual_value),
            pd_word(ix::p099_pi3_actual_value),
            setting(ix::p810_rs485_address, 0, 99, 0),
            setting(ix::p811_rs485_group_address, 100, 199, 100),
            // 0-650 s in 0.001 s; quantity 4 = time in s, as the manual's read-scale example.
            setting(ix::p812_rs485_timeout_delay, 0, 650000, 0, 4, -3),
            // PO data enable ON, so a fresh drive follows its PO words [sim assumption].
            setting(ix::p876_po_data_enable, 0, 1, 1),
        }};
    }

    parameter* entry(std::uint16_t index, std::uint8_t subindex = 0) noexcept {
        for (auto& p : params_)
            if (p.index == index && p.subindex == subindex) return &p;
        return nullptr;
    }
    std::int32_t value_of(std::uint16_t index) const noexcept { return find(index)->value; }
    void set_live(std::uint16_t index, std::int32_t v) noexcept { entry(index)->value = v; }

    static std::int32_t round_to_int(double x) noexcept {
        return static_cast<std::int32_t>(x < 0 ? x - 0.5 : x + 0.5);
    }
    static double seconds(duration d) noexcept { return std::chrono::duration<double>(d).count(); }

    // --- process data --------------------------------------------------------------------

    // MTB special cases (movilink.md §3.1): control word not described -> ENABLE, no
    // setpoint described -> 0, the same function twice -> the first PO word wins.
    void take_over_po() noexcept {
        namespace ix = parameter_index;
        control_word cw = control_word::enable();
        double setpoint = 0;
        duration ramp = cfg_.default_ramp;
        bool have_cw = false, have_setpoint = false, have_ramp = false;
        for (std::size_t i = 0; i < max_pd_words; ++i) {
            const auto f = static_cast<po_function>(
                value_of(static_cast<std::uint16_t>(ix::p870_po1_description + i)));
            if (f == po_function::control_word_1 && !have_cw) {
                cw = control_word{po_[i]};
                have_cw = true;
            } else if (f == po_function::speed && !have_setpoint) {
                setpoint = digits_to_rpm(po_[i]);
                have_setpoint = true;
            } else if (f == po_function::speed_percent && !have_setpoint) {
                setpoint = digits_to_percent(po_[i]) * cfg_.max_speed_rpm / 100.0;
                have_setpoint = true;
            } else if (f == po_function::ramp && !have_ramp) {
                ramp = std::max<duration>(digits_to_ramp(po_[i]), cfg_.min_ramp);
                have_ramp = true;
            }
        }
        // Reset acts on the 0 -> 1 edge of bit 6 [UNCERTAIN, movilink.md §8.6].
        if (cw.reset() && !cw_.reset()) fault_ = warning_ = 0;
        cw_ = cw;
        setpoint_ = std::clamp(setpoint, -cfg_.max_speed_rpm, cfg_.max_speed_rpm);
        ramp_ = ramp;
        integrate({});
    }

    std::uint16_t process_input(std::size_t i) const noexcept {
        const auto f = static_cast<pi_function>(
            value_of(static_cast<std::uint16_t>(parameter_index::p873_pi1_description + i)));
        switch (f) {
        case pi_function::speed: return rpm_to_digits(speed_);
        case pi_function::output_current: return current_to_digits(output_current_percent());
        case pi_function::status_word_1: return status().value;
        case pi_function::speed_percent:
            return percent_to_digits(speed_ * 100.0 / cfg_.max_speed_rpm);
        default: return 0; // not simulated
        }
    }

    // --- motor model ---------------------------------------------------------------------

    control_word::command command() const noexcept {
        if (fault_ != 0 || !terminal_enable_) return control_word::command::inhibit;
        return cw_.requested();
    }
    bool output_stage_on() const noexcept {
        const auto c = command();
        return c == control_word::command::enable ||
               (c != control_word::command::inhibit && speed_ != 0);
    }
    double target_rpm() const noexcept {
        return command() == control_word::command::enable ? setpoint_ : 0.0;
    }
    std::uint8_t unit_status() const noexcept {
        if (cw_.requested() == control_word::command::inhibit)
            return status_word::unit_status_controller_inhibit;
        if (terminal_enable_ && cw_.requested() == control_word::command::enable)
            return status_word::unit_status_enable;
        return status_word::unit_status_no_enable;
    }

    void integrate(duration dt) noexcept {
        if (!output_stage_on()) {
            speed_ = 0;
            return;
        }
        const double target = target_rpm();
        const duration ramp =
            command() == control_word::command::rapid_stop ? cfg_.rapid_stop_ramp : ramp_;
        if (ramp <= duration::zero()) {
            speed_ = target;
            return;
        }
        const double step = cfg_.ramp_reference_rpm * seconds(dt) / seconds(ramp);
        speed_ =
            speed_ < target ? std::min(target, speed_ + step) : std::max(target, speed_ - step);
    }

    void trip_fault(std::uint8_t number) noexcept {
        fault_ = number;
        speed_ = 0;
    }

    // --- parameter channel ---------------------------------------------------------------

    // Cyclic types: a toggled handshake bit starts a service; until it is done (after
    // param_latency more requests) the drive answers with the previous result, whose
    // handshake bit is the old one (movilink.md §2.3).
    param_channel cyclic_service(const param_channel& request) noexcept {
        if (request.handshake() != job_handshake_) {
            job_handshake_ = request.handshake();
            job_ = request;
            job_wait_ = param_latency_;
            job_running_ = true;
        }
        if (job_running_) {
            if (job_wait_ == 0) {
                result_ = execute(job_);
                job_running_ = false;
            } else {
                --job_wait_;
            }
        }
        return result_;
    }

    param_channel execute(const param_channel& req) noexcept {
        namespace ix = parameter_index;
        param_channel r{
            static_cast<std::uint8_t>(req.management & (mgmt_service_mask | mgmt_handshake)),
            req.subindex, req.index, 0};
        const service s = req.svc();
        if (s == service::none) return r;
        ++services_;
        r.management = static_cast<std::uint8_t>(r.management | mgmt_length_4_bytes);
        const auto fail = [&r](std::uint8_t cls, std::uint8_t code, std::uint16_t add) {
            r.management = static_cast<std::uint8_t>(r.management | mgmt_status_error);
            r.data = error_data(cls, code, add);
            return r;
        };
        constexpr std::uint8_t other = 8; // error class 8, code 0 (movilink.md §2.5)
        if (s > service::read_attribute) return fail(5, 5, 0); // illegal service code
        const bool writing = s == service::write || s == service::write_volatile;
        // Reads ignore the data length (SC01 p.32); writes need 4 bytes (§2.5: class 6 code 8).
        if (writing && req.data_length() != 4) return fail(6, 8, 0);
        refresh_live_values();
        parameter* p = entry(req.index, req.subindex);
        if (!p) return fail(other, 0, 0x10);
        switch (s) {
        case service::read: r.data = static_cast<std::uint32_t>(p->value); break;
        case service::write:
        case service::write_volatile: {
            if (p->read_only) return fail(other, 0, 0x12);
            const auto v = static_cast<std::int32_t>(req.data);
            if (v > p->max) return fail(other, 0, 0x15);
            if (v < p->min) return fail(other, 0, 0x16);
            p->value = v;
            if (s == service::write && !p->volatile_only) {
                p->eeprom = v;
                ++eeprom_writes_;
            }
            // After changing P870-P875, P876 must be set ON again (MTB 5947017867).
            if (req.index >= ix::p870_po1_description && req.index <= ix::p875_pi3_description)
                set_live(ix::p876_po_data_enable, 0);
            r.data = static_cast<std::uint32_t>(v);
            break;
        }
        case service::read_minimum: r.data = static_cast<std::uint32_t>(p->min); break;
        case service::read_maximum: r.data = static_cast<std::uint32_t>(p->max); break;
        case service::read_default: r.data = static_cast<std::uint32_t>(p->default_value); break;
        case service::read_scale:
            // Bytes 4-5 reserved, byte 6 quantity index, byte 7 conversion index (§2.4).
            r.data = (std::uint32_t{p->quantity} << 8) | static_cast<std::uint8_t>(p->conversion);
            break;
        case service::read_attribute: {
            // Bytes 4-5 next available index (0 after the last), bytes 6-7 access attributes:
            // bit 0 write access, bit 1 saved in EEPROM, bit 5 no controller inhibit needed
            // for writing (MTB "read attribute", 5947119499).
            const auto pos = static_cast<std::size_t>(p - params_.data());
            const std::uint16_t next = pos + 1 < params_.size() ? params_[pos + 1].index : 0;
            const std::uint16_t attributes = static_cast<std::uint16_t>(
                (p->read_only ? 0 : 0x21) | (p->volatile_only ? 0 : 0x02));
            r.data = (std::uint32_t{next} << 16) | attributes;
            break;
        }
        default: break;
        }
        return r;
    }

    void refresh_live_values() noexcept {
        namespace ix = parameter_index;
        const double current = output_current_percent();
        set_live(ix::p010_inverter_status, status().value);
        set_live(ix::p000_speed, round_to_int(speed_ * 1000));
        set_live(ix::p002_frequency, round_to_int(speed_ * cfg_.pole_pairs / 60 * 1000));
        set_live(ix::p004_output_current, round_to_int(current * 1000));
        set_live(ix::p008_dc_link_voltage, round_to_int(cfg_.dc_link_voltage_v * 1000));
        set_live(ix::p009_output_current_a,
                 round_to_int(current / 100 * cfg_.rated_current_a * 1000));
        set_live(ix::p014_heat_sink_temperature, cfg_.heat_sink_temperature_c);
        for (std::size_t i = 0; i < max_pd_words; ++i) {
            set_live(static_cast<std::uint16_t>(ix::p094_po1_setpoint + i), po_[i]);
            set_live(static_cast<std::uint16_t>(ix::p097_pi1_actual_value + i), pi_[i]);
        }
    }

    movitrac_b_config cfg_;
    parameter_table params_;
    unsigned param_latency_;
    bool terminal_enable_;

    time_point now_{};
    double speed_ = 0;
    double setpoint_ = 0;
    duration ramp_{};
    control_word cw_{};
    std::uint8_t fault_ = 0;
    std::uint8_t warning_ = 0;
    std::array<std::uint16_t, max_pd_words> po_{};
    std::array<std::uint16_t, max_pd_words> pi_{};
    bool cyclic_seen_ = false;
    time_point last_cyclic_{};

    bool job_handshake_ = false;
    bool job_running_ = false;
    unsigned job_wait_ = 0;
    param_channel job_{};
    param_channel result_{};
    std::uint32_t services_ = 0;
    std::uint32_t eeprom_writes_ = 0;
};

} // namespace ferrule::movilink::sim
