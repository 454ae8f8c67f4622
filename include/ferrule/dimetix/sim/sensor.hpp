// A simulated Dimetix D-Series sensor (e.g. DAN-10-150), sans-I/O: feed it the host's bytes
// with on_receive(), ask next() what to put on the line and when. For tests (bus.hpp)
// and for ferrule-sim on a pseudo-terminal.
//
//   operation      sNc, sNg, sNh, sNh+t, sNf+t / sNf, sNq, sNm+0/1, sNt, sNre, sNce, sNo
//                  (S1 §8.2); a single measurement answers after measurement_time;
//                  tracking sends a line per max(sampling time, measurement_time) until sNc,
//                  which is answered after `tracking_backlog` already queued lines (dimetix.md
//                  §5); sNq reports the buffer status from the samples taken since the last
//                  sNq (S1 §8.2.6)
//   configuration  get / set of S1 §8.3-8.4 with range checks (@E203), volatile until sNs;
//                  sNd restores the factory values; sNbr takes effect at power_on()
//   information    sNsv, sNsn, sNdt, ID-less dt and dg (S1 §8.5)
//   distance       constant, ramp or sine of time plus deterministic noise; user output
//                  format 0 / 200 / 300 / 301 with offset and gain (S1 §8.4.1-8.4.3)
//   errors         inject_error(code) makes the next measurement fail with gN@Ezzz; the
//                  error stack keeps it, power_on() adds the boot marker 200 (S1 §8.6)
//
// Only requests with its own ID are answered (other IDs are ignored); dt / dg are answered
// whatever the ID. Assumptions where the manual is silent (dimetix.md §11): sNid is
// acknowledged with the old ID and takes effect at once; a command other than sNc during
// continuous output, and sNg / sNh / sNm during buffered tracking, get @E212; the display
// format 1ab is not simulated (@E203); commands during boot_time are not heard; sNA is stored
// but does not start measuring.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <utility>

#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/dimetix/command.hpp"
#include "ferrule/dimetix/constants.hpp"
#include "ferrule/dimetix/line.hpp"
#include "ferrule/dimetix/reply_encoder.hpp"

namespace ferrule::dimetix::sim {

using namespace std::chrono_literals;

enum class profile : std::uint8_t { constant, ramp, sine };

struct d_series_config {
    std::uint8_t id = 0;
    profile shape = profile::constant;
    std::int32_t distance = 12345;           // 0.1 mm: constant value, ramp start, sine centre
    std::int32_t slope = 0;                  // ramp: 0.1 mm per second
    std::int32_t amplitude = 0;              // sine: 0.1 mm
    duration period = 10s;                   // sine
    std::int32_t noise = 0;                  // uniform in ±noise, 0.1 mm
    std::uint32_t seed = 1;                  // of the noise generator
    std::int32_t signal = 8384;              // relative signal strength (S1 §8.4.1 example)
    std::int32_t temperature = 254;          // 0.1 °C
    duration measurement_time = 100ms;       // per value: 0.05…4 s on the real sensor (S1 §4.1)
    duration response_time = 2ms;            // answer delay of commands that do not measure
    duration boot_time = 500ms;              // power_on() to the startup string gN?
    std::int32_t user_output = 0;            // sNuo: 0, 200, 300, 301
    std::int32_t comm_setting = 7;           // sNbr (S1 §8.3.1)
    std::int32_t software_version = 4100121; // gNsv+aaaabbbb, encoding not documented
    std::int32_t serial_number = 12345678;
    unsigned tracking_backlog = 2; // tracking lines still sent after sNc
};

class d_series {
public:
    static constexpr std::size_t queue_capacity = 8;
    static constexpr std::size_t stack_capacity = 8;

    explicit d_series(const d_series_config& cfg = {}) noexcept
        : cfg_(cfg), id_(cfg.id), comm_(cfg.comm_setting), pending_comm_(cfg.comm_setting),
          rng_(cfg.seed ? cfg.seed : 1) {
        factory_settings();
        saved_ = settings_;
    }

