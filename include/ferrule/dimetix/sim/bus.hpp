// A simulated RS-422/485 line with up to N D-Series sensors, as the mock_peer of a
// mock_serial (S1 §5.8: up to 100 devices with distinct IDs on one line).
//
//   * every sensor hears the host's bytes; the addressed one answers when its answer is due
//   * the sensors do not hear each other
//   * fault knobs act on the next k answer lines, whichever sensor sends them: drop the
//     line (the host sees a timeout), flip bits of one byte, or send it later
#pragma once

#include <cstddef>

#include "ferrule/core/station.hpp"
#include "ferrule/dimetix/sim/sensor.hpp"
#include "ferrule/sim/line.hpp"

namespace ferrule::dimetix::sim {

static_assert(ferrule::station<d_series>);

// Fault knobs (drop / corrupt / delay the next replies): see ferrule::reply_faults.
template <std::size_t N>
class bus final : public sim_line<d_series, N> {
public:
    // A sensor on the line; nullptr when all N places are taken.
    d_series* add(const d_series_config& cfg = {}) { return this->place(d_series(cfg)); }

    // Power cycle of every sensor: each sends its startup string gN? (S1 §8.1.5).
    void power_on(time_point now) noexcept {
        for (std::size_t i = 0; i < this->size(); ++i) (*this)[i].power_on(now);
    }
};

} // namespace ferrule::dimetix::sim
