// gateway::sim::rig: a gateway::core between two lines in virtual time, for tests, benchmarks
// and the simulator. The DP master is the session of a mock_serial whose peer is the rig; the
// rig owns the drive line, a second mock_serial with simulated Modbus VFDs on it
// (modbus::sim::bus). Both lines share one time: before the gateway hears DP bytes at `t`,
// the drive line is run up to `t`, and the rig asks the DP line to wake it when the drive
// line needs attention (a reply arriving, a Modbus deadline).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "ferrule/core/error.hpp"
#include "ferrule/core/session.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/gateway/gateway.hpp"
#include "ferrule/modbus/sim/bus.hpp"
#include "ferrule/sim/mock_serial.hpp"

namespace ferrule::gateway::sim {

template <std::size_t Drives = 8>
class rig final : public mock_peer {
public:
    explicit rig(const config& c) noexcept : core_(c), drive_line_(c.modbus.format, &drives_) {}
    rig(const rig&) = delete;
    rig& operator=(const rig&) = delete;

    gateway::core& core() noexcept { return core_; }
    const gateway::core& core() const noexcept { return core_; }
    modbus::sim::bus<Drives>& drives() noexcept { return drives_; }
    mock_serial& drive_line() noexcept { return drive_line_; }

    // --- the DP line's peer -------------------------------------------------------------
    void on_receive(mock_serial&, std::span<const std::uint8_t> bytes, time_point end) override {
        run_drive_line(end);
        core_.on_dp_receive(bytes, end);
        run_drive_line(end); // a command just taken starts now
    }

    time_point wake_at() const noexcept override {
        return earliest(core_.dp_wake_at(), drive_wake_);
    }

    void on_wake(mock_serial& dp_line, time_point now) override {
        run_drive_line(now);
        for (;;) {
            const session_action a = core_.next_dp(now);
            if (a.what != session_action::kind::send) break;
            if (drop_ > 0) {
                --drop_;
                continue;
            }
            dp_line.inject(a.bytes, now);
        }
        run_drive_line(now); // a DP loss just seen starts the safe writes now
    }

    // Runs the drive line alone up to `until` (a DP master that has stopped).
    void run_until(time_point until) { run_drive_line(until); }

    // The next k replies of the gateway on the DP line are lost (the master sees a timeout
    // and repeats its request with the same FCB).
    void drop_dp_replies(unsigned k) noexcept { drop_ = k; }

private:
    void run_drive_line(time_point until) {
        std::array<std::uint8_t, 64> buf{};
        for (;;) {
            const session_action a = core_.next_modbus(drive_line_.now());
            if (a.what == session_action::kind::send) {
                if (a.discard_input) drive_line_.discard_input();
                const io_result w = drive_line_.write(a.bytes);
                if (w.ec) core_.on_modbus_error(w.ec);
                continue;
            }
            if (a.what != session_action::kind::wait) {
                // Bytes that come while no reply is awaited (a late one) still reach the
                // gateway, as from any driver: left on the line, they would wake the rig
                // again and again.
                if (reached(drive_line_.next_arrival(), until)) {
                    const io_result r = drive_line_.read_some(buf, until);
                    if (r.bytes > 0)
                        core_.on_modbus_receive({buf.data(), r.bytes}, drive_line_.now());
                    continue;
                }
                drive_line_.sleep_until(until);
                drive_wake_ = earliest(drives_.wake_at(), drive_line_.next_arrival());
                return;
            }
            const time_point attention =
                earliest(a.deadline, earliest(drives_.wake_at(), drive_line_.next_arrival()));
            if (!before(drive_line_.now(), until) && !reached(attention, drive_line_.now())) {
                drive_wake_ = attention;
                return;
            }
            const io_result r = drive_line_.read_some(buf, earliest(a.deadline, until));
            if (r.bytes > 0)
                core_.on_modbus_receive({buf.data(), r.bytes}, drive_line_.now());
            else if (r.ec && r.ec != errc::timeout)
                core_.on_modbus_error(r.ec); // as host::serve_gateway does
        }
    }

    gateway::core core_;
    modbus::sim::bus<Drives> drives_{};
    mock_serial drive_line_;
    time_point drive_wake_ = never;
    unsigned drop_ = 0;
};

} // namespace ferrule::gateway::sim