    // Power cycle: volatile settings are lost, a new sNbr takes effect, the boot marker 200
    // goes on the error stack and the startup string gN? follows after boot_time (S1 §8.1.5).
    void power_on(time_point now) noexcept {
        if (!powered_) origin_ = now;
        powered_ = true;
        stop_all();
        queue_size_ = 0;
        decoder_.reset();
        settings_ = saved_;
        comm_ = pending_comm_;
        push_error(200);
        ready_at_ = now + cfg_.boot_time;
        booting_.set(now, ready_at_);
        ack(ready_at_);
    }

    // The next measurement answers gN@E<code> instead (e.g. 255: signal too low).
    void inject_error(int code) noexcept { injected_ = code; }

    void on_receive(std::span<const std::uint8_t> bytes, time_point now) noexcept {
        while (!bytes.empty()) {
            const auto step = decoder_.feed(bytes);
            bytes = bytes.subspan(step.consumed);
            if (step.what == line_decoder::status::line) handle(decoder_.line(), now);
        }
    }

    // send: put these bytes on the line now; wait: until the next answer is due; idle.
    session_action next(time_point now) noexcept {
        produce(now);
        if (queue_size_ > 0 && !before(now, queue_[0].due)) {
            const line& l = queue_[0];
            tx_size_ = l.size;
            std::copy(l.text.begin(), l.text.begin() + l.size, tx_.begin());
            std::move(queue_.begin() + 1, queue_.begin() + queue_size_, queue_.begin());
            --queue_size_;
            ++lines_sent_;
            return session_action::send({tx_.data(), tx_size_}, false);
        }
        const time_point t = wake_at();
        return t == never ? session_action::idle() : session_action::wait_until(t);
    }

    // When next() has something to do; `never` when nothing is due.
    time_point wake_at() const noexcept {
        time_point t = queue_size_ > 0 ? scheduled(queue_[0].due) : never;
        if (streaming() && queue_size_ < queue_capacity) t = earliest(t, scheduled(next_sample_));
        return t;
    }

    // The distance the sensor would measure at `t` (0.1 mm, raw, before offset and gain).
    // The profile's time counts from the first power_on() (from time 0 without one), so a
    // sensor on a host clock starts at cfg.distance too.
    std::int32_t distance_at(time_point t) const noexcept {
        const double s = std::chrono::duration<double>(t - origin_).count();
        switch (cfg_.shape) {
        case profile::constant: return cfg_.distance;
        case profile::ramp:
            return cfg_.distance + static_cast<std::int32_t>(std::lround(cfg_.slope * s));
        case profile::sine: {
            const double p = std::chrono::duration<double>(cfg_.period).count();
            return cfg_.distance + static_cast<std::int32_t>(std::lround(
                                       cfg_.amplitude * std::sin(6.283185307179586 * s / p)));
        }
        }
        return cfg_.distance;
    }

    std::uint8_t id() const noexcept { return id_; }
    std::int32_t comm_setting() const noexcept { return comm_; }
    bool laser_on() const noexcept { return laser_; }
    bool tracking() const noexcept { return mode_ != mode::none; }
    std::size_t lines_sent() const noexcept { return lines_sent_; }
    std::size_t requests() const noexcept { return requests_; } // own-ID and ID-less
    std::span<const std::uint16_t> error_stack() const noexcept {
        return {stack_.data(), stack_size_};
    }
    // A configuration value as set (afi / ado: selector = filter / output number).
    std::int32_t setting(std::string_view name, std::size_t index = 0,
                         std::int32_t selector = 0) const noexcept {
        const entry* e = find(name, selector);
        return e && index < e->count ? e->values[index] : 0;
    }

private:
    enum class mode : std::uint8_t { none, tracking, signal, buffered };

    struct line {
        time_point due{};
        std::array<std::uint8_t, max_line_length> text{};
        std::uint8_t size = 0;
    };
    struct entry {
        std::string_view name;
        std::int32_t selector = 0; // afi / ado
        std::array<std::int32_t, 4> values{};
        std::uint8_t count = 0;
        std::uint8_t width = 8; // digits in the get answer
    };
    static constexpr std::size_t settings_count = 23;

