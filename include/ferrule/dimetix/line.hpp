// Dimetix line framing: every answer is 7-bit ASCII text ended by CR LF (S1 §8.1.1 p.40).
//
// line_decoder is fed bytes as they arrive and yields one line at its LF, without the CR LF.
// A line that is not printable ASCII ended by CR LF, or that grows beyond max_line_length,
// is reported once as errc::malformed; the decoder then resynchronises at the next LF.
// It never joins, shortens or invents lines.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <system_error>

#include "ferrule/core/error.hpp"
#include "ferrule/dimetix/constants.hpp"

namespace ferrule::dimetix {

class line_decoder {
public:
    enum class status : std::uint8_t { need_more, line, error };
    struct step {
        status what = status::need_more;
        std::size_t consumed = 0; // bytes of the input used; feed the rest again
        std::error_code ec{};
    };

    step feed(std::span<const std::uint8_t> in) noexcept {
        if (complete_) {
            size_ = 0;
            complete_ = false;
        }
        for (std::size_t i = 0; i < in.size(); ++i) {
            const std::uint8_t b = in[i];
            if (skipping_) { // the rest of an overlong line, already reported
                ++skipped_;
                skipping_ = b != lf;
                continue;
            }
            if (b == lf) {
                if (!bad_ && size_ >= 2 && buf_[size_ - 1] == cr) {
                    --size_;
                    complete_ = true;
                    return {status::line, i + 1, {}};
                }
                return drop(i, false);
            }
            // Printable 7-bit ASCII only, and CR only right before the LF.
            if ((size_ > 0 && buf_[size_ - 1] == cr) || (b < 0x20 && b != cr) || b > 0x7E)
                bad_ = true;
            // Longer than any answer can be: report now, drop up to the next LF.
            if (size_ == buf_.size()) return drop(i, true);
            buf_[size_++] = b;
        }
        return {status::need_more, in.size(), {}};
    }

    // The line just yielded, without CR LF (valid until the next feed()).
    std::span<const std::uint8_t> line() const noexcept {
        return {buf_.data(), complete_ ? size_ : std::size_t{0}};
    }
    // Bytes of an unfinished line are buffered (or an overlong one is being skipped).
    bool in_line() const noexcept { return (!complete_ && size_ > 0) || skipping_; }
    // Bytes dropped as parts of malformed or overlong lines, LF included.
    std::size_t skipped() const noexcept { return skipped_; }
    void reset() noexcept {
        size_ = 0;
        complete_ = false;
        skipping_ = false;
        bad_ = false;
    }

private:
    // The buffered bytes and in[i] are dropped; an overlong line is skipped up to its LF.
    step drop(std::size_t i, bool overlong) noexcept {
        skipped_ += size_ + 1;
        size_ = 0;
        bad_ = false;
        skipping_ = overlong;
        return {status::error, i + 1, errc::malformed};
    }

    std::array<std::uint8_t, max_line_length - 1> buf_{}; // everything but the LF
    std::size_t size_ = 0;
    std::size_t skipped_ = 0;
    bool complete_ = false;
    bool skipping_ = false;
    bool bad_ = false; // a byte that cannot be in an answer
};

} // namespace ferrule::dimetix
