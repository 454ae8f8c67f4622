// pty_server: serves simulated devices on a pseudo-terminal, so a program that opens a
// serial port by path (ferrule's CLI, another library, a terminal) can talk to them with no
// hardware. Several stations (core/station.hpp) on one pty form a multi-drop bus: each hears
// every byte the master writes and answers on its own.
//
// Fault injection for tests and demos: drop or corrupt a share of the replies, delay them.
// A pty has no baud rate: bytes arrive as fast as the master writes them.
#pragma once

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <random>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "ferrule/core/session.hpp"
#include "ferrule/core/station.hpp"
#include "ferrule/core/time.hpp"
#include "ferrule/host/pseudo_terminal.hpp"
#include "ferrule/host/serial_stream.hpp"

namespace ferrule::host {

// A pty moves bytes without wire time. Stations that frame telegrams by idle gaps (MOVILINK)
// reckon the gap before a chunk from its wire time, so on a pty they are configured with
// this rate, at which a telegram's wire time is negligible (11 us per character).
inline constexpr std::uint32_t pty_line_baud = 1'000'000;

struct pty_faults {
    double drop_percent = 0;    // replies never sent
    double corrupt_percent = 0; // replies with one byte's bits flipped
    duration extra_delay{};     // added to every reply
    std::uint32_t seed = 1;     // the same seed, the same faults
};

struct pty_stats {
    std::uint64_t bytes_in = 0;
    std::uint64_t replies = 0;
    std::uint64_t dropped = 0;
    std::uint64_t corrupted = 0;
};

template <station Station>
class pty_server {
public:
    explicit pty_server(pty_faults faults = {}) : faults_(faults), rng_(faults.seed) {}
    pty_server(const pty_server&) = delete;
    pty_server& operator=(const pty_server&) = delete;
    // Creates the pty; path() is then the device to open.
    std::error_code open() { return pty_.open(); }
    // A stable name for the device: a symlink to path() where nothing (or a stale link) is,
    // removed with the server while it is still the server's (pseudo_terminal::link()).
    std::error_code link(const std::string& link_path) { return pty_.link(link_path); }

    const std::string& path() const noexcept { return pty_.path(); }
    void add(Station& station) { stations_.push_back(&station); }
    const pty_stats& stats() const noexcept { return stats_; }

    // Serves until `stop` becomes true (checked at least every 50 ms).
    void run(const std::atomic<bool>& stop) {
        while (!stop.load(std::memory_order_relaxed)) poll_once(std::chrono::milliseconds(50));
    }

    // Waits for bytes at most `max_wait` (less when a reply is due), then serves them.
    void poll_once(duration max_wait) {
        time_point now = steady_now();
        time_point due = now + max_wait;
        for (Station* st : stations_) {
            const session_action a = st->next(now);
            if (a.what == session_action::kind::wait) due = std::min(due, a.deadline);
        }
        pollfd p{pty_.fd(), POLLIN, 0};
        const auto wait_ms = std::chrono::ceil<std::chrono::milliseconds>(due - now).count();
        if (::poll(&p, 1, static_cast<int>(std::max<decltype(wait_ms)>(wait_ms, 0))) > 0 &&
            (p.revents & POLLIN)) {
            std::array<std::uint8_t, 256> buf{};
            const ssize_t n = ::read(pty_.fd(), buf.data(), buf.size());
            if (n > 0) {
                stats_.bytes_in += static_cast<std::uint64_t>(n);
                now = steady_now();
                const std::span<const std::uint8_t> in(buf.data(), static_cast<std::size_t>(n));
                for (Station* st : stations_) st->on_receive(in, now);
            }
        }
        now = steady_now();
        for (Station* st : stations_) {
            const session_action a = st->next(now);
            if (a.what == session_action::kind::send) send(a.bytes);
        }
    }

private:
    void send(std::span<const std::uint8_t> reply) {
        std::uniform_real_distribution<double> percent(0.0, 100.0);
        if (faults_.drop_percent > 0 && percent(rng_) < faults_.drop_percent) {
            ++stats_.dropped;
            return;
        }
        std::vector<std::uint8_t> out(reply.begin(), reply.end());
        if (!out.empty() && faults_.corrupt_percent > 0 &&
            percent(rng_) < faults_.corrupt_percent) {
            out[std::uniform_int_distribution<std::size_t>(0, out.size() - 1)(rng_)] ^= 0x5A;
            ++stats_.corrupted;
        }
        if (faults_.extra_delay > duration::zero())
            ::usleep(static_cast<useconds_t>(
                std::chrono::duration_cast<std::chrono::microseconds>(faults_.extra_delay)
                    .count()));
        if (!pty_.write(out)) return;
        ++stats_.replies;
    }

    pty_faults faults_;
    std::mt19937 rng_;
    pseudo_terminal pty_;
    std::vector<Station*> stations_;
    pty_stats stats_{};
};

} // namespace ferrule::host