    void factory_settings() noexcept {
        // Factory values (S1 §6.6 p.35): Normal characteristic, format 0, gain 1, offset 0,
        // filters off, RS-422/485 active, NPN outputs, 4…20 mA off.
        settings_ = {{
            {"vm", 0, {0}, 1, 1},
            {"ve", 0, {0}, 1, 3},
            {"v", 0, {0, 100000}, 2, 8},
            {"ot", 0, {0}, 1, 1},
            {"1", 0, {0, 0}, 2, 8},
            {"2", 0, {0, 0}, 2, 8},
            {"DI1", 0, {0}, 1, 8},
            {"RI", 0, {0}, 1, 1},
            {"SSI", 0, {0}, 1, 3},
            {"SSIe", 0, {-1}, 1, 8},
            {"mc", 0, {0}, 1, 8},
            {"fi", 0, {0, 0, 0}, 3, 2},
            {"A", 0, {0}, 1, 8},
            {"uo", 0, {cfg_.user_output}, 1, 8},
            {"uof", 0, {0}, 1, 8},
            {"uga", 0, {1, 1}, 2, 8},
            {"um", 0, {0}, 1, 8},
            {"afi", 1, {1, 0}, 2, 8},
            {"afi", 2, {2, 1}, 2, 8},
            {"afi", 3, {3, 0}, 2, 8},
            {"ado", 1, {1, 0, 0, 0}, 4, 8},
            {"ado", 2, {2, 0, 0, 0}, 4, 8},
            {"f", 0, {0}, 1, 8},
        }};
    }

    const entry* find(std::string_view name, std::int32_t selector) const noexcept {
        for (const auto& e : settings_)
            if (e.name == name && e.selector == selector) return &e;
        return nullptr;
    }
    entry* find(std::string_view name, std::int32_t selector) noexcept {
        return const_cast<entry*>(std::as_const(*this).find(name, selector));
    }

