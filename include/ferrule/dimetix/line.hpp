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

#include "ferrule/core/error.hpp"
#include "ferrule/dimetix/constants.hpp"

namespace ferrule::dimetix {

class line_decoder {
public:
    enum class status : std::uint8_t { need_more, line, error };
    struct step {
        status what = status::need_more;
        std::size_t consumed = 0; // bytes of the input used; feed the rest again
        ferrule::error ec{};
    };

    step feed(std::span<const std::uint8_t> in) noexcept {
        status what = status::need_more;
        std::size_t i = 0;
        line_size_ = 0;
        while (what == status::need_more && i < in.size()) what = push(in[i++]);
        ferrule::error ec{};
        if (what == status::error) ec = errc::malformed;
        return {what, i, ec};
    }

    // The line just yielded, without CR LF (valid until the next feed()).
    std::span<const std::uint8_t> line() const noexcept { return {buf_.data(), line_size_}; }
    // Bytes of an unfinished line are buffered (or an overlong one is being skipped).
    bool in_line() const noexcept { return size_ > 0 || skipping_; }
    // Bytes dropped as parts of malformed or overlong lines, LF included.
    std::size_t skipped() const noexcept { return skipped_; }
    void reset() noexcept {
        size_ = 0;
        line_size_ = 0;
        controls_ = 0;
        skipping_ = false;
    }

private:
    friend class sensor;

    // feed() for one byte, without the error_code (the sensor reads its bytes one by one):
    // status::line or status::error at the LF that ends a line (or at the byte that makes it
    // overlong), else need_more. line() is then the line yielded, empty after an error.
    status push(std::uint8_t b) noexcept {
        if (skipping_) { // the rest of an overlong line, already reported
            ++skipped_;
            skipping_ = b != lf;
            return status::need_more;
        }
        if (b != lf && size_ != buf_.size()) {
            controls_ += b < 0x20 || b > 0x7E;
            buf_[size_++] = b;
            return status::need_more;
        }
        // At the LF a line of printable 7-bit ASCII ended by CR LF (the CR is its only control
        // byte); anything else, or a line longer than any answer can be, is an error, reported
        // once: an overlong line is dropped up to its LF.
        status what = status::line;
        if (b == lf && size_ >= 2 && buf_[size_ - 1] == cr && controls_ == 1) {
            line_size_ = size_ - 1;
        } else {
            skipped_ += size_ + 1;
            skipping_ = b != lf;
            line_size_ = 0;
            what = status::error;
        }
        size_ = 0;
        controls_ = 0;
        return what;
    }

    // The counters first: Thumb code reaches them with short instructions.
    std::size_t size_ = 0;      // of the line being read
    std::size_t line_size_ = 0; // of the line just yielded
    std::size_t skipped_ = 0;
    std::uint8_t controls_ = 0; // bytes of the line outside printable ASCII, CR included
    bool skipping_ = false;
    std::array<std::uint8_t, max_line_length - 1> buf_{}; // everything but the LF
};

} // namespace ferrule::dimetix
