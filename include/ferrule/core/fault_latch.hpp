// fault_latch: what a master keeps across its transactions to decide, after a failed
// attempt, whether to send again: retries are left, the failure may be retried, and no fault
// is latched. `fault_threshold` failed attempts in a row latch the fault (DESIGN.md; the
// MOVILINK paper: resend after a timeout, 5 errors in a row -> fault); a success clears the
// count, reset_fault() the latch. A master refuses to start while it is latched.
#pragma once

namespace ferrule {

class fault_latch {
public:
    // Attempt `attempts` (1 for the first send) failed: true when it is to be sent again.
    constexpr bool retry(unsigned attempts, unsigned retries, unsigned fault_threshold,
                         bool may_retry = true) noexcept {
        ++consecutive_failures_;
        if (fault_threshold != 0 && consecutive_failures_ >= fault_threshold) latched_ = true;
        return !latched_ && may_retry && attempts <= retries;
    }
    constexpr void succeeded() noexcept { consecutive_failures_ = 0; }

    constexpr bool fault_latched() const noexcept { return latched_; }
    constexpr unsigned consecutive_failures() const noexcept { return consecutive_failures_; }
    constexpr void reset_fault() noexcept {
        latched_ = false;
        consecutive_failures_ = 0;
    }

private:
    unsigned consecutive_failures_ = 0;
    bool latched_ = false;
};

// The same interface for a master that keeps no latch, where a firmware image has no byte to
// spare: a failed attempt is sent again while retries are left, and nothing ever latches.
class no_fault_latch {
public:
    constexpr bool retry(unsigned attempts, unsigned retries, unsigned,
                         bool may_retry = true) noexcept {
        return may_retry && attempts <= retries;
    }
    constexpr void succeeded() noexcept {}

    constexpr bool fault_latched() const noexcept { return false; }
    constexpr unsigned consecutive_failures() const noexcept { return 0; }
    constexpr void reset_fault() noexcept {}
};

} // namespace ferrule