    // --- requests ------------------------------------------------------------------------
    void handle(std::span<const std::uint8_t> text, time_point now) noexcept {
        const auto parsed = parse_request(text);
        if (!parsed) {
            if (booting_.holds(now)) return;
            // Only answer garbage that starts with our own ID: `sN` + something unreadable.
            if (addressed_raw(text)) error(203, now + cfg_.response_time);
            return;
        }
        const command& c = *parsed;
        if (c.id != command::no_id && c.id != id_) return;
        if (booting_.holds(now)) return; // still booting: not listening yet
        ++requests_;
        const auto m = c.mnemonic.view();
        const bool stop = m == "c";
        if (!streaming()) queue_size_ = 0; // a new command cancels a measurement (S1 §8.2.2)
        if (!validate(c)) return error(203, now + cfg_.response_time);
        const time_point soon = now + cfg_.response_time;
        const time_point measured = now + cfg_.measurement_time;
        if (streaming() && !stop) return error(212, soon);
        if (mode_ == mode::buffered && (m == "g" || m == "h" || m == "m" || m == "A"))
            return error(212, soon);

        if (stop) {
            if (streaming()) {
                // Lines already in the transmit buffer still go out before the acknowledge.
                for (unsigned k = 0; k < cfg_.tracking_backlog; ++k) emit_stream(now);
            }
            stop_all();
            return ack(soon);
        }
        if (m == "g") return measurement_line("g", measured);
        if (m == "h") {
            mode_ = mode::tracking;
            start_stream(c.param_count ? c.params[0] : 0, now);
            return;
        }
        if (m == "m") {
            if (c.params[0] == 0) {
                if (injected()) return error(take_injected(), measured);
                begin_line();
                out_.put_mnemonic("m");
                out_.put_value(cfg_.signal, 8);
                return finish_line(measured);
            }
            mode_ = mode::signal;
            start_stream(0, now);
            return;
        }
        if (m == "f" && c.param_count == 1) {
            mode_ = mode::buffered;
            interval_ =
                std::max<duration>(std::chrono::milliseconds(c.params[0]), cfg_.measurement_time);
            buffer_start_ = now;
            samples_read_ = 0;
            find("f", 0)->values[0] = c.params[0];
            return set_ack("f", soon);
        }
        if (m == "q") return buffer_line(now, soon);
        if (m == "t") {
            begin_line();
            out_.put_mnemonic("t");
            out_.put_value(cfg_.temperature, 8);
            return finish_line(soon);
        }
        if (m == "re") {
            begin_line();
            out_.put_mnemonic("re");
            if (stack_size_ == 0) out_.put_value(0, 3);
            for (std::size_t i = 0; i < stack_size_; ++i) out_.put_value(stack_[i], 3);
            return finish_line(soon);
        }
        if (m == "ce") {
            stack_size_ = 0;
            return set_ack("ce", soon);
        }
        if (m == "o") {
            laser_ = true;
            return ack(soon);
        }
        if (m == "br") {
            pending_comm_ = c.params[0]; // "activated after power off sequence" (S1 §8.3.1)
            return ack(soon);
        }
        if (m == "id") {
            ack(soon);
            id_ = static_cast<std::uint8_t>(c.params[0]);
            return;
        }
        if (m == "s") {
            saved_ = settings_;
            return set_ack("s", now + cfg_.measurement_time); // flash write
        }
        if (m == "d") {
            // Restores every parameter and writes flash, comm settings included (S1 §8.3.15).
            ack(now + cfg_.measurement_time);
            factory_settings();
            saved_ = settings_;
            id_ = 0;
            pending_comm_ = 7;
            return;
        }
        if (m == "sv") return info("sv", cfg_.software_version, 8, soon);
        if (m == "sn") return info("sn", cfg_.serial_number, 8, soon);
        if (m == "dt") return info("dt", d_series_device_type, 4, soon);
        if (m == "dg") {
            begin_line();
            out_.put_mnemonic("dg");
            out_.put_value(d_series_generation, 3);
            out_.put_value(comm_, 2);
            return finish_line(soon);
        }
        configure(c, soon);
    }

    // Configuration get / set (S1 §8.3-8.4).
    void configure(const command& c, time_point at) noexcept {
        const auto m = c.mnemonic.view();
        const bool selected = m == "afi" || m == "ado";
        const std::int32_t selector = selected && c.param_count > 0 ? c.params[0] : 0;
        entry* e = find(m, selector);
        if (!e) return error(203, at);
        const std::size_t get_params = selected ? 1 : 0;
        if (c.param_count == get_params) {
            begin_line();
            out_.put_mnemonic(m);
            for (std::size_t i = 0; i < e->count; ++i)
                out_.put_value(e->values[i], selected && i == 0 ? 1 : e->width);
            return finish_line(at);
        }
        if (!in_range(c)) return error(203, at);
        for (std::size_t i = 0; i < c.param_count; ++i) e->values[i] = c.params[i];
        begin_line();
        out_.put_mnemonic(m);
        if (selected) out_.put_value(selector, 1);
        out_.put_ack();
        finish_line(at);
    }

    // Ranges of S1 §8.3-8.4 beyond the first-parameter range validate() checks.
    static bool in_range(const command& c) noexcept {
        const auto m = c.mnemonic.view();
        const auto* p = c.params.data();
        if (m == "ve") return p[0] <= 200 || p[0] == 999;
        if (m == "DI1") return p[0] == 0 || p[0] == 2 || p[0] == 3 || p[0] == 4 || p[0] == 8;
        if (m == "fi") // filter length 0 or 2…32; 2·spikes + errors ≤ 0.4·length (S1 §8.3.13)
            return (p[0] == 0 || p[0] >= 2) && p[1] >= 0 && p[2] >= 0 &&
                   5 * (2 * p[1] + p[2]) <= 2 * p[0];
        if (m == "uo") return p[0] == 0 || p[0] == 200 || p[0] == 300 || p[0] == 301;
        if (m == "uga") return p[0] != 0 && p[1] != 0;
        if (m == "um") return p[0] == 0 || p[0] == 2 || p[0] == 5;
        if (m == "afi") return p[0] == 2 ? p[1] >= 1 && p[1] <= 400 : p[1] >= 0;
        if (m == "ado") return p[1] >= 0 && p[1] <= 3 && p[2] >= 0 && p[2] <= 1 && p[3] >= 0;
        return true;
    }

