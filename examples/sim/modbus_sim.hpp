// ferrule-sim modbus: simulated VFDs (modbus::sim::vfd) served on a pty (Modbus RTU) by the
// pty server's thread and over TCP by an asio thread. One mutex keeps the two off a drive
// at the same time.
#pragma once

#include <cstdint>
#include <mutex>
#include <span>
#include <string_view>

#include "ferrule/core/session.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/host/serial_stream.hpp"
#include "ferrule/modbus/data_model.hpp"
#include "ferrule/modbus/sim/station.hpp"

namespace ferrule::sim_app {

namespace mb = ferrule::modbus;

// A station for pty_server: modbus::sim::station under the shared lock.
struct locked_station {
    mb::sim::station station;
    std::mutex* lock;

    locked_station(const mb::server_config& cfg, std::mutex& m) : station(cfg), lock(&m) {}

    void on_receive(std::span<const std::uint8_t> bytes, time_point end) {
        const std::lock_guard guard(*lock);
        station.on_receive(bytes, end);
    }
    // The reply's bytes live in the station's session, which only the pty thread touches.
    session_action next(time_point now) {
        const std::lock_guard guard(*lock);
        return station.next(now);
    }
    time_point wake_at() const {
        const std::lock_guard guard(*lock);
        return station.wake_at();
    }
};
static_assert(station<locked_station>);

// One station's drive as the TCP server's data model: the speed model runs up to each
// request, as the station's does on the pty.
class locked_vfd {
public:
    locked_vfd(mb::sim::vfd& drive, std::mutex& m) : drive_(&drive), lock_(&m) {}

    std::uint8_t read_bits(mb::function fc, std::uint16_t a, std::uint16_t q,
                           std::span<std::uint8_t> out) {
        const std::lock_guard guard(*lock_);
        drive_->advance(host::steady_now());
        return drive_->read_bits(fc, a, q, out);
    }
    std::uint8_t read_registers(mb::function fc, std::uint16_t a, std::uint16_t q,
                                std::span<std::uint8_t> out) {
        const std::lock_guard guard(*lock_);
        drive_->advance(host::steady_now());
        return drive_->read_registers(fc, a, q, out);
    }
    std::uint8_t write_coils(std::uint16_t a, std::uint16_t q, std::span<const std::uint8_t> in) {
        const std::lock_guard guard(*lock_);
        drive_->advance(host::steady_now());
        return drive_->write_coils(a, q, in);
    }
    std::uint8_t write_registers(std::uint16_t a, std::uint16_t q,
                                 std::span<const std::uint8_t> in) {
        const std::lock_guard guard(*lock_);
        drive_->advance(host::steady_now());
        return drive_->write_registers(a, q, in);
    }
    std::string_view device_id(std::uint8_t id) { return drive_->device_id(id); }

private:
    mb::sim::vfd* drive_;
    std::mutex* lock_;
};

static_assert(mb::data_model<locked_vfd>);

} // namespace ferrule::sim_app