    bool addressed_raw(std::span<const std::uint8_t> text) const noexcept {
        if (text.size() < 2 || text[0] != 's') return false;
        const std::uint8_t a = text[1];
        const std::uint8_t b = text.size() > 2 ? text[2] : 0;
        const bool two = b >= '0' && b <= '9';
        const int id = two ? (a - '0') * 10 + (b - '0') : a - '0';
        return a >= '0' && a <= '9' && id == id_;
    }

    // --- measurements --------------------------------------------------------------------
    bool injected() const noexcept { return injected_ != 0; }
    int take_injected() noexcept {
        const int code = injected_;
        injected_ = 0;
        push_error(code);
        return code;
    }

    std::int32_t measured_at(time_point t) noexcept {
        std::int32_t d = distance_at(t);
        if (cfg_.noise > 0) {
            rng_ ^= rng_ << 13; // xorshift32
            rng_ ^= rng_ >> 17;
            rng_ ^= rng_ << 5;
            d += static_cast<std::int32_t>(rng_ %
                                           (2u * static_cast<std::uint32_t>(cfg_.noise) + 1u)) -
                 cfg_.noise;
        }
        return d;
    }

    // gN<m>+distance[+signal+temperature[+speed]] per sNuo (S1 §8.4.1-8.4.3).
    void measurement_line(std::string_view m, time_point due) noexcept {
        if (injected()) return error(take_injected(), due);
        begin_line();
        out_.put_mnemonic(m);
        put_measurement(due);
        finish_line(due);
    }

    void put_measurement(time_point t) noexcept {
        const std::int32_t format = find("uo", 0)->values[0];
        std::int64_t d = measured_at(t);
        if (format != 0) {
            const entry* gain = find("uga", 0);
            d = (d + find("uof", 0)->values[0]) * gain->values[0] / gain->values[1];
        }
        out_.put_value(static_cast<std::int32_t>(d), 8);
        if (format >= 300) {
            out_.put_value(cfg_.signal, 6);
            out_.put_value(cfg_.temperature, 3);
        }
        if (format == 301) {
            // mm/s from the profile over the last 10 ms: 0.1 mm per 10 ms = 10 mm/s.
            out_.put_value((distance_at(t) - distance_at(t - 10ms)) * 10, 6);
        }
    }

    void buffer_line(time_point now, time_point due) noexcept {
        if (mode_ != mode::buffered) { // S1 §8.2.6: only with tracking with buffering
            begin_line();
            out_.put_error(210);
            out_.put_value(0, 1);
            return finish_line(due);
        }
        const std::int64_t taken =
            before(now, buffer_start_ + cfg_.measurement_time)
                ? 0
                : (now - buffer_start_ - cfg_.measurement_time) / interval_ + 1;
        const std::int64_t fresh = taken - samples_read_;
        samples_read_ = taken;
        const int status = fresh == 0 ? 0 : fresh == 1 ? 1 : 2;
        begin_line();
        if (injected()) {
            out_.put_error(take_injected());
        } else {
            out_.put_mnemonic("q");
            const time_point last =
                buffer_start_ + cfg_.measurement_time + (taken > 0 ? taken - 1 : 0) * interval_;
            out_.put_value(static_cast<std::int32_t>(taken > 0 ? measured_at(last) : 0), 8);
        }
        out_.put_value(status, 1);
        finish_line(due);
    }

    // --- continuous output -----------------------------------------------------------------
    bool streaming() const noexcept { return mode_ == mode::tracking || mode_ == mode::signal; }

    void start_stream(std::int32_t sampling_ms, time_point now) noexcept {
        interval_ =
            std::max<duration>(std::chrono::milliseconds(sampling_ms), cfg_.measurement_time);
        next_sample_ = now + cfg_.measurement_time;
    }

    // Queues the stream lines that are due by `now` while there is room (a full queue is a
    // full transmit buffer: the sensor waits).
    void produce(time_point now) noexcept {
        while (streaming() && !before(now, next_sample_) && queue_size_ < queue_capacity) {
            emit_stream(next_sample_);
        }
    }

    void emit_stream(time_point at) noexcept {
        if (queue_size_ == queue_capacity) return;
        if (injected()) {
            error(take_injected(), at);
        } else if (mode_ == mode::signal) {
            begin_line();
            out_.put_mnemonic("m");
            out_.put_value(cfg_.signal, 8);
            finish_line(at);
        } else {
            begin_line();
            out_.put_mnemonic("h");
            put_measurement(at);
            finish_line(at);
        }
        next_sample_ = at + interval_;
    }

    void stop_all() noexcept {
        mode_ = mode::none;
        laser_ = false;
    }

    void push_error(int code) noexcept {
        const std::size_t n = std::min(stack_size_ + 1, stack_capacity);
        std::move_backward(stack_.begin(), stack_.begin() + n - 1, stack_.begin() + n);
        stack_[0] = static_cast<std::uint16_t>(code);
        stack_size_ = n;
    }

    // --- answer text ---------------------------------------------------------------------
    void ack(time_point at) noexcept {
        begin_line();
        out_.put_ack();
        finish_line(at);
    }
    void set_ack(std::string_view m, time_point at) noexcept {
        begin_line();
        out_.put_mnemonic(m);
        out_.put_ack();
        finish_line(at);
    }
    void error(int code, time_point at) noexcept {
        begin_line();
        out_.put_error(code);
        finish_line(at);
    }
    void info(std::string_view m, std::int32_t v, std::size_t width, time_point at) noexcept {
        begin_line();
        out_.put_mnemonic(m);
        out_.put_value(v, width);
        finish_line(at);
    }

    void begin_line() noexcept { out_.begin(id_); }
    void finish_line(time_point due) noexcept {
        if (queue_size_ == queue_capacity) return; // transmit buffer full: dropped
        const auto text = out_.finish();
        line l;
        l.due = due;
        l.size = static_cast<std::uint8_t>(text.size());
        std::copy(text.begin(), text.end(), l.text.begin());
        // Keep the queue in due order (a stop's acknowledge after the queued lines).
        std::size_t at = queue_size_;
        while (at > 0 && before(due, queue_[at - 1].due)) --at;
        std::move_backward(queue_.begin() + at, queue_.begin() + queue_size_,
                           queue_.begin() + queue_size_ + 1);
        queue_[at] = l;
        ++queue_size_;
    }

    time_point origin_{}; // time 0 of the distance profile
    bool powered_ = false;
    d_series_config cfg_;
    std::uint8_t id_;
    std::int32_t comm_;
    std::int32_t pending_comm_;
    std::uint32_t rng_;
    std::array<entry, settings_count> settings_{};
    std::array<entry, settings_count> saved_{};
    mode mode_ = mode::none;
    bool laser_ = false;
    duration interval_{};
    time_point next_sample_{};
    time_point buffer_start_{};
    std::int64_t samples_read_ = 0;
    int injected_ = 0;
    time_point ready_at_{};
    line_hold booting_{}; // power_on() to ready_at_
    std::array<std::uint16_t, stack_capacity> stack_{};
    std::size_t stack_size_ = 0;
    line_decoder decoder_{};
    reply_encoder out_{};
    std::array<line, queue_capacity> queue_{};
    std::size_t queue_size_ = 0;
    std::array<std::uint8_t, max_line_length> tx_{};
    std::size_t tx_size_ = 0;
    std::size_t lines_sent_ = 0;
    std::size_t requests_ = 0;
};

} // namespace ferrule::dimetix::sim
